//! `lipmap indices`: the 12 facial indices of a landmark file, or of a session's speaker
//! (neutral frame) and head (neutral pose) with the matching verdict; corpus class bounds.

use crate::cli::new::session_path;
use crate::cli::output::{FormatArgs, write_tables};
use crate::eval::report::{indices_table, verdict_table};
use crate::eval::{Cell, Table};
use crate::io::{bounds_table, landmark_format, obj};
use crate::landmarks::FrameLandmarks;
use crate::math::DVector;
use crate::measure::indices::{BoxPlot, facial_indices_partial, shape_indices_partial};
use crate::measure::mouth::trajectory_from_track;
use crate::measure::mouth::visible_points;
use crate::measure::{
    BoundsTable, FacialIndex, FacialIndices, IndexClass, MatchVerdict, choose_neutral_frame,
    match_speaker_head,
};
use crate::model::LandmarkMap;
use crate::session::Session;
use crate::workflow::Resources;
use anyhow::{Context, Result, anyhow, bail};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Facial indices (×100 distance ratios, issue 6) with their low/middle/high classes.
///
/// On a landmark file: the indices of one frame. On a session: the speaker's indices on a
/// neutral frame, the head's on its neutral pose (the head mesh, else the model's mean,
/// through the landmark map, frontal projection) and the speaker–head verdict.
/// With --compute-bounds: class bounds from many speakers by the box-plot rule.
#[derive(clap::Args, Debug)]
pub struct IndicesArgs {
    /// A session (`NAME` for sessions/NAME.lipmap.json, or a `.lipmap.json` path) or a
    /// landmark file (.pts, OpenFace CSV, dlib XML, lipmap CSV, folder of .pts). With
    /// --compute-bounds: one neutral-frame landmark file (or session) per speaker.
    #[arg(required = true, num_args = 1..)]
    pub inputs: Vec<String>,
    /// Frame to measure (default: a landmark file's first frame; in a session, the frame
    /// with the smallest mouth opening inside a silence interval of the clip's alignment).
    #[arg(long)]
    pub frame: Option<usize>,
    /// Session clip for the speaker (default: the first).
    #[arg(long)]
    pub clip: Option<String>,
    /// Class bounds to use instead of the published ones: CSV with columns index,low,high,
    /// or TOML (`.toml`) with [[bounds]] entries index, low, high.
    #[arg(long, value_name = "FILE")]
    pub bounds: Option<PathBuf>,
    /// Compute class bounds from the inputs (one speaker each, ≥ 4) with the box-plot rule
    /// (low = Q1, high = Q3) and write them to FILE (`.toml` for TOML, else CSV), for use
    /// with --bounds.
    #[arg(long, value_name = "FILE")]
    pub compute_bounds: Option<PathBuf>,
    #[command(flatten)]
    pub output: FormatArgs,
}

/// What a command-line input names.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum IndicesInput {
    Session(PathBuf),
    Landmarks(PathBuf),
}

/// A `.json` path (no landmark format is JSON) or a name that is not an existing path is a
/// session; any other existing path is a landmark file or folder.
pub fn classify_input(s: &str) -> IndicesInput {
    let p = Path::new(s);
    if s.ends_with(".json") || !p.exists() {
        IndicesInput::Session(session_path(s))
    } else {
        IndicesInput::Landmarks(p.to_path_buf())
    }
}

/// Reads a user bounds table: TOML for `.toml` files, CSV otherwise.
///
/// # Errors
/// Unreadable file; a parse error naming the file and line or field.
pub fn load_bounds(path: &Path) -> Result<BoundsTable> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    Ok(bounds_table::parse_bounds_table(path, &text)?)
}

/// Writes a bounds table in the format [`load_bounds`] reads back.
///
/// # Errors
/// The write failing.
pub fn save_bounds(table: &BoundsTable, path: &Path) -> Result<()> {
    Ok(bounds_table::write_bounds_table(table, path)?)
}

/// The indices of one frame of a landmark file: frame `frame` if given, else the first.
///
/// # Errors
/// Unreadable file, no such frame, or a frame lacking a point the indices need.
pub fn file_indices(path: &Path, frame: Option<usize>) -> Result<(usize, FacialIndices)> {
    let track = landmark_format::read_track(path)?;
    let f = pick_frame(&track.frames, frame).ok_or_else(|| match frame {
        Some(n) => anyhow!("{}: no landmarks for frame {n}", path.display()),
        None => anyhow!("{}: no frames of landmarks", path.display()),
    })?;
    let ix = frame_indices_checked(f)
        .with_context(|| format!("{}: frame {}", path.display(), f.frame))?;
    Ok((f.frame, ix))
}

/// A frame's indices from its visible points; indices needing an occluded point are NaN.
///
/// # Errors
/// When no index at all can be computed.
pub fn frame_indices_checked(frame: &FrameLandmarks) -> Result<FacialIndices> {
    nonempty(facial_indices_partial(&visible_points(frame)))
}

fn nonempty(ix: FacialIndices) -> Result<FacialIndices> {
    if ix.values.iter().all(|v| v.is_nan()) {
        bail!("none of the 12 indices can be computed (index points missing)");
    }
    Ok(ix)
}

/// A note naming the indices left out for lack of points, if any.
pub fn missing_note(ix: &FacialIndices, why: &str) -> Option<String> {
    let missing: Vec<String> =
        FacialIndex::ALL.into_iter().filter(|i| ix.get(*i).is_nan()).map(|i| i.name()).collect();
    (!missing.is_empty()).then(|| format!("not computed ({why}): {}", missing.join(", ")))
}

fn pick_frame(frames: &[FrameLandmarks], frame: Option<usize>) -> Option<&FrameLandmarks> {
    match frame {
        Some(n) => frames.iter().find(|f| f.frame == n),
        None => frames.first(),
    }
}

/// How the speaker's neutral frame was chosen.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum NeutralChoice {
    /// Given with --frame.
    User,
    /// Smallest mouth opening inside a silence interval.
    Silence,
    /// No silence frame had a measure: smallest opening over the whole clip.
    WholeClip,
}

/// A speaker's neutral frame and its indices.
#[derive(Clone, Debug, PartialEq)]
pub struct SpeakerNeutral {
    pub clip: String,
    pub frame: usize,
    pub choice: NeutralChoice,
    pub indices: FacialIndices,
}

impl SpeakerNeutral {
    /// A one-line account of where the speaker's indices come from.
    pub fn describe(&self) -> String {
        let how = match self.choice {
            NeutralChoice::User => "chosen with --frame",
            NeutralChoice::Silence => "smallest mouth opening inside silence",
            NeutralChoice::WholeClip => {
                "smallest mouth opening over the clip (no silence frame with landmarks)"
            }
        };
        format!("speaker: clip `{}`, neutral frame {} ({how})", self.clip, self.frame)
    }
}

/// The speaker's indices on the neutral frame of clip `clip` (effective landmarks, i.e.
/// with corrections): frame `frame` when given, else [`choose_neutral_frame`] on the
/// clip's H trajectory and alignment.
///
/// # Errors
/// Unknown clip or frame; no frame with a mouth measure; the frame lacking index points.
pub fn speaker_neutral(
    session: &Session,
    clip: usize,
    frame: Option<usize>,
) -> Result<SpeakerNeutral> {
    let c = session.clip(clip)?;
    let track = session.effective_track(clip)?;
    let (frame, choice) = match frame {
        Some(n) => (n, NeutralChoice::User),
        None => {
            let h = trajectory_from_track(&track, None).h;
            let alignment = c.alignment.clone().unwrap_or_default();
            let n = choose_neutral_frame(&h, &alignment, c.front.fps).ok_or_else(|| {
                anyhow!("clip `{}`: no frame has a mouth measure to choose a neutral frame", c.name)
            })?;
            let choice =
                if n.in_silence { NeutralChoice::Silence } else { NeutralChoice::WholeClip };
            (n.frame, choice)
        }
    };
    let f = pick_frame(&track.frames, Some(frame))
        .ok_or_else(|| anyhow!("clip `{}`: no landmarks for frame {frame}", c.name))?;
    let indices =
        frame_indices_checked(f).with_context(|| format!("clip `{}`, frame {frame}", c.name))?;
    Ok(SpeakerNeutral { clip: c.name.clone(), frame, choice, indices })
}

/// A head's indices on its neutral pose and where that pose came from.
#[derive(Clone, Debug, PartialEq)]
pub struct HeadNeutral {
    pub indices: FacialIndices,
    pub source: String,
}

/// The neutral pose of a head, flat `x0 y0 z0 …`: the head mesh when it has the model's
/// vertex count (it is the face being animated), else the model's mean shape.
pub fn neutral_shape(res: &Resources) -> (DVector, &'static str) {
    match &res.head {
        Some(mesh) if mesh.num_vertices() == res.model.num_vertices() => {
            (mesh.to_flat(), "head mesh")
        }
        _ => (res.model.shape.mean.clone(), "model mean shape"),
    }
}

/// The indices of a loaded head (see [`neutral_shape`]).
///
/// # Errors
/// An index point the landmark map leaves unmapped, or a degenerate shape.
pub fn resources_head_indices(res: &Resources) -> Result<HeadNeutral> {
    let (shape, what) = neutral_shape(res);
    let indices = nonempty(shape_indices_partial(&shape, &res.map))
        .with_context(|| format!("head indices on the {what}"))?;
    Ok(HeadNeutral { indices, source: format!("head: {what}, frontal projection of the map") })
}

/// The head's indices of a session: its head mesh (which needs no model) or its model's
/// mean, through its landmark map.
///
/// # Errors
/// No map; neither head mesh nor model; unreadable files; unmapped index points.
pub fn session_head_indices(session: &Session) -> Result<HeadNeutral> {
    let map: LandmarkMap =
        session.landmark_map.resolve()?.ok_or_else(|| anyhow!(crate::workflow::NO_MAP_MESSAGE))?;
    if session.model.is_some() {
        return resources_head_indices(&Resources::load(session)?);
    }
    let Some(head) = &session.head_mesh else {
        bail!("the session has neither a head mesh nor a model to take the head's indices from");
    };
    let mesh = obj::read_obj(head)?;
    let indices = nonempty(shape_indices_partial(&mesh.to_flat(), &map))
        .with_context(|| format!("head indices on {}", head.display()))?;
    Ok(HeadNeutral { indices, source: format!("head: {}, frontal projection", head.display()) })
}

/// The clip named `name`, or the first.
///
/// # Errors
/// No such clip, or a session without clips.
pub fn clip_or_first(session: &Session, name: Option<&str>) -> Result<usize> {
    match name {
        Some(n) => session.clip_index(n).ok_or_else(|| anyhow!("no clip `{n}` in the session")),
        None if session.clips.is_empty() => bail!("the session has no clips"),
        None => Ok(0),
    }
}

/// The verdict's two checks as a table (so CSV and JSON carry them too, not only the
/// text notes): vertical mouth height classes and narrow-onto-wide mouth width.
pub fn checks_table(verdict: &MatchVerdict) -> Table {
    let headers = ["check", "speaker", "head", "result"];
    let mut t = Table::new("verdict", headers.map(String::from).to_vec());
    let class = |c: Option<IndexClass>| c.map_or(Cell::Empty, |c| Cell::text(c.as_str()));
    let row = |i: FacialIndex| verdict.rows[i.position()];
    let vmh = row(FacialIndex::VerticalMouthHeight);
    let mw = row(FacialIndex::MouthWidth);
    let known = |a: Option<IndexClass>, b: Option<IndexClass>| a.is_some() && b.is_some();
    let result = |ok: bool, warn: bool, what: &str| {
        Cell::text(match (ok, warn) {
            (false, _) => "unknown: index not computed".to_string(),
            (true, true) => format!("warning: {what}"),
            (true, false) => "ok".to_string(),
        })
    };
    let opposite = matches!(
        (vmh.speaker_class, vmh.head_class),
        (Some(IndexClass::Low), Some(IndexClass::High))
            | (Some(IndexClass::High), Some(IndexClass::Low))
    );
    let vmh_known = known(vmh.speaker_class, vmh.head_class);
    t.push_row(vec![
        Cell::text("vertical mouth height classes"),
        class(vmh.speaker_class),
        class(vmh.head_class),
        result(vmh_known, opposite, "low vs high"),
    ]);
    let narrow_on_wide =
        mw.speaker_class == Some(IndexClass::Low) && mw.head_class == Some(IndexClass::High);
    let mw_known = known(mw.speaker_class, mw.head_class);
    t.push_row(vec![
        Cell::text("mouth width (narrow onto wide)"),
        class(mw.speaker_class),
        class(mw.head_class),
        result(mw_known, narrow_on_wide, "narrow onto wide"),
    ]);
    t.notes.push(if !verdict.is_good_match() {
        format!("verdict: {}", crate::cli::output::plural(verdict.warnings.len(), "warning"))
    } else if vmh_known && mw_known {
        "verdict: good match".into()
    } else {
        "verdict: incomplete (an index needed by a check could not be computed)".into()
    });
    t
}

/// The speaker, head and verdict tables of a session.
///
/// # Errors
/// As [`speaker_neutral`] and [`session_head_indices`].
pub fn session_tables(
    session: &Session,
    clip: Option<&str>,
    frame: Option<usize>,
    bounds: &BoundsTable,
) -> Result<Vec<Table>> {
    let c = clip_or_first(session, clip)?;
    let speaker = speaker_neutral(session, c, frame)?;
    let head = session_head_indices(session)?;
    let verdict = match_speaker_head(&speaker.indices, &head.indices, bounds);
    let mut st = indices_table("speaker indices", &speaker.indices, bounds);
    st.notes.push(speaker.describe());
    st.notes.extend(missing_note(&speaker.indices, "points not visible"));
    let mut ht = indices_table("head indices", &head.indices, bounds);
    ht.notes.push(head.source);
    ht.notes.extend(missing_note(&head.indices, "landmarks not mapped to vertices"));
    Ok(vec![st, ht, verdict_table(&verdict), checks_table(&verdict)])
}

/// One speaker's indices for a corpus: a session's neutral frame or a landmark file's frame.
fn corpus_sample(input: &str, frame: Option<usize>, clip: Option<&str>) -> Result<FacialIndices> {
    match classify_input(input) {
        IndicesInput::Landmarks(p) => Ok(file_indices(&p, frame)?.1),
        IndicesInput::Session(p) => {
            let session = Session::load(&p).with_context(|| p.display().to_string())?;
            let c = clip_or_first(&session, clip)?;
            Ok(speaker_neutral(&session, c, frame)?.indices)
        }
    }
}

/// The box plots behind computed bounds, one row per index.
pub fn box_plot_table(table: &BoundsTable, plots: &[BoxPlot]) -> Table {
    let headers = [
        "index",
        "n",
        "low (Q1)",
        "median",
        "high (Q3)",
        "lower whisker",
        "upper whisker",
        "outliers",
    ];
    let mut t = Table::new("computed class bounds", headers.map(String::from).to_vec());
    t.precision = 2;
    for (b, p) in table.bounds.iter().zip(plots) {
        t.push_row(vec![
            Cell::text(b.index.name()),
            Cell::Int(p.n as i64),
            Cell::Num(b.low),
            Cell::Num(p.median),
            Cell::Num(b.high),
            Cell::Num(p.lower_whisker),
            Cell::Num(p.upper_whisker),
            Cell::Int(p.n_outliers as i64),
        ]);
    }
    t.notes
        .push("box-plot rule: quartiles (type 7), whiskers at 1.5 IQR; low = Q1, high = Q3".into());
    t
}

pub fn run(a: &IndicesArgs, out: &mut dyn Write) -> Result<()> {
    if let Some(dest) = &a.compute_bounds {
        let samples = a
            .inputs
            .iter()
            .map(|i| corpus_sample(i, a.frame, a.clip.as_deref()).with_context(|| i.clone()))
            .collect::<Result<Vec<_>>>()?;
        let (table, plots) = BoundsTable::from_corpus(&samples)
            .map_err(|e| anyhow!("computing bounds from {} speakers: {e}", samples.len()))?;
        save_bounds(&table, dest)?;
        let mut t = box_plot_table(&table, &plots);
        t.notes.push(format!("written to {}", dest.display()));
        return write_tables(&[&t], a.output.format(), out);
    }
    let [input] = a.inputs.as_slice() else {
        bail!("give one session or landmark file (several only with --compute-bounds)");
    };
    let bounds = match &a.bounds {
        Some(p) => load_bounds(p)?,
        None => BoundsTable::default(),
    };
    let tables = match classify_input(input) {
        IndicesInput::Landmarks(p) => {
            let (frame, ix) = file_indices(&p, a.frame)?;
            let mut t = indices_table("facial indices", &ix, &bounds);
            t.notes.push(format!("{}, frame {frame}", p.display()));
            t.notes.extend(missing_note(&ix, "points not visible"));
            vec![t]
        }
        IndicesInput::Session(p) => {
            if !p.exists() {
                bail!("{}: no such session or landmark file", p.display());
            }
            let session = Session::load(&p).with_context(|| p.display().to_string())?;
            session_tables(&session, a.clip.as_deref(), a.frame, &bounds)?
        }
    };
    let refs: Vec<&Table> = tables.iter().collect();
    write_tables(&refs, a.output.format(), out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measure::IndexBounds;

    #[test]
    fn json_and_missing_paths_are_sessions() {
        let d = tempfile::tempdir().unwrap();
        let pts = d.path().join("a.pts");
        std::fs::write(&pts, "").unwrap();
        let s = pts.to_str().unwrap();
        assert_eq!(classify_input(s), IndicesInput::Landmarks(pts.clone()));
        assert_eq!(classify_input("demo"), IndicesInput::Session(session_path("demo")));
        let j = d.path().join("x.json");
        std::fs::write(&j, "").unwrap();
        assert_eq!(classify_input(j.to_str().unwrap()), IndicesInput::Session(j.clone()));
    }

    #[test]
    fn checks_say_unknown_when_an_index_is_missing() {
        let bounds = BoundsTable::default();
        let mid = |i: FacialIndex| {
            let (lo, hi) = i.published_bounds();
            0.5 * (lo + hi)
        };
        let speaker = FacialIndices { values: FacialIndex::ALL.map(mid) };
        let mut head = speaker;
        head.values[FacialIndex::MouthWidth.position()] = f64::NAN;
        let t = checks_table(&match_speaker_head(&speaker, &head, &bounds));
        assert_eq!(t.rows[0][3], Cell::text("ok"));
        assert_eq!(t.rows[1][3], Cell::text("unknown: index not computed"));
        assert!(t.notes[0].contains("incomplete"));
        head.values[FacialIndex::VerticalMouthHeight.position()] = 30.0;
        let low = IndexBounds { index: FacialIndex::VerticalMouthHeight, low: 20.0, high: 25.0 };
        let custom = BoundsTable { bounds: vec![low] };
        let t = checks_table(&match_speaker_head(&speaker, &head, &custom));
        assert_eq!(t.rows[0][1], Cell::text("low"));
        assert_eq!(t.rows[0][3], Cell::text("warning: low vs high"));
    }

    #[test]
    fn bounds_files_round_trip_in_both_formats() {
        let d = tempfile::tempdir().unwrap();
        for name in ["b.csv", "b.toml"] {
            let p = d.path().join(name);
            save_bounds(&BoundsTable::default(), &p).unwrap();
            assert_eq!(load_bounds(&p).unwrap(), BoundsTable::default(), "{name}");
        }
    }
}
