//! Facial indices (×100 distance ratios) of a speaker's neutral frame and of a head's
//! neutral pose, the speaker–head match, class bounds files, and the tables showing them.

use super::error::{Context, Error, Result, session_hint};
use super::resources::Resources;
use super::session::{ReadSession, clip_or_first};
use crate::alignment::Alignment;
use crate::eval::report::{indices_table, verdict_table};
use crate::eval::{Cell, Table};
use crate::io::{landmark_format, obj};
use crate::landmarks::{FrameLandmarks, Track};
use crate::math::DVector;
use crate::measure::indices::{BoxPlot, facial_indices_partial, shape_indices_partial};
use crate::measure::mouth::trajectory_from_track;
use crate::measure::mouth::visible_points;
use crate::measure::{
    BoundsTable, FacialIndex, FacialIndices, IndexClass, MatchVerdict, choose_neutral_frame,
    match_speaker_head,
};
use crate::model::{LandmarkMap, MapCheck, MapProblem, Mesh, MorphableModel, check_map};
use crate::session::Session;
use std::path::Path;

/// Reads a user bounds table: TOML for `.toml` files, CSV otherwise.
///
/// # Errors
/// Unreadable file; a parse error naming the file and line or field.
pub fn load_bounds(path: &Path) -> Result<BoundsTable> {
    Ok(crate::io::bounds_table::read_bounds_table(path)?)
}

/// Writes a bounds table in the format [`load_bounds`] reads back.
///
/// # Errors
/// The write failing.
pub fn save_bounds(table: &BoundsTable, path: &Path) -> Result<()> {
    Ok(crate::io::bounds_table::write_bounds_table(table, path)?)
}

/// The indices of one frame of a landmark file: frame `frame` if given, else the first.
///
/// # Errors
/// Unreadable file, no such frame, or a frame lacking a point the indices need.
pub fn file_indices(path: &Path, frame: Option<usize>) -> Result<(usize, FacialIndices)> {
    let track = landmark_format::read_track(path)?;
    let f = pick_frame(&track.frames, frame).ok_or_else(|| match frame {
        Some(n) => Error::Invalid(format!("{}: no landmarks for frame {n}", path.display())),
        None => Error::Invalid(format!("{}: no frames of landmarks", path.display())),
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
        return Err(Error::Invalid(
            "none of the 12 indices can be computed (index points missing)".into(),
        ));
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
    let alignment = c.alignment.clone().unwrap_or_default();
    speaker_neutral_of(&c.name, &track, &alignment, c.front.fps, frame)
}

/// [`speaker_neutral`] on a clip's parts as a front holds them: its name, effective
/// landmarks, alignment and frame rate.
///
/// # Errors
/// As [`speaker_neutral`].
pub fn speaker_neutral_of(
    name: &str,
    track: &Track,
    alignment: &Alignment,
    fps: f64,
    frame: Option<usize>,
) -> Result<SpeakerNeutral> {
    let (frame, choice) = match frame {
        Some(n) => (n, NeutralChoice::User),
        None => {
            let h = trajectory_from_track(track, None).h;
            let n = choose_neutral_frame(&h, alignment, &crate::reference::current().phones, fps)
                .ok_or_else(|| {
                Error::Invalid(format!(
                    "clip `{name}`: no frame has a mouth measure to choose a neutral frame"
                ))
            })?;
            let choice =
                if n.in_silence { NeutralChoice::Silence } else { NeutralChoice::WholeClip };
            (n.frame, choice)
        }
    };
    let f = pick_frame(&track.frames, Some(frame))
        .ok_or_else(|| Error::Invalid(format!("clip `{name}`: no landmarks for frame {frame}")))?;
    let indices =
        frame_indices_checked(f).with_context(|| format!("clip `{name}`, frame {frame}"))?;
    Ok(SpeakerNeutral { clip: name.to_string(), frame, choice, indices })
}

/// A head's indices on its neutral pose and where that pose came from.
#[derive(Clone, Debug, PartialEq)]
pub struct HeadNeutral {
    pub indices: FacialIndices,
    pub source: String,
    /// The map checked on the head's neutral pose: the verdict is withheld when it makes
    /// the head's own indices untrustworthy ([`withholds_verdict`]).
    pub check: MapCheck,
}

/// Whether a map check makes the head's indices untrustworthy: eye/mouth proportions
/// outside the human range, landmarks sharing a vertex, or left and right swapped.
pub fn withholds_verdict(check: &MapCheck) -> bool {
    check.problems.iter().any(|p| {
        matches!(
            p,
            MapProblem::Proportion { .. }
                | MapProblem::SharedVertex { .. }
                | MapProblem::PairSwapped { .. }
        )
    })
}

/// The head's vertices of a flat shape, for the map check.
fn shape_points(shape: &DVector) -> Vec<crate::math::Point3> {
    shape.as_slice().chunks_exact(3).map(|c| crate::math::Point3::new(c[0], c[1], c[2])).collect()
}

/// The neutral pose of a head, flat `x0 y0 z0 …`: the head mesh when it has the model's
/// vertex count (it is the face being animated), else the model's mean shape.
pub fn neutral_shape(model: &MorphableModel, head: Option<&Mesh>) -> (DVector, &'static str) {
    match head {
        Some(mesh) if mesh.num_vertices() == model.num_vertices() => (mesh.to_flat(), "head mesh"),
        _ => (model.shape.mean.clone(), "model mean shape"),
    }
}

/// The indices of a loaded head (see [`neutral_shape`]) through `map`.
///
/// # Errors
/// An index point the landmark map leaves unmapped, or a degenerate shape.
pub fn head_indices(
    model: &MorphableModel,
    map: &LandmarkMap,
    head: Option<&Mesh>,
) -> Result<HeadNeutral> {
    let (shape, what) = neutral_shape(model, head);
    let indices = nonempty(shape_indices_partial(&shape, map))
        .with_context(|| format!("head indices on the {what}"))?;
    let check = check_map(map, &shape_points(&shape));
    Ok(HeadNeutral {
        indices,
        source: format!("head: {what}, frontal projection of the map"),
        check,
    })
}

/// [`head_indices`] of loaded resources: a head that is another mesh than the model is read
/// through its own map.
///
/// # Errors
/// As [`head_indices`].
pub fn resources_head_indices(res: &Resources) -> Result<HeadNeutral> {
    match (&res.head, &res.head_map) {
        (Some(mesh), Some(map)) => mesh_indices(mesh, map, OWN_MAP_HEAD),
        _ => head_indices(&res.model, &res.map, res.head.as_ref()),
    }
}

/// The indices of `mesh` as it is, through `map`.
fn mesh_indices(mesh: &Mesh, map: &LandmarkMap, what: &str) -> Result<HeadNeutral> {
    let indices = nonempty(shape_indices_partial(&mesh.to_flat(), map))
        .with_context(|| format!("head indices on the {what}"))?;
    Ok(HeadNeutral {
        indices,
        source: format!("head: {what}, frontal projection"),
        check: check_map(map, &mesh.vertices),
    })
}

/// The head's indices of a session: its head mesh (which needs no model) or its model's
/// mean, through its landmark map.
///
/// # Errors
/// No map; neither head mesh nor model; unreadable files; unmapped index points.
pub fn session_head_indices(session: &Session) -> Result<HeadNeutral> {
    if let (Some(head), Some(r)) = (&session.head_mesh, &session.head_map) {
        let map = r
            .resolve()?
            .filter(|m| !m.is_empty())
            .ok_or_else(|| Error::NoHeadMap { head: head.clone(), session: None })?;
        return mesh_indices(&obj::read_obj(head)?, &map, OWN_MAP_HEAD);
    }
    let map: LandmarkMap = session.landmark_map.resolve()?.ok_or(Error::NoMap { session: None })?;
    if session.model.is_some() {
        return resources_head_indices(&Resources::load(session)?);
    }
    let Some(head) = &session.head_mesh else {
        return Err(Error::Invalid(
            "the session has neither a head mesh nor a model to take the head's indices from"
                .into(),
        ));
    };
    let mesh = obj::read_obj(head)?;
    let indices = nonempty(shape_indices_partial(&mesh.to_flat(), &map))
        .with_context(|| format!("head indices on {}", head.display()))?;
    let check = check_map(&map, &mesh.vertices);
    Ok(HeadNeutral {
        indices,
        source: format!("head: {}, frontal projection", head.display()),
        check,
    })
}

/// The verdict's two checks as a table (so CSV and JSON carry them too, not only the
/// text notes): vertical mouth height classes and narrow-onto-wide mouth width.
pub fn checks_table(verdict: &MatchVerdict) -> Table {
    let headers = ["check", "speaker", "head", "result"];
    let mut t = Table::new("verdict", headers.map(String::from).to_vec()).keyed("verdict");
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
        let n = verdict.warnings.len();
        format!("verdict: {n} warning{}", if n == 1 { "" } else { "s" })
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
    read: &ReadSession,
    clip: Option<&str>,
    frame: Option<usize>,
    bounds: &BoundsTable,
) -> Result<Vec<Table>> {
    let session = &read.session;
    let c = clip_or_first(session, clip)?;
    let speaker = speaker_neutral(session, c, frame)?;
    let head = session_head_indices(session).map_err(|e| e.in_session(&read.path))?;
    Ok(match_tables(&speaker, head, bounds, Some(&read.path)))
}

/// The head a front takes facial indices on, as [`session_head_indices`] chooses it: a head
/// that is another mesh than the model through its own map, else the model (its head mesh
/// when of the model's topology, else its mean) through the model map.
#[derive(Clone, Copy, Debug)]
pub enum IndexHead<'a> {
    /// The model through the model map ([`head_indices`]).
    Model { model: &'a MorphableModel, map: &'a LandmarkMap, head: Option<&'a Mesh> },
    /// A head that is another mesh than the model, through its own map.
    OwnMap { mesh: &'a Mesh, map: &'a LandmarkMap },
}

/// The speaker, head and verdict tables from what a front already holds: the head (see
/// [`IndexHead`]), and the clip's name, effective landmarks (as corrected, lips not sealed:
/// the track `lipmap indices` reads), alignment and frame rate (the speaker's neutral frame
/// chosen as [`speaker_neutral`] does). Nothing is read from disk.
///
/// # Errors
/// As [`speaker_neutral_of`] and [`head_indices`].
pub fn index_tables(
    head: IndexHead<'_>,
    clip: &str,
    track: &Track,
    alignment: &Alignment,
    fps: f64,
    bounds: &BoundsTable,
) -> Result<Vec<Table>> {
    let speaker = speaker_neutral_of(clip, track, alignment, fps, None)?;
    let head = match head {
        IndexHead::Model { model, map, head } => head_indices(model, map, head)?,
        IndexHead::OwnMap { mesh, map } => mesh_indices(mesh, map, OWN_MAP_HEAD)?,
    };
    Ok(match_tables(&speaker, head, bounds, None))
}

/// What the head's indices note says a head with its own map is.
const OWN_MAP_HEAD: &str = "head mesh, its own map";

/// The tables of a speaker against a head; `session` names the session in the hint that
/// withholds the verdict, when known.
fn match_tables(
    speaker: &SpeakerNeutral,
    head: HeadNeutral,
    bounds: &BoundsTable,
    session: Option<&Path>,
) -> Vec<Table> {
    let verdict = match_speaker_head(&speaker.indices, &head.indices, bounds);
    let mut st = indices_table("speaker indices", &speaker.indices, bounds).keyed("speaker");
    st.notes.push(speaker.describe());
    st.notes.extend(missing_note(&speaker.indices, "points not visible"));
    let mut ht = indices_table("head indices", &head.indices, bounds).keyed("head");
    ht.notes.push(head.source);
    ht.notes.extend(missing_note(&head.indices, "landmarks not mapped to vertices"));
    if !head.check.is_plausible() {
        ht.notes.push(head.check.summary());
    }
    if withholds_verdict(&head.check) {
        let mut t = Table::new("verdict", vec!["verdict".to_string()]).keyed("verdict");
        t.push_row(vec![Cell::text("withheld")]);
        t.notes.push(format!(
            "verdict withheld: the head's own indices are implausible ({}); fix the map ({}) first",
            head.check.summary(),
            session_hint("lipmap map check SESSION", session)
        ));
        return vec![st, ht, t];
    }
    vec![st, ht, verdict_table(&verdict).keyed("comparison"), checks_table(&verdict)]
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
    let mut t =
        Table::new("computed class bounds", headers.map(String::from).to_vec()).keyed("bounds");
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measure::IndexBounds;

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
