//! Quality prediction (SAQP, `crate::saqp`) on sessions: gather the fitted clips with phone
//! alignments of one or more sessions into a motion corpus, run the paper's
//! cross-validation, train a predictor and save it, score a new phone sequence, and read a
//! researcher's own synthesized motion from files.
//!
//! A clip becomes a sentence when it has a phone alignment and at least one good fit. Frames
//! whose fit failed (or that the flags discredit) are bridged from the good fits on either
//! side by the fit's gap policy (`fit::gaps`), so motion and phones stay frame-aligned. Motion
//! is measured from one neutral per session (the identity coefficients averaged over every
//! good fit of the session's clips, expressions at 0): a session is one speaker, and a
//! per-clip neutral would carry each clip's identity error into its motion.
//!
//! Start with [`session_corpus`], then [`cross_validate_sessions`] or [`train_predictor`];
//! predictors are saved by [`save_predictor`] and read by [`load_predictor`].

use super::error::{Context, Error, Result, Warning};
use super::fit::fit_clip_cached;
use super::flags::clip_flags;
use super::resources::Resources;
use super::session::{clip_length, open_for_read};
use super::{Progress, ProgressFn};
use crate::alignment::Phone;
use crate::eval::{Cell, Table};
use crate::fit::{FrameFit, GapError, fill_gaps};
use crate::glossary::names::{LARGEST_TRAINING_ERROR, MOUTH_WEIGHT, SATF_ERROR, SMOOTHING_WEIGHT};
use crate::io::alignment_format::read_alignment;
use crate::io::motion_csv::read_motion_csv;
use crate::io::obj::read_obj;
use crate::landmarks::flags::FlagThresholds;
use crate::math::{DVector, Point3};
use crate::plot::{Panel, Series, TrajectoryPlot, draw_trajectories};
use crate::saqp::{
    CalibrationKind, Corpus, CvOptions, CvReport, External, INPUT_NAMES, LinearShapes, Predictor,
    Prepared, QualityEstimate, SaqpError, Sentence, Skill, SynthKind, TrainOptions,
};
use crate::session::Session;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;
use std::path::{Path, PathBuf};

/// The machine keys (CSV and JSON columns) of ω_m and ξ, as the model files name them.
const OMEGA_M: &str = "omega_m";
const XI: &str = "xi";

/// What a quality-model file says it is (`io::json_model`).
pub const SAQP_MODEL_FORMAT: &str = crate::io::json_model::QUALITY_MODEL.format;
/// The version this lipmap writes and reads.
pub const SAQP_MODEL_VERSION: u32 = crate::io::json_model::QUALITY_MODEL.version;

/// Where a corpus sentence came from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SentenceOrigin {
    pub session: PathBuf,
    pub clip: usize,
}

/// The motion corpus of some sessions.
#[derive(Clone, Debug)]
pub struct SessionCorpus {
    pub corpus: Corpus,
    /// One per sentence, in corpus order.
    pub origins: Vec<SentenceOrigin>,
    /// Frames in the corpus, and those bridged (a failed fit, or flagged and not kept).
    pub frames: usize,
    pub bridged: usize,
    pub warnings: Vec<Warning>,
}

/// Which frames make the ground-truth motion.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct CorpusOptions {
    /// Use frames the flags discredit (crossed lips, a broken lip shape, a high fit
    /// residual, the tracker's own doubt) as they are, instead of bridging them from their
    /// neighbours.
    pub keep_flagged: bool,
}

/// A core error as a workflow error.
fn saqp_error(e: SaqpError) -> Error {
    Error::Invalid(e.to_string())
}

/// Gathers the fitted clips with phone alignments of `sessions` (one morphable model and
/// landmark map for all) into a motion corpus, fitting what the fit cache lacks and saving
/// it where the session can be locked. Sentences are named by their clip; a clip name that
/// several sessions use becomes `SESSION:CLIP` (the session file's stem).
///
/// The corpus is the ground truth every synthesizer is scored against, so a tracker's gross
/// error would count as the truth: frames whose fit failed, and unless
/// `options.keep_flagged` frames whose flags discredit them
/// ([`crate::landmarks::flags::FlagReason::discredits_frame`]), are bridged linearly from
/// the nearest usable frames on either side. Frames flagged only as unusual motion stay:
/// they are as often real fast speech.
///
/// # Errors
/// A session, model or map that cannot be read; sessions of different models or maps; no
/// clip with both an alignment and a good fit.
pub fn session_corpus(
    sessions: &[String],
    options: &CorpusOptions,
    progress: ProgressFn<'_>,
) -> Result<SessionCorpus> {
    let mut g = Gathering::default();
    let mut shared: Option<(Resources, String)> = None;
    for s in sessions {
        let mut read = open_for_read(s)?;
        g.warnings.append(&mut read.notices);
        let res = Resources::load(&read.session).map_err(|e| e.context(s))?;
        if let Some((first, name)) = &shared
            && (first.model.num_vertices() != res.model.num_vertices()
                || LinearShapes::from_model(&first.model).num_coefficients()
                    != LinearShapes::from_model(&res.model).num_coefficients()
                || first.map.to_vertex != res.map.to_vertex)
        {
            return Err(Error::Invalid(format!(
                "{s}: its model or landmark map differs from {name}'s; gather sessions of one model"
            )));
        }
        g.add_session(&mut read.session, &read.path, &res, s, options, progress)?;
        read.save_if_locked().context(s.as_str())?;
        if shared.is_none() {
            shared = Some((res, s.clone()));
        }
    }
    progress(Progress::Finished);
    let (res, _) = shared.ok_or_else(|| Error::Invalid("no sessions given".into()))?;
    g.finish(res, &sessions.join(", "))
}

/// [`session_corpus`] of one session already open (the TUI's, with its unsaved
/// corrections), at `path`; fits the cache lacks are computed and kept in `session`.
///
/// # Errors
/// As [`session_corpus`].
pub fn open_session_corpus(
    session: &mut Session,
    path: &Path,
    options: &CorpusOptions,
    progress: ProgressFn<'_>,
) -> Result<SessionCorpus> {
    let label = path.display().to_string();
    let res = Resources::load(session).map_err(|e| e.context(&label))?;
    let mut g = Gathering::default();
    g.add_session(session, path, &res, &label, options, progress)?;
    progress(Progress::Finished);
    g.finish(res, &label)
}

/// Sentences gathered so far from some sessions.
#[derive(Default)]
struct Gathering {
    sentences: Vec<Sentence>,
    origins: Vec<SentenceOrigin>,
    stems: Vec<String>,
    frames: usize,
    bridged: usize,
    warnings: Vec<Warning>,
}

impl Gathering {
    /// Adds the usable clips of `session` (named `s` in messages), with the session's
    /// neutral.
    fn add_session(
        &mut self,
        session: &mut Session,
        path: &Path,
        res: &Resources,
        s: &str,
        options: &CorpusOptions,
        progress: ProgressFn<'_>,
    ) -> Result<()> {
        let settings = session.fit_settings.clone();
        let mut neutral_sum: Option<DVector> = None;
        let mut good_total = 0usize;
        let first_new = self.sentences.len();
        for clip in 0..session.clips.len() {
            let c = &session.clips[clip];
            let (name, fps) = (c.name.clone(), c.front.fps);
            let Some(alignment) = c.alignment.clone().filter(|a| !a.phones.is_empty()) else {
                self.warnings.push(Warning(format!(
                    "lipmap: warning: {s}: clip `{name}` has no phone alignment; not used \
                     (a clip gets one with --alignment in `lipmap new` or `lipmap import`)"
                )));
                continue;
            };
            progress(Progress::Stage { what: format!("fitting {name}"), total: 0 });
            let steps = |done: usize, total: usize| progress(Progress::Steps { done, total });
            let clip_fits = fit_clip_cached(session, res, clip, &settings, Some(&steps))
                .map_err(|e| e.context(format!("{s}: clip `{name}`")))?;
            self.warnings.extend(clip_fits.map_warning);
            let fits = clip_fits.fits;
            let n = clip_length(session, clip)?;
            let skip: Vec<usize> = if options.keep_flagged {
                Vec::new()
            } else {
                let track = session.effective_track(clip)?;
                clip_flags(&track, &fits, &[], &FlagThresholds::default())
                    .iter()
                    .filter(|f| f.reasons.iter().any(|r| r.discredits_frame()))
                    .map(|f| f.frame)
                    .collect()
            };
            let (frames, bridged) = match bridged_coefficients(&fits, n, fps, &skip) {
                Ok(b) => b,
                Err(why) => {
                    self.warnings.push(Warning(format!(
                        "lipmap: warning: {s}: clip `{name}`: {why}; not used"
                    )));
                    continue;
                }
            };
            self.frames += n;
            self.bridged += bridged;
            for f in fits.iter().filter(|f| f.is_usable()) {
                let c = LinearShapes::neutral_of_fit(f);
                neutral_sum = Some(neutral_sum.map_or_else(|| c.clone(), |sum| sum + &c));
                good_total += 1;
            }
            self.sentences.push(Sentence {
                name,
                phones: alignment.phones,
                fps,
                frames,
                neutral: DVector::zeros(0),
            });
            self.origins.push(SentenceOrigin { session: path.to_path_buf(), clip });
            self.stems.push(session_stem(path));
        }
        if let Some(sum) = neutral_sum {
            let neutral = sum / good_total as f64;
            for sentence in &mut self.sentences[first_new..] {
                sentence.neutral = neutral.clone();
            }
        }
        Ok(())
    }

    /// The corpus on `res`'s model and map; `what` names the sessions in errors.
    fn finish(self, res: Resources, what: &str) -> Result<SessionCorpus> {
        let Gathering { mut sentences, origins, stems, frames, bridged, warnings } = self;
        if sentences.is_empty() {
            return Err(Error::Invalid(format!(
                "{what}: no clip has both a phone alignment and a successful fit (a clip gets an \
                 alignment with --alignment in `lipmap new` or `lipmap import`)"
            )));
        }
        let mut count: HashMap<String, usize> = HashMap::new();
        for s in &sentences {
            *count.entry(s.name.clone()).or_default() += 1;
        }
        for (s, stem) in sentences.iter_mut().zip(&stems) {
            if count[&s.name] > 1 {
                s.name = format!("{stem}:{}", s.name);
            }
        }
        let corpus = Corpus {
            shapes: LinearShapes::from_model(&res.model),
            landmarks: res.map,
            sentences,
            visemes: crate::reference::current().visemes.clone(),
            phones: crate::reference::current().phones.clone(),
        };
        corpus.validate().map_err(saqp_error)?;
        Ok(SessionCorpus { corpus, origins, frames, bridged, warnings })
    }
}

/// The shape coefficients of `n` frames (at `fps`) from `fits`, the frames without a usable
/// fit or listed in `skip` filled in by the fit's gap policy ([`fill_gaps`]), and how many
/// were so bridged.
fn bridged_coefficients(
    fits: &[FrameFit],
    n: usize,
    fps: f64,
    skip: &[usize],
) -> std::result::Result<(Vec<DVector>, usize), GapError> {
    let filled = fill_gaps(fits, n, fps, skip)?;
    Ok((filled.fits.iter().map(LinearShapes::coefficients_of_fit).collect(), filled.filled))
}

/// `demo` of `sessions/demo.lipmap.json`.
fn session_stem(path: &Path) -> String {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    name.strip_suffix(".lipmap.json")
        .or_else(|| name.strip_suffix(".json"))
        .unwrap_or(&name)
        .to_string()
}

/// The marker vertices quality is measured on (landmark vertices, then evenly spread face
/// vertices), in order, and whether each is a mouth marker: what a synthesized-motion file
/// must give.
///
/// # Errors
/// As [`session_corpus`]; a corpus without motion.
pub fn marker_vertices(corpus: &Corpus) -> Result<Vec<(usize, bool)>> {
    let prepared = Prepared::new(corpus).map_err(saqp_error)?;
    let m = &prepared.markers;
    Ok(m.vertices.iter().copied().zip(m.mouth.iter().copied()).collect())
}

/// A researcher's synthesized motion, per corpus sentence that has a file.
#[derive(Clone, Debug, Default)]
pub struct SynthFiles {
    pub motion: HashMap<String, External>,
    /// Sentences without a file (not scored for the external synthesizer).
    pub missing: Vec<String>,
}

/// Reads synthesized motion for the corpus's sentences from `dir`: `DIR/NAME.csv`
/// (`frame,vertex,x,y,z`, [`crate::io::motion_csv`]) or a folder `DIR/NAME/` of OBJ meshes
/// with the model's vertex order, one per frame, ordered by the last number in their names.
/// NAME is the sentence name made a safe file name as `lipmap export` does.
///
/// # Errors
/// An unreadable folder or file (named, with its line); a folder without OBJs; no file for
/// any sentence.
pub fn read_synth_files(dir: &Path, corpus: &Corpus) -> Result<SynthFiles> {
    if !dir.is_dir() {
        return Err(Error::Invalid(format!(
            "{}: not a folder of synthesized motion",
            dir.display()
        )));
    }
    let names: Vec<String> = corpus.sentences.iter().map(|s| s.name.clone()).collect();
    let files = super::export::safe_file_names(&names);
    let mut out = SynthFiles::default();
    for (name, file) in names.iter().zip(&files) {
        let csv = dir.join(format!("{file}.csv"));
        let folder = dir.join(file);
        let motion = if csv.is_file() {
            let m = read_motion_csv(&csv)?;
            External { vertices: m.vertices, frames: m.frames }
        } else if folder.is_dir() {
            External::whole_meshes(read_obj_sequence(&folder)?)
        } else {
            out.missing.push(name.clone());
            continue;
        };
        out.motion.insert(name.clone(), motion);
    }
    if out.motion.is_empty() {
        let example = files.first().map_or("NAME", String::as_str);
        return Err(Error::Invalid(format!(
            "{}: no synthesized motion for any of the {} sentences (expected e.g. {example}.csv \
             with columns frame,vertex,x,y,z, or a folder {example}/ of OBJs)",
            dir.display(),
            names.len()
        )));
    }
    Ok(out)
}

/// The vertex positions of every OBJ in `dir`, ordered by the last number in the name.
fn read_obj_sequence(dir: &Path) -> Result<Vec<Vec<Point3>>> {
    let entries = std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))?;
    let mut files: Vec<(u64, PathBuf)> = Vec::new();
    for entry in entries {
        let path = entry.map_err(|e| Error::io(dir, e))?.path();
        if path.extension().is_some_and(|x| x.eq_ignore_ascii_case("obj")) {
            files.push((last_number(&path), path));
        }
    }
    if files.is_empty() {
        return Err(Error::Invalid(format!("{}: no OBJ files in the folder", dir.display())));
    }
    files.sort();
    files
        .iter()
        .map(|(_, p)| {
            let mesh = read_obj(p)?;
            Ok(mesh.vertices.iter().map(|v| Point3::new(v.x, v.y, v.z)).collect())
        })
        .collect()
}

/// The last run of digits in a file's stem (`frame_00012.obj` → 12), 0 without one.
fn last_number(path: &Path) -> u64 {
    let stem = path.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default();
    let digits: String = stem
        .chars()
        .rev()
        .skip_while(|c| !c.is_ascii_digit())
        .take_while(char::is_ascii_digit)
        .collect::<Vec<_>>()
        .into_iter()
        .rev()
        .collect();
    digits.parse().unwrap_or(0)
}

/// What to learn: the cross-validation options and, for the external synthesizer, the
/// folder of the researcher's motion.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct SaqpSettings {
    pub corpus: CorpusOptions,
    pub cv: CvOptions,
    pub synth_files: Option<PathBuf>,
}

/// The corpus's external motion when the settings learn it.
fn external_motion(
    settings: &SaqpSettings,
    corpus: &Corpus,
    warnings: &mut Vec<Warning>,
) -> Result<HashMap<String, External>> {
    let Some(dir) = &settings.synth_files else {
        if settings.cv.synths.contains(&SynthKind::External) {
            return Err(Error::Invalid("the external synthesizer needs --synth-files DIR".into()));
        }
        return Ok(HashMap::new());
    };
    let files = read_synth_files(dir, corpus)?;
    if !files.missing.is_empty() {
        warnings.push(Warning(format!(
            "lipmap: warning: {}: no motion for {} of {} sentences (e.g. `{}`); they are not scored for it",
            dir.display(),
            files.missing.len(),
            corpus.sentences.len(),
            files.missing[0]
        )));
    }
    Ok(files.motion)
}

/// A synthesized-motion error names the folder it came from.
fn with_synth_dir(e: SaqpError, settings: &SaqpSettings) -> Error {
    let hint = matches!(e, SaqpError::MissingVertex { .. });
    let msg = match (&settings.synth_files, &e) {
        (
            Some(dir),
            SaqpError::FrameCount { .. }
            | SaqpError::PointCount { .. }
            | SaqpError::MissingVertex { .. }
            | SaqpError::VertexOutOfRange { .. },
        ) => format!("{}: {e}", dir.display()),
        _ => e.to_string(),
    };
    if hint {
        Error::Invalid(format!("{msg} (`lipmap saqp markers SESSION` lists the vertices needed)"))
    } else {
        Error::Invalid(msg)
    }
}

/// The cross-validation of some sessions.
#[derive(Clone, Debug)]
pub struct SaqpCv {
    pub report: CvReport,
    pub sentences: usize,
    pub warnings: Vec<Warning>,
}

/// Runs the paper's cross-validation on the corpus of `sessions`.
///
/// # Errors
/// As [`session_corpus`] and [`read_synth_files`]; the core's errors (too few sentences, a
/// synthesized motion of the wrong size), naming the sentence.
pub fn cross_validate_sessions(
    sessions: &[String],
    settings: &SaqpSettings,
    progress: ProgressFn<'_>,
) -> Result<SaqpCv> {
    let sc = session_corpus(sessions, &settings.corpus, progress)?;
    cross_validate_corpus(sc, settings)
}

/// [`cross_validate_sessions`] on a corpus already gathered.
///
/// # Errors
/// As [`cross_validate_sessions`].
pub fn cross_validate_corpus(sc: SessionCorpus, settings: &SaqpSettings) -> Result<SaqpCv> {
    let SessionCorpus { corpus, mut warnings, .. } = sc;
    let external = external_motion(settings, &corpus, &mut warnings)?;
    let report = crate::saqp::cross_validate(&corpus, &external, &settings.cv)
        .map_err(|e| with_synth_dir(e, settings))?;
    warn_unscored(&report, settings, &mut warnings);
    Ok(SaqpCv { report, sentences: corpus.sentences.len(), warnings })
}

/// Warns of a synthesizer with fewer than two held-out sentences: its r and RMSE say
/// nothing.
fn warn_unscored(report: &CvReport, settings: &SaqpSettings, warnings: &mut Vec<Warning>) {
    for s in report.synths.iter().filter(|s| s.held_out.len() < 2) {
        let dir = settings.synth_files.as_ref().map_or(String::new(), |d| d.display().to_string());
        warnings.push(Warning(format!(
            "lipmap: warning: {} held-out sentences have {} motion, too few to score it{}",
            s.held_out.len(),
            s.synth.name(),
            if s.synth == SynthKind::External {
                format!("; give {dir} motion for more sentences")
            } else {
                String::new()
            }
        )));
    }
}

/// A predictor as saved.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SaqpModelFile {
    pub format: String,
    pub version: u32,
    /// The sessions it was trained on.
    pub sessions: Vec<String>,
    pub sentences: usize,
    pub predictor: Predictor,
}

/// A trained predictor with the cross-validation that chose it.
#[derive(Clone, Debug)]
pub struct SaqpTrained {
    pub file: SaqpModelFile,
    pub report: CvReport,
    pub warnings: Vec<Warning>,
}

/// Trains a predictor for `synth` on the corpus of `sessions`.
///
/// # Errors
/// As [`cross_validate_sessions`].
pub fn train_predictor(
    sessions: &[String],
    settings: &SaqpSettings,
    synth: SynthKind,
    progress: ProgressFn<'_>,
) -> Result<SaqpTrained> {
    let SessionCorpus { corpus, mut warnings, .. } =
        session_corpus(sessions, &settings.corpus, progress)?;
    let external = external_motion(settings, &corpus, &mut warnings)?;
    let mut cv = settings.cv.clone();
    if !cv.synths.contains(&synth) {
        cv.synths = vec![synth];
    }
    let (predictor, report) = crate::saqp::train(&corpus, &external, &TrainOptions { cv, synth })
        .map_err(|e| with_synth_dir(e, settings))?;
    warn_unscored(&report, settings, &mut warnings);
    let file = SaqpModelFile {
        format: SAQP_MODEL_FORMAT.into(),
        version: SAQP_MODEL_VERSION,
        sessions: sessions.to_vec(),
        sentences: corpus.sentences.len(),
        predictor,
    };
    Ok(SaqpTrained { file, report, warnings })
}

/// Writes a quality model atomically (a failed write leaves the old file). It is held to the
/// rules a load checks first, so a non-finite or out-of-range value stops here, naming the
/// field.
///
/// # Errors
/// A value out of its range (nothing written); the file cannot be written.
pub fn save_predictor(path: &Path, file: &SaqpModelFile) -> Result<()> {
    file.predictor.validate().map_err(|e| {
        Error::Invalid(format!("{}: not written: the trained model has {e}", path.display()))
    })?;
    let text = serde_json::to_string(file)
        .map_err(|e| Error::Invalid(format!("{}: {e}", path.display())))?;
    crate::io::atomic::write_atomic_bytes(path, text.as_bytes()).map_err(|e| Error::io(path, e))
}

/// Reads a quality model file.
///
/// # Errors
/// One line naming the file: unreadable, not a quality model, another version.
pub fn load_predictor(path: &Path) -> Result<SaqpModelFile> {
    let fail = |msg: String| Error::Invalid(format!("{}: {msg}", path.display()));
    let head = crate::io::json_model::read_json_model(path, &crate::io::json_model::QUALITY_MODEL)?;
    let model: SaqpModelFile =
        serde_json::from_value(head).map_err(|e| fail(format!("bad quality model: {e}")))?;
    model.predictor.validate().map_err(|e| fail(format!("bad quality model: {e}")))?;
    Ok(model)
}

/// Predicts the quality `model` gives the timed phones of `phones_file` (TextGrid, HTK .lab
/// or `start,end,phone` CSV).
///
/// # Errors
/// An unreadable model or alignment; a sequence of fewer than two phones or of phones the
/// corpus never saw (named by the file).
pub fn predict_quality(model: &SaqpModelFile, phones_file: &Path) -> Result<QualityEstimate> {
    let alignment = read_alignment(phones_file, None)?;
    predict_phones(model, &phones_file.display().to_string(), &alignment.phones)
}

/// [`predict_quality`] of phones already read; `name` names them in errors.
///
/// # Errors
/// As [`predict_quality`].
pub fn predict_phones(
    model: &SaqpModelFile,
    name: &str,
    phones: &[Phone],
) -> Result<QualityEstimate> {
    let tables = crate::reference::current();
    model.predictor.predict(name, phones, &tables.phones, &tables.visemes).map_err(saqp_error)
}

/// The region PCA of a cross-validation: vertices, dimensions and variance kept per region.
pub fn regions_table(report: &CvReport) -> Table {
    let headers = ["region", "vertices", "dims", "variance kept %"].map(String::from).to_vec();
    let mut t = Table::new("Motion regions (PCA per region, ≥ 95 % of the variance)", headers)
        .keyed("regions");
    for r in &report.regions {
        t.push_row(vec![
            Cell::Text(r.region.name().into()),
            Cell::Int(r.vertices as i64),
            Cell::Int(r.dims as i64),
            Cell::Num(100.0 * r.variance_kept),
        ]);
    }
    let dims: usize = report.regions.iter().map(|r| r.dims).sum();
    t.notes.push(format!("{dims} dimensions in all; {} markers measure quality", report.markers));
    t.precision = 1;
    t
}

/// A held-out figure, or `Missing` when no held-out sentence was scored (an external
/// synthesizer's motion may cover only some sentences).
fn scored(skill: &Skill, v: f64) -> Cell {
    if skill.sentences == 0 || !v.is_finite() { Cell::Missing } else { Cell::Num(v) }
}

/// The plain verdict of each synthesizer's kept predictor, one line each.
pub fn skill_lines(report: &CvReport) -> Vec<String> {
    report
        .synths
        .iter()
        .map(|s| {
            let k = s.kept_skill();
            format!("{}: {} predictor kept; {}", s.synth.name(), s.kept.name(), k.describe())
        })
        .collect()
}

/// Per synthesizer and calibration (the GP, and the straight line on the same inputs
/// beside it): held-out r and RMSE against a constant predictor's (the training mean), the
/// RMSE ratio with its 95 % bootstrap interval over the held-out sentences, the verdict,
/// and which calibration a trained predictor keeps.
pub fn synths_table(report: &CvReport) -> Table {
    let headers = [
        "synthesizer",
        "calibration",
        "held out",
        "r",
        "RMSE",
        "RMSE constant",
        "RMSE ratio",
        "ratio CI low",
        "ratio CI high",
        "verdict",
        "kept",
    ]
    .map(String::from)
    .to_vec();
    let mut t = Table::new(
        format!(
            "Predicted vs ground-truth quality (Likert 1-5) on {} held-out sentences; trained on {}",
            report.test_sentences, report.train_sentences
        ),
        headers,
    )
    .keyed("summary");
    for s in &report.synths {
        for kind in [CalibrationKind::Gp, CalibrationKind::Linear] {
            let k = s.skill(kind);
            t.push_row(vec![
                Cell::Text(s.synth.name().into()),
                Cell::Text(kind.name().into()),
                Cell::Int(k.sentences as i64),
                scored(k, k.pearson_r),
                scored(k, k.rmse),
                scored(k, k.rmse_constant),
                scored(k, k.ratio),
                scored(k, k.ratio_low),
                scored(k, k.ratio_high),
                Cell::Text(k.verdict().as_str().into()),
                Cell::Text(if s.kept == kind { "yes" } else { "" }.into()),
            ]);
        }
    }
    t.notes.extend(skill_lines(report));
    t.notes.push(format!(
        "{SATF_ERROR}: {SMOOTHING_WEIGHT} {}, order {} (chosen by cross-validation); {} training (E, Q) pairs, {} dropped as all phones unseen",
        report.satf.lambda, report.satf.order, report.pairs, report.unseen
    ));
    if report.synths.iter().any(|s| s.synth == SynthKind::Concatenative) {
        t.notes.push(format!(
            "concat: motion smoothed by a Gaussian of {:.0} ms (the width with the lowest mean training error)",
            report.smoothing * 1000.0
        ));
    }
    t.notes.push(
        "inputs: E and the coverage (how well recorded occurrences match each speech phone's context, two phones either way, 0–1); linear: least squares on them; kept: the GP only when its leave-one-sentence-out RMSE on the training pairs is lower than the line's by more than one standard error, else the line"
            .into(),
    );
    t.notes.push(
        "RMSE in Likert points; RMSE constant: predicting the training mean; skill: the ratio's 95 % bootstrap interval over the held-out sentences lies below 1"
            .into(),
    );
    t.notes.push(TERMS_HINT.into());
    t
}

/// Where the saqp tables' terms are explained.
pub const TERMS_HINT: &str = "terms: `lipmap help TERM` (E, coverage, omega_m, xi, RMSE ratio, bridged; `lipmap help terms` lists them)";

/// Per synthesizer: ω_m and ξ, the GP's hyperparameters, the line's coefficients, and both
/// calibrations' leave-one-sentence-out RMSE on the training pairs.
pub fn models_table(report: &CvReport) -> Table {
    let mut headers: Vec<String> = ["synthesizer", OMEGA_M, XI].map(String::from).to_vec();
    headers.extend(INPUT_NAMES.iter().map(|n| format!("GP length scale {n}")));
    headers.extend(["GP signal var", "GP noise var", "line intercept"].map(String::from));
    headers.extend(INPUT_NAMES.iter().map(|n| format!("line slope {n}")));
    headers.extend(["training RMSE GP", "training RMSE linear", "kept"].map(String::from));
    let mut t = Table::new(
        format!("Models: {MOUTH_WEIGHT}, {LARGEST_TRAINING_ERROR}, the GP's hyperparameters and the line beside it"),
        headers,
    )
    .keyed("models")
    .labelled(OMEGA_M, MOUTH_WEIGHT)
    .labelled(XI, LARGEST_TRAINING_ERROR);
    for s in &report.synths {
        let h = &s.gp.hyper;
        let mut row =
            vec![Cell::Text(s.synth.name().into()), Cell::Num(s.omega_m), Cell::Num(s.xi)];
        row.extend(h.length_scales.iter().map(|&v| Cell::Num(v)));
        row.extend([Cell::Num(h.signal_variance), Cell::Num(h.noise_variance)]);
        row.extend(s.linear.coefficients.iter().map(|&v| Cell::Num(v)));
        row.extend([
            Cell::Num(s.gp_training_rmse),
            Cell::Num(s.linear_training_rmse),
            Cell::Text(s.kept.name().into()),
        ]);
        t.push_row(row);
    }
    t
}

/// The paper's choice of ω_m (§5.3, Fig. 6): per synthesizer and candidate, the
/// leave-one-sentence-out RMSE of the GP's training predictions, which picks ω_m, beside the
/// scores' spread (what the training mean would err by) and their ratio.
pub fn omega_table(report: &CvReport) -> Table {
    let headers = ["synthesizer", OMEGA_M, "CV RMSE", "standard error", "spread", "chosen"]
        .map(String::from)
        .to_vec();
    let mut t = Table::new(
        format!("Choosing the {MOUTH_WEIGHT}: cross-validated RMSE of the training scores (Likert points)"),
        headers,
    )
    .keyed("omega")
    .labelled(OMEGA_M, MOUTH_WEIGHT);
    for s in &report.synths {
        let lowest = s.omega_scores.iter().min_by(|a, b| a.rmse.total_cmp(&b.rmse));
        for o in &s.omega_scores {
            let why = match lowest {
                _ if o.omega_m != s.omega_m => String::new(),
                Some(l) if l.omega_m == o.omega_m => "yes: the lowest".into(),
                Some(l) => format!("yes: within 1 SE of the lowest ({})", l.omega_m),
                None => String::new(),
            };
            t.push_row(vec![
                Cell::Text(s.synth.name().into()),
                Cell::Num(o.omega_m),
                Cell::Num(o.rmse),
                Cell::Num(o.rmse_error),
                Cell::Num(o.spread),
                Cell::Text(why),
            ]);
        }
    }
    t.notes.push(
        "the mouth weight ω_m weighs the mouth markers in the quality error Q (eq. 8); as the paper, the candidate with the lowest cross-validated RMSE (one training sentence left out at a time), but the smallest within one standard error of it, as the RMSEs differ by less than their noise; spread: what predicting the training mean would err by"
            .into(),
    );
    t
}

/// Every held-out sentence: E, coverage, ground-truth Q and Likert score, the kept
/// calibration's prediction, its σ and its error (predicted − ground truth).
pub fn held_out_table(report: &CvReport) -> Table {
    let headers =
        ["sentence", "synthesizer", "E", "coverage", "Q", "likert", "predicted", "sigma", "error"]
            .map(String::from)
            .to_vec();
    let mut t = Table::new("Held-out sentences: ground-truth and predicted quality", headers)
        .keyed("sentences");
    for s in &report.synths {
        for h in &s.held_out {
            let p = h.prediction(s.kept);
            t.push_row(vec![
                Cell::Text(h.sentence.clone()),
                Cell::Text(s.synth.name().into()),
                Cell::Num(h.e),
                Cell::num(h.inputs.get(1).copied()),
                Cell::Num(h.q),
                Cell::Num(h.likert),
                Cell::Num(p.mean),
                Cell::Num(p.std()),
                Cell::Num(p.mean - h.likert),
            ]);
        }
    }
    t.notes.push("predicted: by each synthesizer's kept calibration (see the summary)".into());
    t
}

/// The paper's Fig. 8: per synthesizer, held-out sentences sorted by ground-truth score,
/// the ground truth and the prediction with ±σ.
pub fn quality_chart(report: &CvReport, width: u32) -> image::RgbImage {
    let panels = report
        .synths
        .iter()
        .map(|s| {
            let mut held: Vec<&crate::saqp::HeldOut> = s.held_out.iter().collect();
            held.sort_by(|a, b| a.likert.total_cmp(&b.likert));
            let series =
                |name: &str, colour: [u8; 3], f: &dyn Fn(&crate::saqp::HeldOut) -> f64| Series {
                    name: name.into(),
                    colour,
                    // Ranks count from 1: nothing at x = 0.
                    values: std::iter::once(None).chain(held.iter().map(|h| Some(f(h)))).collect(),
                };
            Panel {
                y_label: "Likert score\n1 worst – 5 best".into(),
                caption: Some(format!(
                    "{} synthesizer: Pearson r {:.2}",
                    s.synth.name(),
                    s.pearson_r
                )),
                series: vec![
                    series("ground truth", [31, 119, 180], &|h| h.likert),
                    series("predicted", [255, 127, 14], &|h| h.prediction(s.kept).mean),
                    series("predicted ± σ", [250, 200, 150], &|h| {
                        let p = h.prediction(s.kept);
                        p.mean + p.std()
                    }),
                    series("predicted ± σ", [250, 200, 150], &|h| {
                        let p = h.prediction(s.kept);
                        p.mean - p.std()
                    }),
                ],
            }
        })
        .collect();
    draw_trajectories(&TrajectoryPlot {
        title: "Quality of held-out sentences (cross-validation): ground truth vs predicted".into(),
        fps: 1.0,
        alignment: None,
        panels,
        width,
        panel_height: 180,
        x_label: "held-out sentence, ranked by ground-truth score (rank)".into(),
    })
}

/// Writes [`quality_chart`] as a PNG, atomically.
///
/// # Errors
/// The file cannot be written.
pub fn write_quality_chart(path: &Path, report: &CvReport) -> Result<()> {
    let img = quality_chart(report, 900);
    crate::io::atomic::write_atomic(path, |w| {
        let enc = image::codecs::png::PngEncoder::new(w);
        img.write_with_encoder(enc).map_err(std::io::Error::other)
    })
    .map_err(|e| Error::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bridged_frames_are_the_filled_fits_coefficients() {
        // The policy itself is tested in `fit::gaps`; here, what a sentence takes of it.
        let fit = |frame, value| FrameFit {
            identity: vec![1.0],
            expression: vec![value],
            ..FrameFit::unposed(frame)
        };
        let (frames, bridged) =
            bridged_coefficients(&[fit(0, 0.0), fit(2, 4.0)], 3, 25.0, &[]).unwrap();
        let values: Vec<[f64; 2]> = frames.iter().map(|c| [c[0], c[1]]).collect();
        assert_eq!((values, bridged), (vec![[1.0, 0.0], [1.0, 2.0], [1.0, 4.0]], 1));
    }
}
