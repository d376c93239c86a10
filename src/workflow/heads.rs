//! Several heads compared (`lipmap eval SESSION --heads A,B,C`): one speaker's clips fitted
//! onto each head, the W/H(/P) RMSE table per head with paired t-tests, and corresponding vs
//! non-corresponding heads.
//!
//! A head is named on the command line by a path: a session file (`.json`) whose model,
//! landmark map and head mesh are used, or a folder holding a model and a landmark map (what
//! `lipmap demo` writes: `model.lmm`, `head_map.toml`, `head.obj`, `poses/`).

use super::error::{Context, Error, Result, Warning};
use super::evaluate::{Normalisation, utterance_of_clip};
use super::indices::{NeutralChoice, SpeakerNeutral, resources_head_indices, speaker_neutral};
use super::resources::{Resources, check_map_vertices};
use super::session::{image_height, load_session};
use super::{Progress, ProgressFn};
use crate::eval::stats::paired_t_test;
use crate::eval::{Cell, Comparison, Configuration, RowKey, Table, Utterance};
use crate::eval::{compare_configurations, mean_of};
use crate::fit::fit_clip;
use crate::io::model_source::{ModelSourceKind, detect_model_source, load_model};
use crate::io::{landmark_map_toml, obj};
use crate::measure::{
    FacialIndex, IndexClass, MatchVerdict, Measure, MeshMeasureOptions, match_speaker_head,
};
use crate::session::Session;
use std::path::{Path, PathBuf};

/// A head to map the speaker onto: its display name and what fitting it needs.
#[derive(Clone, Debug)]
pub struct Head {
    pub name: String,
    pub path: PathBuf,
    pub resources: Resources,
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

/// Loads the head named by `path`: a session file (its model, map and head mesh) or a
/// folder with a model, a landmark map and optionally `head.obj` (its neutral pose).
///
/// # Errors
/// A path that is neither; a folder lacking a model or map; any file's format error; a map
/// naming vertices the model lacks.
pub fn load_head(path: &Path) -> Result<Head> {
    let name = file_name(path).trim_end_matches(".lipmap.json").to_string();
    let resources = if path.is_dir() {
        let files = sorted_files(path)?;
        let (model_path, blend) = head_model_paths(path, &files)?;
        let map_path = head_map_path(path, &files)?;
        let model = load_model(&model_path, blend.as_deref())?;
        let map = landmark_map_toml::read_landmark_map(&map_path)?;
        check_map_vertices(&map, model.num_vertices(), Some(&map_path))?;
        let head_obj = path.join("head.obj");
        let head = head_obj.is_file().then(|| obj::read_obj(&head_obj)).transpose()?;
        Resources { model, map, head }
    } else if path.is_file() && file_name(path).ends_with(".json") {
        let session = load_session(path)?;
        Resources::load(&session).with_context(|| path.display().to_string())?
    } else {
        return Err(Error::Invalid(format!(
            "{}: a head is a folder with a model and a landmark map, or a session file",
            path.display()
        )));
    };
    Ok(Head { name, path: path.to_path_buf(), resources })
}

/// Loads every head, making repeated names unique (`b`, `b#2`).
///
/// # Errors
/// As [`load_head`], naming the head.
pub fn load_heads(paths: &[PathBuf]) -> Result<Vec<Head>> {
    let mut heads: Vec<Head> = Vec::new();
    for p in paths {
        let mut h = load_head(p).with_context(|| format!("head {}", p.display()))?;
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

/// The session's clips fitted onto `head` with the session's fit settings, and what was
/// worked around. The fits are not cached: the session's cache is keyed to its own model and
/// map. Progress: one stage per clip.
///
/// # Errors
/// Unknown clip; unreadable frames when the clip's image size is not recorded.
pub fn head_utterances(
    session: &Session,
    head: &Head,
    clips: &[usize],
    progress: ProgressFn<'_>,
) -> Result<(Vec<Utterance>, Vec<Warning>)> {
    let settings = &session.fit_settings;
    let res = &head.resources;
    let mut utterances = Vec::new();
    let mut warnings = Vec::new();
    for &c in clips {
        let track = session.effective_track(c)?;
        let height = image_height(session, c)?;
        let total = track.frames.len();
        let what = format!("{} onto {}", session.clip(c)?.name, head.name);
        progress(Progress::Stage { what, total });
        let report = |done: usize| progress(Progress::Steps { done, total });
        let fits = fit_clip(&res.model, &res.map, &track.frames, height, settings, Some(&report));
        let (u, w) = utterance_of_clip(session, res, c, &fits, &MeshMeasureOptions::default())?;
        utterances.push(u);
        warnings.extend(w);
    }
    progress(Progress::Finished);
    Ok((utterances, warnings))
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
    let mut t = Table::new("speaker-head match", headers.map(String::from).to_vec());
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
    let mut t = Table::new("corresponding vs non-corresponding heads", headers);
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

/// Fits the clips `clips` of `session` onto each head and compares them: the RMSE
/// comparison against the first head, the speaker–head match per head and, when both kinds
/// are present, corresponding vs non-corresponding heads.
///
/// # Errors
/// No clips; as [`head_utterances`]; a comparison that cannot be made.
pub fn compare_heads(
    session: &Session,
    heads: &[Head],
    clips: &[usize],
    normalise: Normalisation,
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
    let bounds = &crate::reference::current().bounds;
    let mut configs = Vec::new();
    let mut matches = Vec::new();
    for h in heads {
        let (utterances, w) = head_utterances(session, h, clips, progress)?;
        warnings.extend(w);
        configs
            .push(Configuration { name: h.name.clone(), utterances: normalise.apply(&utterances) });
        let verdict = match (&speaker, resources_head_indices(&h.resources)) {
            (Some(s), Ok(hi)) => Ok(match_speaker_head(&s.indices, &hi.indices, bounds)),
            (None, _) => Err("no speaker indices".to_string()),
            (_, Err(e)) => Err(super::error_chain(&e)),
        };
        matches.push(HeadMatch { head: h.name.clone(), verdict });
    }
    let comparison = compare_configurations(&configs, 0, RowKey::Sentence)?;
    let mut rmse = comparison.to_table();
    rmse.title = "RMSE by head".into();
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
        let f = touch(d.path(), "model.obj", "");
        assert!(load_head(&f).unwrap_err().to_string().contains("a head is a folder"));
    }
}
