//! Several heads compared (`lipmap eval SESSION --heads A,B,C`): one speaker's clips fitted
//! onto each head, the W/H(/P) RMSE table per head with paired t-tests, and corresponding vs
//! non-corresponding heads.
//!
//! A head is named on the command line by a path: a session file (`.json`) whose model,
//! landmark map and head mesh are used, a folder holding a model and a landmark map (what
//! `lipmap demo` writes: `model.lmm`, `head_map.toml`, `head.obj`, `poses/`), or a plain OBJ
//! with a landmark map and neither model nor blendshapes: the session's own model is fitted
//! and its motion transferred onto that head ([`super::transfer`]), as `lipmap transfer` does.
//!
//! Start at [`load_heads`] and [`compare_heads`].

use super::error::{Context, Error, Result, Warning};
use super::evaluate::{Normalisation, utterance_of_clip};
use super::indices::{NeutralChoice, SpeakerNeutral, resources_head_indices, speaker_neutral};
use super::resources::{Resources, check_map_vertices};
use super::session::{image_height, read_session};
use super::transfer::transferred_utterance;
use super::transfer::{TargetFiles, default_mapping, load_target, mode_name, set_up_for_head};
use super::{Progress, ProgressFn};
use crate::eval::stats::paired_t_test;
use crate::eval::{Cell, Comparison, Configuration, RowKey, Table, Utterance};
use crate::eval::{compare_configurations, mean_of};
use crate::fit::{FrameFit, fit_clip};
use crate::io::model_source::{ModelSourceKind, detect_model_source, load_model};
use crate::io::{landmark_map_toml, obj};
use crate::measure::indices::shape_indices_partial;
use crate::measure::{
    FacialIndex, FacialIndices, IndexClass, MatchVerdict, Measure, MeshMeasureOptions,
    PoseComparison, match_speaker_head,
};
use crate::session::Session;
use crate::transfer::{Interpolation, Transfer};
use std::path::{Path, PathBuf};

/// A head to map the speaker onto: its display name and what driving it needs.
#[derive(Clone, Debug)]
pub struct Head {
    pub name: String,
    pub path: PathBuf,
    pub kind: HeadKind,
}

/// How a head follows the speaker.
#[derive(Clone, Debug)]
pub enum HeadKind {
    /// Fitted directly: the head has a model and a landmark map of its own.
    Fitted(Resources),
    /// A plain OBJ: the session's model is fitted and its motion transferred onto the head.
    Transferred {
        target: TargetFiles,
        /// The head's landmark map file.
        mapping: PathBuf,
        mode: Interpolation,
    },
}

fn sorted_files(dir: &Path) -> Result<Vec<PathBuf>> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .map_err(|e| Error::io(dir, e).context(format!("reading {}", dir.display())))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.is_file())
        .collect();
    files.sort();
    Ok(files)
}

fn file_name(p: &Path) -> String {
    p.file_name().map_or_else(String::new, |n| n.to_string_lossy().into_owned())
}

/// The model of a head folder: a lipmap model file, else an eos `.bin` (a `*blendshape*`
/// `.bin` beside it is loaded as its expressions), else `.npz`, else the folder itself when
/// it holds `mean.npy`, else `poses/` (PCA of the pose OBJs). Returns (model, blendshapes).
fn head_model_paths(dir: &Path, files: &[PathBuf]) -> Result<(PathBuf, Option<PathBuf>)> {
    let kind = |p: &PathBuf| detect_model_source(p).ok();
    if let Some(p) = files.iter().find(|p| kind(p) == Some(ModelSourceKind::LipmapFile)) {
        return Ok((p.clone(), None));
    }
    let bins: Vec<&PathBuf> =
        files.iter().filter(|p| kind(p) == Some(ModelSourceKind::EosBin)).collect();
    let is_blend = |p: &&PathBuf| file_name(p).to_ascii_lowercase().contains("blendshape");
    if let Some(shape) = bins.iter().find(|p| !is_blend(p)) {
        let blend = bins.iter().find(|p| is_blend(p)).map(|p| (*p).clone());
        return Ok(((*shape).clone(), blend));
    }
    if let Some(p) = files.iter().find(|p| kind(p) == Some(ModelSourceKind::Npz)) {
        return Ok((p.clone(), None));
    }
    if dir.join("mean.npy").is_file() {
        return Ok((dir.to_path_buf(), None));
    }
    let poses = dir.join("poses");
    if poses.is_dir() {
        return Ok((poses, None));
    }
    Err(Error::Invalid(format!(
        "{}: no model (expected a lipmap model file such as model.lmm, an eos .bin, an .npz, \
         mean.npy or a poses/ folder of OBJs)",
        dir.display()
    )))
}

/// The landmark map of a head folder: its only `.toml` file (or the one whose name has
/// `map` in it), else an eos-style `ibug_to_*.txt`.
fn head_map_path(dir: &Path, files: &[PathBuf]) -> Result<PathBuf> {
    let ext = |p: &PathBuf, e: &str| p.extension().is_some_and(|x| x.eq_ignore_ascii_case(e));
    let tomls: Vec<&PathBuf> = files.iter().filter(|p| ext(p, "toml")).collect();
    let chosen = match tomls.as_slice() {
        [one] => Some(*one),
        [] => files.iter().find(|p| ext(p, "txt") && file_name(p).starts_with("ibug_to_")),
        many => {
            let named: Vec<&&PathBuf> =
                many.iter().filter(|p| file_name(p).to_ascii_lowercase().contains("map")).collect();
            match named.as_slice() {
                [one] => Some(**one),
                _ => {
                    return Err(Error::Invalid(format!(
                        "{}: several .toml files and none is clearly the landmark map ({})",
                        dir.display(),
                        many.iter().map(|p| file_name(p)).collect::<Vec<_>>().join(", ")
                    )));
                }
            }
        }
    };
    chosen.cloned().ok_or_else(|| {
        Error::Invalid(format!(
            "{}: no landmark map (a .toml file or ibug_to_*.txt)",
            dir.display()
        ))
    })
}

fn is_obj(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("obj"))
}

/// Loads the head named by `path`: a session file (its model, map and head mesh), a folder
/// with a model, a landmark map and optionally `head.obj` (its neutral pose), or an OBJ
/// file, driven through transfer with `mode` and its landmark map `mapping` (`None`: the
/// map beside it, [`default_mapping`]). `mapping` is refused for any other kind of head.
///
/// # Errors
/// A path that is none of these; a folder lacking a model or map; an OBJ without a map;
/// any file's format error; a map naming vertices the model lacks.
pub fn load_head(path: &Path, mapping: Option<&Path>, mode: Interpolation) -> Result<Head> {
    let name = file_name(path).trim_end_matches(".lipmap.json").to_string();
    if let Some(m) = mapping.filter(|_| !is_obj(path)) {
        return Err(Error::Invalid(format!(
            "{}: a landmark map ({}) is only taken by an OBJ head; this head brings its own",
            path.display(),
            m.display()
        )));
    }
    let resources = if is_obj(path) {
        if !path.is_file() {
            return Err(Error::io(path, std::io::ErrorKind::NotFound.into()));
        }
        let name = path.file_stem().map_or_else(String::new, |s| s.to_string_lossy().into_owned());
        let mapping = match mapping {
            Some(m) => m.to_path_buf(),
            None => default_mapping(path)?,
        };
        let target = load_target(path, &mapping)?;
        let kind = HeadKind::Transferred { target, mapping, mode };
        return Ok(Head { name, path: path.to_path_buf(), kind });
    } else if path.is_dir() {
        let files = sorted_files(path)?;
        let (model_path, blend) = head_model_paths(path, &files)?;
        let map_path = head_map_path(path, &files)?;
        let model = load_model(&model_path, blend.as_deref())?;
        let map = landmark_map_toml::read_landmark_map(&map_path)?;
        check_map_vertices(&map, model.num_vertices(), Some(&map_path))?;
        let head_obj = path.join("head.obj");
        let head = head_obj.is_file().then(|| obj::read_obj(&head_obj)).transpose()?;
        Resources { model, map, head, head_map: None, accept_map_warnings: false }
    } else if path.is_file() && file_name(path).ends_with(".json") {
        // A head's session is only read: its journal's map edits count, nothing is saved.
        let session = read_session(path)?.session;
        Resources::load(&session).with_context(|| path.display().to_string())?
    } else {
        return Err(Error::Invalid(format!(
            "{}: a head is a folder with a model and a landmark map, a session file, or an OBJ \
             with a landmark map",
            path.display()
        )));
    };
    Ok(Head { name, path: path.to_path_buf(), kind: HeadKind::Fitted(resources) })
}

/// Loads every head, making repeated names unique (`b`, `b#2`). The OBJ heads take the
/// landmark maps of `mappings` in order; those beyond its end take the session's head map
/// when they are the session's head (`session`, see
/// [`super::transfer::session_head_map_file`]), else the map beside them.
///
/// # Errors
/// More maps than OBJ heads; as [`load_head`], naming the head.
pub fn load_heads(
    paths: &[PathBuf],
    mappings: &[PathBuf],
    mode: Interpolation,
    session: Option<&crate::session::Session>,
) -> Result<Vec<Head>> {
    let objs = paths.iter().filter(|p| is_obj(p)).count();
    if mappings.len() > objs {
        return Err(Error::Invalid(format!(
            "{} landmark maps given for {objs} OBJ heads (each map goes with an OBJ head, in order)",
            mappings.len()
        )));
    }
    let mut maps = mappings.iter().peekable();
    let mut heads: Vec<Head> = Vec::new();
    for p in paths {
        let named = |e: Error| {
            // An error that starts with the head's path names it already.
            if e.to_string().starts_with(&p.display().to_string()) {
                e
            } else {
                e.context(format!("head {}", p.display()))
            }
        };
        let mapping = match (is_obj(p), maps.next_if(|_| is_obj(p)), session) {
            (true, Some(m), _) => Some(m.clone()),
            (true, None, Some(s)) => super::transfer::session_head_map_file(s, p).map_err(named)?,
            _ => None,
        };
        let mut h = load_head(p, mapping.as_deref(), mode).map_err(named)?;
        let base = if h.name.is_empty() { "head".to_string() } else { h.name.clone() };
        h.name = base.clone();
        let mut k = 1;
        while heads.iter().any(|o| o.name == h.name) {
            k += 1;
            h.name = format!("{base}#{k}");
        }
        heads.push(h);
    }
    Ok(heads)
}

/// What drives one head in a comparison, ready to run: its own model, or the session's
/// model with the transfer onto the head set up.
#[derive(Debug)]
pub enum Driver<'a> {
    Fitted(&'a Resources),
    /// The set-up is boxed: it is large, and most heads in a comparison are fitted.
    Transferred {
        source: &'a Resources,
        transfer: Box<Transfer>,
        target: &'a TargetFiles,
    },
}

impl<'a> Driver<'a> {
    /// Sets up what `head` needs; `source` (the session's resources) drives OBJ heads.
    ///
    /// # Errors
    /// An OBJ head without `source`; the transfer's setup errors, naming the head file.
    pub fn new(head: &'a Head, source: Option<&'a Resources>) -> Result<Self> {
        match &head.kind {
            HeadKind::Fitted(res) => Ok(Self::Fitted(res)),
            HeadKind::Transferred { target, mode, .. } => {
                let source = source.ok_or(Error::NoModel)?;
                let transfer = Box::new(set_up_for_head(source, target, *mode, &head.path)?);
                Ok(Self::Transferred { source, transfer, target })
            }
        }
    }

    /// The resources the clips are fitted with.
    fn fitted(&self) -> &Resources {
        match self {
            Self::Fitted(res) | Self::Transferred { source: res, .. } => res,
        }
    }

    /// The clip measured on the driven head: the fitted model's own measures, or those of
    /// the transferred head compared as `pose` says (as the model's were).
    fn measure(&self, u: Utterance, fits: &[FrameFit], pose: PoseComparison) -> Result<Utterance> {
        match self {
            Self::Fitted(_) => Ok(u),
            Self::Transferred { source, transfer, target } => {
                transferred_utterance(source, transfer, &target.map, &u, fits, pose)
            }
        }
    }
}

/// The session's clips fitted with `driver`'s model and the session's fit settings and
/// measured on the head it drives, W/H compared with the video as `pose` says, and what was
/// worked around. The fits are not cached: the
/// session's cache is keyed to its own model and map. Progress: one stage per clip.
///
/// # Errors
/// Unknown clip; unreadable frames when the clip's image size is not recorded; a fitted
/// shape the transfer refuses.
pub fn head_utterances(
    session: &Session,
    name: &str,
    driver: &Driver<'_>,
    clips: &[usize],
    pose: PoseComparison,
    progress: ProgressFn<'_>,
) -> Result<(Vec<Utterance>, Vec<Warning>)> {
    let settings = &session.fit_settings;
    let res = driver.fitted();
    let mut utterances = Vec::new();
    let mut warnings = Vec::new();
    for &c in clips {
        // The landmarks `fit` and `eval` fit (sealed lips closed when the settings say so),
        // so a head compared here is driven by the motion `eval` measures.
        let track = session.fit_input_track(c, settings)?;
        let height = image_height(session, c)?;
        let total = track.frames.len();
        let what = format!("{} onto {name}", session.clip(c)?.name);
        progress(Progress::Stage { what, total });
        let report = |done: usize| progress(Progress::Steps { done, total });
        let fits = fit_clip(&res.model, &res.map, &track.frames, height, settings, Some(&report));
        let (u, w) =
            utterance_of_clip(session, res, c, &fits, &MeshMeasureOptions::default(), pose)?;
        utterances.push(driver.measure(u, &fits, pose)?);
        warnings.extend(w);
    }
    progress(Progress::Finished);
    Ok((utterances, warnings))
}

/// The facial indices of a head on its neutral pose: the model's (see
/// [`resources_head_indices`]) or, for an OBJ head, the mesh as it is.
///
/// # Errors
/// No index can be computed from the head's map.
fn head_neutral_indices(head: &Head) -> Result<FacialIndices> {
    match &head.kind {
        HeadKind::Fitted(res) => Ok(resources_head_indices(res)?.indices),
        HeadKind::Transferred { target, .. } => {
            let ix = shape_indices_partial(&target.mesh.to_flat(), &target.map);
            if ix.values.iter().all(|v| v.is_nan()) {
                return Err(Error::Invalid(format!(
                    "{}: none of the 12 indices can be computed (index points unmapped)",
                    head.path.display()
                )));
            }
            Ok(ix)
        }
    }
}

/// A head's match with the speaker: the verdict when both sides' indices could be taken.
#[derive(Clone, Debug)]
pub struct HeadMatch {
    pub head: String,
    pub verdict: Result<MatchVerdict, String>,
}

impl HeadMatch {
    /// Same vertical-mouth-height class as the speaker (the thesis's "corresponding" head);
    /// `None` when a class is unknown.
    pub fn corresponding(&self) -> Option<bool> {
        let v = self.verdict.as_ref().ok()?;
        let r = v.rows[FacialIndex::VerticalMouthHeight.position()];
        Some(r.speaker_class? == r.head_class?)
    }
}

/// One row per head: its vertical mouth height, both classes, correspondence and warnings.
pub fn match_table(matches: &[HeadMatch], speaker: Option<&SpeakerNeutral>) -> Table {
    let headers = [
        "head",
        "vertical mouth height",
        "head class",
        "speaker class",
        "corresponding",
        "mouth width",
        "warnings",
    ];
    let mut t =
        Table::new("speaker-head match", headers.map(String::from).to_vec()).keyed("matches");
    t.precision = 2;
    let class = |c: Option<IndexClass>| c.map_or(Cell::Empty, |c| Cell::text(c.as_str()));
    for m in matches {
        let mut row = vec![Cell::text(&m.head)];
        match &m.verdict {
            Ok(v) => {
                let vmh = v.rows[FacialIndex::VerticalMouthHeight.position()];
                let mw = v.rows[FacialIndex::MouthWidth.position()];
                let warnings: Vec<String> = v.warnings.iter().map(ToString::to_string).collect();
                row.extend([
                    Cell::num(Some(vmh.head)),
                    class(vmh.head_class),
                    class(vmh.speaker_class),
                    m.corresponding()
                        .map_or(Cell::Empty, |c| Cell::text(if c { "yes" } else { "no" })),
                    Cell::num(Some(mw.head)),
                    Cell::text(if warnings.is_empty() {
                        "none".into()
                    } else {
                        warnings.join("; ")
                    }),
                ]);
            }
            Err(e) => {
                row.extend([Cell::Empty, Cell::Empty, Cell::Empty, Cell::Empty, Cell::Empty]);
                row.push(Cell::text(format!("indices unavailable: {e}")));
            }
        }
        t.push_row(row);
    }
    if let Some(s) = speaker {
        let v = s.indices.get(FacialIndex::VerticalMouthHeight);
        t.notes.push(format!("{}; vertical mouth height {v:.2}", s.describe()));
        if s.choice == NeutralChoice::WholeClip {
            t.notes.push("note: no silence frame had landmarks; neutral frame may be poor".into());
        }
    }
    t.notes
        .push("corresponding: the head's vertical mouth height class equals the speaker's".into());
    t
}

/// Corresponding vs non-corresponding heads: per row (sentence) the mean RMSE over each
/// group's heads, the means, and a paired t-test (non-corresponding − corresponding).
/// `None` unless both groups have a head.
pub fn correspondence_table(comparison: &Comparison, matches: &[HeadMatch]) -> Option<Table> {
    let group = |want: bool| -> Vec<usize> {
        matches
            .iter()
            .enumerate()
            .filter(|(_, m)| m.corresponding() == Some(want))
            .map(|(i, _)| i)
            .collect()
    };
    let (corr, non) = (group(true), group(false));
    if corr.is_empty() || non.is_empty() {
        return None;
    }
    let measures = &comparison.measures;
    let mut headers = vec!["sentence".to_string()];
    for g in ["corresponding", "non-corresponding"] {
        headers.extend(measures.iter().map(|m| format!("{g} {m}")));
    }
    let mut t =
        Table::new("corresponding vs non-corresponding heads", headers).keyed("correspondence");
    let group_mean = |row: usize, heads: &[usize], m: Measure| {
        mean_of(heads.iter().map(|&h| comparison.values[row][h].get(m)))
    };
    // Per measure, the per-row group means (paired by row).
    let mut cols: Vec<Vec<Option<f64>>> = Vec::new();
    for heads in [&corr, &non] {
        for &m in measures {
            cols.push((0..comparison.row_labels.len()).map(|r| group_mean(r, heads, m)).collect());
        }
    }
    for (r, label) in comparison.row_labels.iter().enumerate() {
        let mut row = vec![Cell::text(label)];
        row.extend(cols.iter().map(|c| Cell::num(c[r])));
        t.push_row(row);
    }
    let mut mean = vec![Cell::text("mean")];
    mean.extend(cols.iter().map(|c| Cell::num(mean_of(c.iter().copied()))));
    t.push_row(mean);
    let mut p = vec![Cell::text("p (paired t-test)")];
    p.extend(measures.iter().map(|_| Cell::Empty));
    let k = measures.len();
    for j in 0..k {
        let (a, b): (Vec<f64>, Vec<f64>) =
            cols[k + j].iter().zip(&cols[j]).filter_map(|(n, c)| Some(((*n)?, (*c)?))).unzip();
        p.push(Cell::num(paired_t_test(&a, &b).map(|t| t.p)));
    }
    t.push_row(p);
    let names =
        |g: &[usize]| g.iter().map(|&i| matches[i].head.as_str()).collect::<Vec<_>>().join(", ");
    t.notes.push(format!(
        "corresponding heads: {}; non-corresponding: {}",
        names(&corr),
        names(&non)
    ));
    t.notes.push(
        "p: two-sided paired t-test over sentences, non-corresponding against corresponding".into(),
    );
    Some(t)
}

/// The tables of a several-heads comparison and what was worked around.
#[derive(Clone, Debug)]
pub struct HeadsReport {
    /// RMSE by head (t-tests against the first), the speaker–head match per head and, when
    /// both kinds are present, corresponding vs non-corresponding heads.
    pub tables: Vec<Table>,
    pub warnings: Vec<Warning>,
}

/// Fits the clips `clips` of `session` onto each head and compares them, W/H under `pose`
/// (as `eval` compares the session's own head): the RMSE comparison against the first head,
/// the speaker–head match per head and, when both kinds are present, corresponding vs
/// non-corresponding heads.
///
/// # Errors
/// No clips; as [`head_utterances`]; a comparison that cannot be made.
pub fn compare_heads(
    session: &Session,
    heads: &[Head],
    clips: &[usize],
    normalise: Normalisation,
    pose: PoseComparison,
    progress: ProgressFn<'_>,
) -> Result<HeadsReport> {
    if clips.is_empty() {
        return Err(Error::NoClips);
    }
    let mut warnings = Vec::new();
    let speaker = clips.iter().find_map(|&c| speaker_neutral(session, c, None).ok());
    if speaker.is_none() {
        warnings.push(Warning(
            "lipmap: warning: no neutral frame with all index points; no speaker-head verdict"
                .into(),
        ));
    }
    // The session's own model drives the OBJ heads; every transfer is set up before any
    // fitting, so a bad head or map fails at once.
    let transferred = heads.iter().any(|h| matches!(h.kind, HeadKind::Transferred { .. }));
    let source = transferred
        .then(|| Resources::load(session))
        .transpose()
        .context("the session's model, which drives the OBJ heads")?;
    let drivers: Vec<Driver<'_>> =
        heads.iter().map(|h| Driver::new(h, source.as_ref())).collect::<Result<_>>()?;
    let bounds = &crate::reference::current().bounds;
    let mut configs = Vec::new();
    let mut matches = Vec::new();
    let mut notes = Vec::new();
    for (h, driver) in heads.iter().zip(&drivers) {
        let (utterances, w) = head_utterances(session, &h.name, driver, clips, pose, progress)?;
        warnings.extend(w);
        configs
            .push(Configuration { name: h.name.clone(), utterances: normalise.apply(&utterances) });
        if let HeadKind::Transferred { mapping, mode, .. } = &h.kind {
            notes.push(format!(
                "{}: the session's fitted model transferred onto {} ({}, map {})",
                h.name,
                h.path.display(),
                mode_name(*mode),
                mapping.display()
            ));
        }
        let verdict = match (&speaker, head_neutral_indices(h)) {
            (Some(s), Ok(hi)) => Ok(match_speaker_head(&s.indices, &hi, bounds)),
            (None, _) => Err("no speaker indices".to_string()),
            (_, Err(e)) => Err(super::error_chain(&e)),
        };
        matches.push(HeadMatch { head: h.name.clone(), verdict });
    }
    let comparison = compare_configurations(&configs, 0, RowKey::Sentence)?;
    let mut rmse = comparison.to_table().keyed("heads");
    rmse.title = format!("RMSE by head · W/H {}", pose.short_label());
    rmse.notes.push(format!("W/H compared {pose}"));
    rmse.notes.extend(notes);
    let mut tables = vec![rmse, match_table(&matches, speaker.as_ref())];
    tables.extend(correspondence_table(&comparison, &matches));
    Ok(HeadsReport { tables, warnings })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn touch(dir: &Path, name: &str, text: &str) -> PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    #[test]
    fn head_folder_map_is_the_toml_or_the_eos_txt() {
        let d = tempfile::tempdir().unwrap();
        let eos = touch(d.path(), "ibug_to_sfm.txt", "");
        touch(d.path(), "notes.txt", "");
        let files = sorted_files(d.path()).unwrap();
        assert_eq!(head_map_path(d.path(), &files).unwrap(), eos);
        let map = touch(d.path(), "head_map.toml", "");
        let files = sorted_files(d.path()).unwrap();
        assert_eq!(head_map_path(d.path(), &files).unwrap(), map);
        touch(d.path(), "settings.toml", "");
        let files = sorted_files(d.path()).unwrap();
        assert_eq!(head_map_path(d.path(), &files).unwrap(), map, "`map` in the name decides");
        touch(d.path(), "other_map.toml", "");
        let files = sorted_files(d.path()).unwrap();
        assert!(head_map_path(d.path(), &files).unwrap_err().to_string().contains("several"));
    }

    #[test]
    fn head_folder_model_prefers_the_shape_bin_and_takes_blendshapes_beside_it() {
        let d = tempfile::tempdir().unwrap();
        let files = sorted_files(d.path()).unwrap();
        assert!(head_model_paths(d.path(), &files).unwrap_err().to_string().contains("no model"));
        std::fs::create_dir(d.path().join("poses")).unwrap();
        let files = sorted_files(d.path()).unwrap();
        assert_eq!(head_model_paths(d.path(), &files).unwrap().0, d.path().join("poses"));
        let blend = touch(d.path(), "expression_blendshapes_3448.bin", "x");
        let shape = touch(d.path(), "sfm_shape_3448.bin", "x");
        let files = sorted_files(d.path()).unwrap();
        assert_eq!(head_model_paths(d.path(), &files).unwrap(), (shape, Some(blend)));
    }

    #[test]
    fn a_head_is_a_folder_or_a_session_file() {
        let d = tempfile::tempdir().unwrap();
        let f = touch(d.path(), "model.ply", "");
        let bih = Interpolation::Biharmonic;
        assert!(load_head(&f, None, bih).unwrap_err().to_string().contains("a head is a folder"));
    }

    #[test]
    fn an_obj_head_is_transferred_with_its_map_given_or_beside_it() {
        let d = tempfile::tempdir().unwrap();
        let obj = touch(d.path(), "scan.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
        let bih = Interpolation::Barycentric;
        let err = load_head(&obj, None, bih).unwrap_err().to_string();
        assert!(err.contains("scan.obj") && err.contains("--mapping"), "{err}");
        let given = touch(d.path(), "given.toml", "[landmark_mappings]\n31 = 1\n");
        let head = load_head(&obj, Some(&given), bih).unwrap();
        assert_eq!(head.name, "scan");
        let HeadKind::Transferred { target, mapping, mode } = &head.kind else {
            panic!("{:?}", head.kind)
        };
        assert_eq!((target.mesh.vertices.len(), mapping, *mode), (3, &given, bih));
        assert_eq!(target.map.vertex(30), Some(1));
        touch(d.path(), "scan_map.toml", "[landmark_mappings]\n31 = 2\n");
        let beside = load_head(&obj, None, bih).unwrap();
        let HeadKind::Transferred { target, .. } = &beside.kind else { panic!() };
        assert_eq!(target.map.vertex(30), Some(2));
        // A map goes with an OBJ head only, and no more maps than OBJ heads.
        let dir = d.path().to_path_buf();
        assert!(load_head(&dir, Some(&given), bih).unwrap_err().to_string().contains("only"));
        let two = [given.clone(), given.clone()];
        let err = load_heads(std::slice::from_ref(&obj), &two, bih, None).unwrap_err().to_string();
        assert!(err.contains("2 landmark maps given for 1 OBJ heads"), "{err}");
        let missing = d.path().join("gone.obj");
        let err = load_head(&missing, Some(&given), bih).unwrap_err().to_string();
        assert!(err.contains("gone.obj"), "{err}");
    }
}
