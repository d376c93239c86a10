//! Speech-driven animation use cases: train the AV-HMM on the clips of sessions that carry
//! audio (with a held-out estimate beside the training fit), evaluate a trained model on a
//! session (AMSE, ACC, whether the session was trained on, and the W/H tables of the
//! speech-driven head against the video), and animate the model's head from new audio.
//!
//! A clip's training pair is its audio (aligned by the clip's audio offset, streamed from
//! the file into per-frame log mel energies) and its fitted mouth: the model-space vertices
//! of the mapped lip landmarks (iBUG 48–67) and chin (7–9), minus the clip's neutral (the
//! mean fitted coefficients over its silent frames, [`neutral_coefficients`]), carried onto
//! the reference face ([`crate::speech::SpeakerNormaliser`]: the first training session's
//! mean neutral, stored in the model). Frames whose fit failed, or whose flags discredit
//! the fit (a tracker's gross error), are bridged from their neighbours, so the audio and
//! visual sequences stay frame-aligned and a tracker's error is not taught as speech.
//!
//! Start with [`train_speech`], [`evaluate_speech`] and [`animate_speech`]; model files are
//! [`SpeechModelFile`]s, read with [`load_speech_model`].

use super::audio::clip_log_mel;
use super::error::{Error, Result, Warning};
use super::evaluate::{EvalReport, Normalisation, evaluate, utterance_of_clip};
use super::fit::fit_clip_cached;
use super::flags::clip_flags;
use super::resources::Resources;
use super::session::{ReadSession, clip_length, open_for_read};
use super::{Progress, ProgressFn};
use crate::eval::Utterance;
use crate::fit::{FrameFit, GapError, fill_gaps};
use crate::io::npy_model;
use crate::io::wav::WavStream;
use crate::landmarks::flags::FlagThresholds;
use crate::landmarks::ibug::{self, PointNo, point_range};
use crate::math::{DMatrix, DVector, Point3, Vector3};
use crate::measure::MeshMeasureOptions;
use crate::model::{LandmarkMap, MorphableModel};
use crate::session::Session;
use crate::speech::{
    Coefficients, FaceRegion, LogMelAnalyser, MfccOptions, MouthClip, MouthDriver,
    SpeakerAdaptation, SpeakerNormaliser, SpeechError, SpeechModel, SpeechOptions, TrainingClip,
    average_correlation, average_mse, frame_features, mouth_points, neutral_coefficients,
    stack_context, stack_rows, visual_basis_of,
};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// What a speech model file says it is (`io::json_model`).
pub const SPEECH_MODEL_FORMAT: &str = crate::io::json_model::SPEECH_MODEL.format;
/// The version this lipmap writes and reads.
pub const SPEECH_MODEL_VERSION: u32 = crate::io::json_model::SPEECH_MODEL.version;
/// The audio rate models are trained at (audio recorded faster is downsampled).
pub const SPEECH_SAMPLE_RATE: u32 = 16_000;
/// Relative ridge of [`MouthDriver`]: small, so reachable mouth shapes are reproduced.
const DRIVER_RIDGE: f64 = 1e-3;
/// The reference face kept in a model: vertices within this fraction of the mouth's width
/// (corner to corner) of a mouth vertex.
const REGION_RADIUS: f64 = 0.35;
/// Bandwidth of the speaker normalisation as a fraction of the mouth's width: a few
/// neighbouring vertices of a usual mesh (5 mm on a 50 mm mouth). Half or twice it gave
/// held-out ACC 0.58 and 0.70 on a demo speaker of other proportions, against 0.77.
const NORMALISATION_BANDWIDTH: f64 = 0.1;
/// Largest magnitude of a neutral coefficient in a model file (coefficients are in prior
/// units, a few at most for a real face).
const MAX_COEFFICIENT: f64 = 1e3;
/// Every fifth clip is held out for the estimate `speech train` reports …
const HELD_OUT_EVERY: usize = 5;
/// … when there are at least this many clips.
const MIN_CLIPS_FOR_HELD_OUT: usize = 10;

/// The iBUG landmarks whose vertices make the mouth: outer and inner lips and the chin,
/// which carries the jaw.
pub fn mouth_landmarks() -> impl Iterator<Item = usize> {
    (ibug::OUTER_LIP.start..ibug::INNER_LIP.end).chain(MOUTH_CHIN)
}

/// The chin points of [`mouth_landmarks`] (0-based): the gnathion and its neighbours.
const MOUTH_CHIN: std::ops::Range<usize> = 7..10;

/// Positions in the mouth list of the mouth corners (iBUG 48 and 54), whose distance is the
/// mouth's width.
const MOUTH_CORNERS: (usize, usize) = (0, 6);

/// A trained model as saved: the speech model, the morphable model it drives and what it
/// was trained on.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SpeechModelFile {
    pub format: String,
    pub version: u32,
    pub speech: SpeechModel,
    pub head: HeadBinding,
    /// The clips trained on, so that scoring a session can say whether it overlaps them.
    pub trained_on: Vec<TrainedClip>,
    /// Scores on clips held out of training, and the fit on trained ones (absent with fewer
    /// than 10 clips).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub held_out: Option<HeldOutEstimate>,
}

/// One clip a model was trained on.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct TrainedClip {
    pub session: PathBuf,
    pub clip: String,
    /// Content hash of its audio ([`WavStream::content_hash`]).
    pub audio_hash: u64,
}

/// What `speech train` measured on clips it did not train on.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HeldOutEstimate {
    /// Held-out clips and frames, scored by a model trained on the other clips.
    pub clips: usize,
    pub frames: usize,
    pub hmm: SpeechScores,
    pub linear: SpeechScores,
    /// The same model on as many of its own training clips (the training fit).
    pub training_clips: usize,
    pub training_hmm: SpeechScores,
    pub training_linear: SpeechScores,
}

/// The morphable model whose mouth the speech model learnt, and the reference face.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct HeadBinding {
    /// The model file (absolute) and its blendshapes.
    pub model: PathBuf,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub blendshapes: Option<PathBuf>,
    /// Vertex count of that model (a model file changed since is refused).
    pub model_vertices: usize,
    /// The model's vertices of [`mouth_landmarks`].
    pub mouth_vertices: Vec<usize>,
    /// The landmark map (iBUG index → vertex), for transferring to other heads.
    pub landmarks: BTreeMap<usize, usize>,
    /// The reference face's neutral coefficients (the first training session's mean
    /// neutral): the face visual features are expressed on, and animation starts from.
    pub neutral_identity: Vec<f64>,
    pub neutral_expression: Vec<f64>,
    /// The reference face around the mouth, to carry other speakers' motion onto it.
    pub region: FaceRegion,
}

impl HeadBinding {
    fn neutral(&self) -> Coefficients {
        Coefficients {
            identity: self.neutral_identity.clone(),
            expression: self.neutral_expression.clone(),
        }
    }

    /// Loads the bound morphable model, checking it is the one trained with.
    ///
    /// # Errors
    /// The model's `FormatError`; a model whose vertex count changed.
    pub fn load_model(&self) -> Result<MorphableModel> {
        let model = crate::io::model_source::load_model(&self.model, self.blendshapes.as_deref())?;
        self.check_model(&model, &self.model)?;
        Ok(model)
    }

    fn check_model(&self, model: &MorphableModel, path: &Path) -> Result<()> {
        if model.num_vertices() != self.model_vertices {
            return Err(Error::Invalid(format!(
                "{}: the speech model was trained on a model with {} vertices, this one has {}",
                path.display(),
                self.model_vertices,
                model.num_vertices()
            )));
        }
        Ok(())
    }

    /// Checks every index and number of a binding read from a file.
    fn validate(&self) -> std::result::Result<(), SpeechError> {
        use crate::speech::SpeechError::Field;
        let field = |f: &str, reason: String| Field { field: format!("head.{f}"), reason };
        let n = self.model_vertices;
        if n == 0 {
            return Err(field("model_vertices", "0".into()));
        }
        let past = |v: usize| format!("vertex {v} is past the model's {n}");
        if let Some(&v) = self.mouth_vertices.iter().find(|&&v| v >= n) {
            return Err(field("mouth_vertices", past(v)));
        }
        if let Some((&l, &v)) = self.landmarks.iter().find(|&(&l, &v)| v >= n || l >= 68) {
            return Err(field("landmarks", format!("landmark {} → {}", PointNo(l), past(v))));
        }
        if let Some(&v) = self.region.vertices.iter().find(|&&v| v >= n) {
            return Err(field("region.vertices", past(v)));
        }
        if self.region.mouth.len() != self.mouth_vertices.len()
            || self
                .region
                .mouth
                .iter()
                .zip(&self.mouth_vertices)
                .any(|(&i, &v)| self.region.vertices.get(i) != Some(&v))
        {
            return Err(field("region.mouth", "does not name the mouth vertices".into()));
        }
        self.region
            .validate(crate::speech::hmm::MAX_PARAMETER)
            .map_err(|e| field("region", e.to_string()))?;
        crate::speech::error::check_finite_within(
            "head.neutral_identity",
            self.neutral_identity.iter().copied(),
            MAX_COEFFICIENT,
        )?;
        crate::speech::error::check_finite_within(
            "head.neutral_expression",
            self.neutral_expression.iter().copied(),
            MAX_COEFFICIENT,
        )
    }

    /// The mouth's width on the reference face.
    fn mouth_width(&self) -> f64 {
        let p = |k: usize| self.region.points[self.region.mouth[k]];
        (p(MOUTH_CORNERS.0) - p(MOUTH_CORNERS.1)).norm()
    }

    /// The reference face's neutral mouth.
    fn reference_mouth(&self) -> Vec<Point3> {
        self.region.mouth.iter().map(|&i| self.region.points[i]).collect()
    }
}

/// Reads a speech model file: format, version, then every number
/// ([`SpeechModel::validate`], the head binding's indices and coefficients, the recorded
/// scores).
///
/// # Errors
/// One line naming the file: unreadable, not a speech model, another version, a value out
/// of its range (named by its field).
pub fn load_speech_model(path: &Path) -> Result<SpeechModelFile> {
    let fail = |msg: String| Error::Invalid(format!("{}: {msg}", path.display()));
    let head = crate::io::json_model::read_json_model(path, &crate::io::json_model::SPEECH_MODEL)?;
    let file: SpeechModelFile =
        serde_json::from_value(head).map_err(|e| fail(format!("bad speech model: {e}")))?;
    check_model_file(&file).map_err(|e| fail(format!("bad speech model: {e}")))?;
    Ok(file)
}

/// Every number of a model file in its range, the first fault named by its field
/// (`speech.visual.mean[3]: 1e308 is not a finite number within ±1e6`).
fn check_model_file(file: &SpeechModelFile) -> std::result::Result<(), SpeechError> {
    let in_speech = |e: SpeechError| match e {
        SpeechError::Field { field, reason } => {
            SpeechError::Field { field: format!("speech.{field}"), reason }
        }
        other => other,
    };
    file.speech.validate().map_err(in_speech)?;
    file.head.validate()?;
    if file.speech.features.mouth_vertices != file.head.mouth_vertices.len() {
        return Err(SpeechError::Field {
            field: "head.mouth_vertices".into(),
            reason: "disagree with the visual basis".into(),
        });
    }
    if let Some(h) = &file.held_out {
        for (name, s) in [
            ("hmm", &h.hmm),
            ("linear", &h.linear),
            ("training_hmm", &h.training_hmm),
            ("training_linear", &h.training_linear),
        ] {
            crate::speech::error::check_finite_within(
                &format!("held_out.{name}"),
                [s.amse, s.acc],
                crate::speech::hmm::MAX_PARAMETER,
            )?;
        }
    }
    Ok(())
}

/// Writes a speech model file atomically (a failed write leaves the old one). It is held
/// to the rules a load checks first: training that produced a non-finite or out-of-range
/// value stops here, naming the field, instead of writing a file no command could read.
///
/// # Errors
/// A value out of its range (nothing written); the file cannot be written.
pub fn save_speech_model(path: &Path, file: &SpeechModelFile) -> Result<()> {
    check_model_file(file).map_err(|e| {
        Error::Invalid(format!("{}: not written: the trained model has {e}", path.display()))
    })?;
    let text = serde_json::to_string(file)
        .map_err(|e| Error::Invalid(format!("{}: {e}", path.display())))?;
    crate::io::atomic::write_atomic_bytes(path, text.as_bytes())
        .map_err(|e| Error::Io { path: path.to_path_buf(), source: e })
}

/// Training settings from the command line.
#[derive(Clone, Debug, PartialEq)]
pub struct SpeechTrainSettings {
    pub states: usize,
    pub mixtures: usize,
    pub context: usize,
}

impl Default for SpeechTrainSettings {
    /// The paper's t_c 3 with [`crate::speech::TrainOptions`]' N 16, M 4.
    fn default() -> Self {
        let t = crate::speech::TrainOptions::default();
        Self { states: t.n_states, mixtures: t.n_mixtures, context: 3 }
    }
}

/// A trained model and what it was trained on.
#[derive(Clone, Debug)]
pub struct SpeechTrained {
    pub file: SpeechModelFile,
    pub clips: usize,
    pub frames: usize,
    /// The model size used, when the corpus was too small for the one asked for.
    pub shrunk: Option<(usize, usize)>,
    /// Baum–Welch on the clips kept for the held-out estimate (from k-means), before the
    /// model's last run on all clips continued from it (`file.speech.report`).
    pub kept_run: Option<KeptRun>,
    pub warnings: Vec<Warning>,
}

/// The first Baum–Welch run of a training with a held-out estimate.
#[derive(Clone, Debug, PartialEq)]
pub struct KeptRun {
    /// Clips it trained on.
    pub clips: usize,
    pub report: crate::speech::TrainReport,
}

/// A clip's fits made ready: bridged over discredited frames, and its neutral.
struct ClipFits {
    clip: usize,
    name: String,
    fps: f64,
    /// Per frame 0..n: the fit used (failed frames hold the last good one), without the
    /// per-landmark residuals (1.6 KB a frame that nothing here reads).
    held: Vec<FrameFit>,
    /// The coefficients with failed and discredited frames bridged: the visual truth.
    bridged: Vec<Coefficients>,
    neutral: Coefficients,
}

/// Fits (from cache) clip `clip` and makes its fits ready; `Ok(None)` with a warning when
/// the clip has no audio or no usable fit.
fn clip_fits(
    session: &mut Session,
    res: &Resources,
    clip: usize,
    progress: ProgressFn<'_>,
    warnings: &mut Vec<Warning>,
) -> Result<Option<ClipFits>> {
    let c = session.clip(clip)?;
    let name = c.name.clone();
    let fps = c.front.fps;
    if c.audio.is_none() {
        warnings.push(Warning(format!("lipmap: warning: clip `{name}` has no audio; not used")));
        return Ok(None);
    }
    let silent_of = |t: f64| {
        c.alignment
            .as_ref()
            .and_then(|a| a.phone_at(t))
            .is_some_and(|p| crate::reference::current().phones.is_silence(&p.label))
    };
    let n = clip_length(session, clip)?;
    let silent: Vec<bool> = (0..n).map(|f| silent_of(f as f64 / fps)).collect();
    progress(Progress::Stage { what: format!("fitting {name}"), total: 0 });
    let steps = |done: usize, total: usize| progress(Progress::Steps { done, total });
    let settings = session.fit_settings.clone();
    let clip_fits = fit_clip_cached(session, res, clip, &settings, Some(&steps))?;
    warnings.extend(clip_fits.map_warning);
    let fits = clip_fits.fits;
    // Frames without a usable fit are filled in by the fit's gap policy (too long a gap is
    // not speech); checked before the audio is sized by the clip's length.
    let held = match fill_gaps(&fits, n, fps, &[]) {
        Ok(filled) => filled.fits,
        Err(GapError::NoUsableFit) => {
            warnings.push(Warning(format!(
                "lipmap: warning: clip `{name}` has no successful fit; not used"
            )));
            return Ok(None);
        }
        Err(why) => {
            warnings.push(Warning(format!("lipmap: warning: clip `{name}`: {why}; not used")));
            return Ok(None);
        }
    };
    let track = session.effective_track(clip)?;
    let mut discredited: Vec<usize> = clip_flags(&track, &fits, &[], &FlagThresholds::default())
        .iter()
        .filter(|f| f.reasons.iter().any(|r| r.discredits_frame()))
        .map(|f| f.frame)
        .collect();
    discredited.sort_unstable();
    // The same policy with the discredited frames left out too gives the visual truth.
    let bridged: Vec<Coefficients> = fill_gaps(&fits, n, fps, &discredited)
        .map_or_else(|_| held.clone(), |f| f.fits)
        .into_iter()
        .map(|f| Coefficients { identity: f.identity, expression: f.expression })
        .collect();
    let mut held = held;
    held.iter_mut().for_each(|f| f.residuals = Vec::new());
    let neutral = neutral_coefficients(&bridged, &silent).map_err(speech_error)?;
    Ok(Some(ClipFits { clip, name, fps, held, bridged, neutral }))
}

fn speech_error(e: SpeechError) -> Error {
    Error::Invalid(e.to_string())
}

/// A flat 3N shape as points.
fn points_of(shape: &DVector) -> Vec<Point3> {
    shape.as_slice().chunks_exact(3).map(|c| Point3::new(c[0], c[1], c[2])).collect()
}

/// The normaliser of a clip whose neutral face is `neutral` on `model`, to the reference
/// face of `head`.
fn normaliser_of(
    head: &HeadBinding,
    model: &MorphableModel,
    neutral: &Coefficients,
) -> Result<SpeakerNormaliser> {
    let shape = model.shape_at(&neutral.identity, &neutral.expression);
    let speaker: Vec<Point3> = head
        .region
        .vertices
        .iter()
        .map(|&v| Point3::new(shape[3 * v], shape[3 * v + 1], shape[3 * v + 2]))
        .collect();
    SpeakerNormaliser::between(&head.region, &speaker, NORMALISATION_BANDWIDTH * head.mouth_width())
        .map_err(speech_error)
}

/// The clip's mouth per frame (from its coefficients) carried onto the reference face: the
/// reference neutral mouth plus each frame's normalised displacement from the speaker's
/// neutral.
fn reference_mouth_frames(
    model: &MorphableModel,
    mouth: &[usize],
    frames: &[Coefficients],
    neutral: &Coefficients,
    normaliser: &SpeakerNormaliser,
    reference: &[Point3],
) -> Result<Vec<Vec<Point3>>> {
    let neutral_mouth =
        mouth_points(&model.shape_at(&neutral.identity, &neutral.expression), mouth)
            .map_err(speech_error)?;
    frames
        .iter()
        .map(|f| {
            let m = mouth_points(&model.shape_at(&f.identity, &f.expression), mouth)
                .map_err(speech_error)?;
            Ok(m.iter()
                .zip(&neutral_mouth)
                .zip(reference)
                .enumerate()
                .map(|(v, ((p, n), r))| r + normaliser.to_reference(v, &(p - n)))
                .collect())
        })
        .collect()
}

/// One session opened for reading with its resources and mouth vertices.
struct Opened {
    read: ReadSession,
    res: Resources,
    mouth: Vec<usize>,
}

fn open(session: &str) -> Result<Opened> {
    let read = open_for_read(session)?;
    let res = Resources::load(&read.session).map_err(|e| e.context(session))?;
    let mouth = mouth_vertices(&res.map)?;
    Ok(Opened { read, res, mouth })
}

/// The model's vertices of the mouth landmarks.
fn mouth_vertices(map: &LandmarkMap) -> Result<Vec<usize>> {
    mouth_landmarks()
        .map(|l| {
            map.vertex(l).ok_or_else(|| {
                Error::Invalid(format!(
                    "the landmark map has no vertex for iBUG point {}; the speech model needs the lips ({}) and chin ({})",
                    PointNo(l),
                    point_range(&(ibug::OUTER_LIP.start..ibug::INNER_LIP.end)),
                    point_range(&MOUTH_CHIN)
                ))
            })
        })
        .collect()
}

/// The reference face of a session's clips: their mean neutral on `model`.
fn reference_binding(
    o: &Opened,
    fits: &[ClipFits],
    model_path: (PathBuf, Option<PathBuf>),
) -> Result<HeadBinding> {
    let mean = speaker_neutral(fits)?;
    let mesh = points_of(&o.res.model.shape_at(&mean.identity, &mean.expression));
    let width = (mesh[o.mouth[MOUTH_CORNERS.0]] - mesh[o.mouth[MOUTH_CORNERS.1]]).norm();
    let region =
        FaceRegion::around(&mesh, &o.mouth, REGION_RADIUS * width).map_err(speech_error)?;
    Ok(HeadBinding {
        model: model_path.0,
        blendshapes: model_path.1,
        model_vertices: o.res.model.num_vertices(),
        mouth_vertices: o.mouth.clone(),
        landmarks: o.res.map.to_vertex.clone(),
        neutral_identity: mean.identity,
        neutral_expression: mean.expression,
        region,
    })
}

/// A training clip as kept: its audio's log mel energies and its mouth on the reference face.
struct ClipData {
    log_mel: DMatrix,
    mouth: Vec<Vec<Point3>>,
    trained: TrainedClip,
}

/// Trains a speech model on every clip with audio of `sessions` (whose models share their
/// vertices and landmark map, and clips their frame rate). Every fifth clip is first held
/// out: a model trained on the others is scored on it (and on as many of its own training
/// clips), then training continues on all the clips. Progress: a stage per clip fit, then
/// one step per Baum–Welch iteration.
///
/// # Errors
/// A session, model or WAV that cannot be read; audio covering too little of its clip; no
/// clip with audio; sessions of different models or frame rates; the training's error.
pub fn train_speech(
    sessions: &[String],
    settings: &SpeechTrainSettings,
    progress: ProgressFn<'_>,
) -> Result<SpeechTrained> {
    let mut warnings = Vec::new();
    let mut data: Vec<ClipData> = Vec::new();
    let mut binding: Option<(HeadBinding, PathBuf)> = None;
    let mut fps: Option<f64> = None;
    for s in sessions {
        let mut o = open(s)?;
        warnings.append(&mut o.read.notices);
        let mref = o.read.session.model.clone().ok_or(Error::NoModel)?;
        if let Some((b, first)) = &binding
            && (b.mouth_vertices != o.mouth || b.model_vertices != o.res.model.num_vertices())
        {
            return Err(Error::Invalid(format!(
                "{s}: its model or landmark map differs from {}'s; train on sessions of one model",
                first.display()
            )));
        }
        let mut fits = Vec::new();
        for clip in 0..o.read.session.clips.len() {
            let f = clip_fits(&mut o.read.session, &o.res, clip, progress, &mut warnings)
                .map_err(|e| e.context(s))?;
            fits.extend(f);
        }
        if binding.is_none() && !fits.is_empty() {
            let b = reference_binding(&o, &fits, (mref.path, mref.blendshapes))
                .map_err(|e| e.context(s))?;
            binding = Some((b, o.read.path.clone()));
        }
        if let Some((head, _)) = &binding
            && !fits.is_empty()
        {
            let reference = head.reference_mouth();
            let neutral = speaker_neutral(&fits).map_err(|e| e.context(s))?;
            let normaliser =
                normaliser_of(head, &o.res.model, &neutral).map_err(|e| e.context(s))?;
            for c in &fits {
                let rate = *fps.get_or_insert(c.fps);
                if (c.fps - rate).abs() > 1e-9 {
                    return Err(Error::Invalid(format!(
                        "{s}: clip `{}` runs at {} fps, the first at {rate}: train on clips of one frame rate",
                        c.name, c.fps
                    )));
                }
                let mouth = reference_mouth_frames(
                    &o.res.model,
                    &o.mouth,
                    &c.bridged,
                    &neutral,
                    &normaliser,
                    &reference,
                )?;
                let audio = o
                    .read
                    .session
                    .clip(c.clip)?
                    .audio
                    .clone()
                    .ok_or_else(|| Error::Invalid(format!("clip `{}` has no audio", c.name)))?;
                let sound = clip_log_mel(&c.name, &audio, &mfcc_options(rate), mouth.len())
                    .map_err(|e| e.context(s))?;
                warnings.extend(sound.warning);
                data.push(ClipData {
                    log_mel: sound.log_mel,
                    mouth,
                    trained: TrainedClip {
                        session: o.read.path.clone(),
                        clip: c.name.clone(),
                        audio_hash: sound.hash,
                    },
                });
            }
        }
        o.read.save_if_locked()?;
    }
    let (head, _) =
        binding.ok_or_else(|| Error::Invalid("no clip with audio and fits to train on".into()))?;
    let fps =
        fps.ok_or_else(|| Error::Invalid("no clip with audio and fits to train on".into()))?;
    let mut opts = SpeechOptions::new(f64::from(SPEECH_SAMPLE_RATE), fps);
    opts.context = settings.context;
    opts.train.n_states = settings.states;
    opts.train.n_mixtures = settings.mixtures;
    let frames: usize = data.iter().map(|d| d.mouth.len()).sum();
    let shrunk = fit_model_size(&mut opts, frames);
    if let Some((n, m)) = shrunk {
        let per_dimension = match MIN_FRAMES_PER_DIMENSION {
            1 => "one training frame".to_string(),
            k => format!("{k} training frames"),
        };
        warnings.push(Warning(format!(
            "lipmap: warning: {frames} frames are too few for {} states × {} mixtures of \
             {}-dimensional Gaussians (each needs on average {per_dimension} per dimension); \
             training {n} × {m} instead (more sentences allow more)",
            settings.states,
            settings.mixtures,
            opts.features(head.mouth_vertices.len()).audio_dim() + opts.visual_components
        )));
    }
    let reference = head.reference_mouth();
    let clips: Vec<TrainingClip> = data
        .iter()
        .map(|d| TrainingClip {
            log_mel: &d.log_mel,
            mouth: MouthClip { frames: &d.mouth, neutral: &reference },
        })
        .collect();
    let (speech, held_out, kept_run) = train_with_held_out(&clips, &opts, progress)?;
    progress(Progress::Finished);
    let n_clips = clips.len();
    drop(clips);
    let file = SpeechModelFile {
        format: SPEECH_MODEL_FORMAT.into(),
        version: SPEECH_MODEL_VERSION,
        speech,
        head,
        trained_on: data.into_iter().map(|d| d.trained).collect(),
        held_out,
    };
    check_model_file(&file).map_err(|e| Error::Invalid(format!("training: {e}")))?;
    Ok(SpeechTrained { file, clips: n_clips, frames, shrunk, kept_run, warnings })
}

/// The audio analysis of models trained on clips at `fps`.
fn mfcc_options(fps: f64) -> MfccOptions {
    MfccOptions::new(f64::from(SPEECH_SAMPLE_RATE), fps)
}

/// Training frames each Gaussian needs per dimension of its vector: a full covariance of
/// dimension d has d(d + 3)/2 parameters, but the covariance floor (a ridge from the whole
/// corpus's variances) carries what few frames cannot; d frames per component on average
/// let 130 sentences train 16 × 4 (held-out ACC 0.013–0.017 above 16 × 2, which 2d frames
/// forced) and keep the 12-sentence example above the linear baseline (docs/speech.md).
pub const MIN_FRAMES_PER_DIMENSION: usize = 1;

/// Shrinks `opts`' states (then mixtures) until every Gaussian has on average
/// [`MIN_FRAMES_PER_DIMENSION`] frames per dimension; the new size when it changed.
fn fit_model_size(opts: &mut SpeechOptions, frames: usize) -> Option<(usize, usize)> {
    let dim = crate::speech::features::frame_dim(&opts.mfcc) * (2 * opts.context + 1)
        + opts.visual_components;
    let most = (frames / (MIN_FRAMES_PER_DIMENSION * dim)).max(2);
    let (mut n, mut m) = (opts.train.n_states, opts.train.n_mixtures);
    if n * m <= most {
        return None;
    }
    while m > 1 && n * m > most {
        m -= 1;
    }
    n = n.min(most / m).max(2);
    opts.train.n_states = n;
    opts.train.n_mixtures = m;
    Some((n, m))
}

/// AMSE and ACC of `model` (HMM and baseline) on `clips`.
fn score_clips(
    model: &SpeechModel,
    clips: &[TrainingClip],
) -> Result<(SpeechScores, SpeechScores, usize)> {
    let inverter = model.inverter().map_err(speech_error)?;
    let mut truth = Vec::new();
    let mut hmm = Vec::new();
    let mut linear = Vec::new();
    for c in clips {
        let audio = model.audio_features(c.log_mel).map_err(speech_error)?;
        truth.push(model.visual_features(&c.mouth).map_err(speech_error)?);
        hmm.push(model.estimate_visual(&inverter, &audio).map_err(speech_error)?);
        linear.push(model.estimate_linear(&audio).map_err(speech_error)?);
    }
    let truth = stack_rows(&truth);
    Ok((scores(&truth, &stack_rows(&hmm))?, scores(&truth, &stack_rows(&linear))?, truth.nrows()))
}

/// Trains on all `clips`, first holding out every fifth to score a model trained on the
/// rest (when there are enough), then continuing Baum–Welch from that model on all of them.
fn train_with_held_out(
    clips: &[TrainingClip],
    opts: &SpeechOptions,
    progress: ProgressFn<'_>,
) -> Result<(SpeechModel, Option<HeldOutEstimate>, Option<KeptRun>)> {
    let training =
        |what: String,
         clips: &[TrainingClip],
         model: Option<(crate::speech::VisualBasis, crate::speech::Hmm)>| {
            let total = opts.train.max_iterations;
            progress(Progress::Stage { what, total });
            let mut step = |i: usize, _: f64| progress(Progress::Steps { done: i, total });
            match model {
                Some((basis, hmm)) => SpeechModel::train(clips, opts, basis, Some(hmm), &mut step),
                None => visual_basis_of(clips, opts)
                    .and_then(|basis| SpeechModel::train(clips, opts, basis, None, &mut step)),
            }
            .map_err(|e| Error::Invalid(format!("training: {e}")))
        };
    let frames: usize = clips.iter().map(|c| c.mouth.frames.len()).sum();
    if clips.len() < MIN_CLIPS_FOR_HELD_OUT {
        let model = training(
            format!("training the AV-HMM on {} clips, {frames} frames", clips.len()),
            clips,
            None,
        )?;
        return Ok((model, None, None));
    }
    let part_of = |held: bool| -> Vec<TrainingClip> {
        let is_held = |i: usize| i % HELD_OUT_EVERY == HELD_OUT_EVERY - 1;
        clips.iter().enumerate().filter(|(i, _)| is_held(*i) == held).map(|(_, c)| *c).collect()
    };
    let (held, kept) = (part_of(true), part_of(false));
    let part = training(
        format!("training on {} clips ({} held out)", kept.len(), held.len()),
        &kept,
        None,
    )?;
    progress(Progress::Stage { what: format!("scoring {} held-out clips", held.len()), total: 0 });
    let (hmm, linear, held_frames) = score_clips(&part, &held)?;
    // The training fit on as many training clips, spread over the corpus.
    let stride = (kept.len() / held.len()).max(1);
    let sample: Vec<TrainingClip> = kept.iter().step_by(stride).take(held.len()).copied().collect();
    let (training_hmm, training_linear, _) = score_clips(&part, &sample)?;
    let estimate = HeldOutEstimate {
        clips: held.len(),
        frames: held_frames,
        hmm,
        linear,
        training_clips: sample.len(),
        training_hmm,
        training_linear,
    };
    let kept_run = KeptRun { clips: kept.len(), report: part.report.clone() };
    let model = training(
        format!("training on all {} clips, {frames} frames", clips.len()),
        clips,
        Some((part.visual.clone(), part.hmm.clone())),
    )?;
    Ok((model, Some(estimate), Some(kept_run)))
}

/// AMSE (eq. 6) and ACC (eq. 7) of one estimator.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SpeechScores {
    pub amse: f64,
    pub acc: f64,
}

/// AMSE and ACC of `estimate` against `truth`; finite, or an error saying why not.
fn scores(truth: &DMatrix, estimate: &DMatrix) -> Result<SpeechScores> {
    let s = SpeechScores {
        amse: average_mse(truth, estimate).map_err(speech_error)?,
        acc: average_correlation(truth, estimate).map_err(speech_error)?,
    };
    if !(s.amse.is_finite() && s.acc.is_finite()) {
        return Err(Error::Invalid(format!(
            "the scores are not finite numbers (AMSE {}, ACC {}): the truth or the estimate overflowed",
            s.amse, s.acc
        )));
    }
    Ok(s)
}

/// Whether a scored session's clips were among a model's training clips.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Overlap {
    /// Clips scored whose audio (the same samples) the model was trained on.
    pub trained_on: usize,
    pub scored: usize,
}

/// How a speech model does on a session.
#[derive(Clone, Debug)]
pub struct SpeechEvaluation {
    pub clips: usize,
    /// How the estimates were adapted to the session's speaker.
    pub adaptation: SpeakerAdaptationChoice,
    pub frames: usize,
    pub hmm: SpeechScores,
    pub linear: SpeechScores,
    pub overlap: Overlap,
    /// The W/H/P tables of the AV-HMM-driven head, the baseline-driven head and the fitted
    /// head, each against the video.
    pub report_hmm: EvalReport,
    pub report_linear: EvalReport,
    pub report_fitted: EvalReport,
    pub warnings: Vec<Warning>,
}

/// The speech-driven trajectories of one clip.
pub struct DrivenClip {
    /// Visual features: the fitted mouth's, the AV-HMM's and the baseline's (T × K each).
    pub truth: DMatrix,
    pub hmm: DMatrix,
    pub linear: DMatrix,
    /// Whether the model was trained on this clip's audio (the same samples).
    pub trained_on: bool,
    /// Utterances (video vs head) with the head driven by the AV-HMM, the baseline, the fit.
    pub utterance_hmm: Utterance,
    pub utterance_linear: Utterance,
    pub utterance_fitted: Utterance,
}

/// Drives the session's head from clip `clip`'s audio with `model`; `Ok(None)` with a
/// warning for a clip without audio or fits. Used by `speech eval` and the TUI's charts.
/// The estimate is adapted to the session's speaker from the visual truth of its other
/// clips ([`crate::speech::adaptation`]).
///
/// # Errors
/// The model was trained on other features (frame rate) or another morphable model; audio
/// covering too little of the clip; the WAV's, the fit's or the inversion's error.
pub fn drive_clip(
    model: &SpeechModelFile,
    session: &mut Session,
    res: &Resources,
    clip: usize,
    progress: ProgressFn<'_>,
    warnings: &mut Vec<Warning>,
) -> Result<Option<DrivenClip>> {
    check_session_model(model, res, session)?;
    // The speaker's neutral is the whole session's; the other clips' warnings are theirs.
    let mut others = Vec::new();
    let mut fits = Vec::new();
    for k in 0..session.clips.len() {
        let said = if k == clip { &mut *warnings } else { &mut others };
        fits.extend(clip_fits(session, res, k, progress, said)?);
    }
    let Some(i) = fits.iter().position(|c| c.clip == clip) else {
        return Ok(None);
    };
    let speaker = SessionSpeaker::of(model, res, &fits, SpeakerAdaptationChoice::OtherClips)?;
    drive_fitted(model, session, res, &fits[i], &speaker, i, warnings).map(Some)
}

/// `Ok` when `res`' model and map are those `model` was trained on.
fn check_session_model(model: &SpeechModelFile, res: &Resources, session: &Session) -> Result<()> {
    let mouth = mouth_vertices(&res.map)?;
    if mouth != model.head.mouth_vertices {
        return Err(Error::Invalid(
            "the session's model or landmark map is not the one the speech model was trained on"
                .into(),
        ));
    }
    model.head.check_model(&res.model, session.base_dir())
}

/// A speaker's neutral: the mean of the neutrals of the speaker's clips (a clip's own, from
/// its few silent frames, carries its fit's noise; every clip of a session is one speaker).
fn speaker_neutral(fits: &[ClipFits]) -> Result<Coefficients> {
    let neutrals: Vec<Coefficients> = fits.iter().map(|c| c.neutral.clone()).collect();
    neutral_coefficients(&neutrals, &[]).map_err(speech_error)
}

/// Whether estimates are adapted to the scored speaker's visual statistics.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum SpeakerAdaptationChoice {
    /// From the visual truth of the speaker's other clips (each clip's own left out).
    OtherClips,
    /// Not at all: the training speakers' parameters as they are.
    Off,
}

/// The speaker of a session's clips as a model sees them: its neutral, the map of its face
/// onto the model's reference face, each clip's visual truth and each clip's adaptation.
struct SessionSpeaker {
    neutral: Coefficients,
    normaliser: SpeakerNormaliser,
    truths: Vec<DMatrix>,
    adaptations: Vec<SpeakerAdaptation>,
}

impl SessionSpeaker {
    fn of(
        model: &SpeechModelFile,
        res: &Resources,
        fits: &[ClipFits],
        choice: SpeakerAdaptationChoice,
    ) -> Result<Self> {
        let neutral = speaker_neutral(fits)?;
        let normaliser = normaliser_of(&model.head, &res.model, &neutral)?;
        let reference = model.head.reference_mouth();
        let sm = &model.speech;
        let truths = fits
            .iter()
            .map(|c| {
                let frames = reference_mouth_frames(
                    &res.model,
                    &model.head.mouth_vertices,
                    &c.bridged,
                    &neutral,
                    &normaliser,
                    &reference,
                )?;
                sm.visual_features(&MouthClip { frames: &frames, neutral: &reference })
                    .map_err(speech_error)
            })
            .collect::<Result<Vec<_>>>()?;
        let adaptations = match choice {
            SpeakerAdaptationChoice::OtherClips => {
                sm.adaptations_leaving_out(&truths).map_err(speech_error)?
            }
            SpeakerAdaptationChoice::Off => {
                vec![SpeakerAdaptation::identity(sm.visual.n_components()); truths.len()]
            }
        };
        Ok(Self { neutral, normaliser, truths, adaptations })
    }
}

/// [`drive_clip`] of a clip's fits, the `i`th clip of `speaker`.
fn drive_fitted(
    model: &SpeechModelFile,
    session: &Session,
    res: &Resources,
    c: &ClipFits,
    speaker: &SessionSpeaker,
    i: usize,
    warnings: &mut Vec<Warning>,
) -> Result<DrivenClip> {
    let mouth = &model.head.mouth_vertices;
    let sm = &model.speech;
    let here =
        crate::speech::FeatureDescription { mfcc: mfcc_options(c.fps), ..sm.features.clone() };
    sm.features.check_matches(&here).map_err(speech_error)?;
    let audio = session
        .clip(c.clip)?
        .audio
        .clone()
        .ok_or_else(|| Error::Invalid("the clip has no audio".into()))?;
    let sound = clip_log_mel(&c.name, &audio, &sm.features.mfcc, c.held.len())?;
    warnings.extend(sound.warning);
    let features = sm.audio_features(&sound.log_mel).map_err(speech_error)?;
    let adapt = |estimate: DMatrix| sm.adapt(&speaker.adaptations[i], &estimate);
    let hmm = sm
        .inverter()
        .and_then(|inv| sm.estimate_visual(&inv, &features))
        .and_then(adapt)
        .map_err(speech_error)?;
    let linear = sm.estimate_linear(&features).and_then(adapt).map_err(speech_error)?;
    let driver = MouthDriver::new(&res.model, mouth, DRIVER_RIDGE).map_err(speech_error)?;
    let drive = |estimate: &DMatrix| -> Result<Vec<FrameFit>> {
        let coefficients =
            drive_coefficients(sm, &driver, &speaker.neutral, estimate, Some(&speaker.normaliser))?;
        Ok(c.held
            .iter()
            .zip(coefficients)
            .map(|(f, k)| FrameFit { identity: k.identity, expression: k.expression, ..f.clone() })
            .collect())
    };
    let opts = MeshMeasureOptions::default();
    let utterance = |fits: &[FrameFit]| -> Result<Utterance> {
        Ok(utterance_of_clip(session, res, c.clip, fits, &opts, Default::default())?.0)
    };
    let utterance_hmm = utterance(&drive(&hmm)?)?;
    let utterance_linear = utterance(&drive(&linear)?)?;
    let utterance_fitted = utterance(&c.held)?;
    let trained_on = model.trained_on.iter().any(|t| t.audio_hash == sound.hash);
    Ok(DrivenClip {
        truth: speaker.truths[i].clone(),
        hmm,
        linear,
        trained_on,
        utterance_hmm,
        utterance_linear,
        utterance_fitted,
    })
}

/// Coefficients per frame that move the neutral's mouth as `features` (T × K, on the
/// reference face) say, carried onto the speaker's face by `normaliser` when given.
fn drive_coefficients(
    model: &SpeechModel,
    driver: &MouthDriver,
    neutral: &Coefficients,
    features: &DMatrix,
    normaliser: Option<&SpeakerNormaliser>,
) -> Result<Vec<Coefficients>> {
    let zero = vec![Point3::origin(); model.visual.n_vertices()];
    let mouths = model.visual.reconstruct(features, &zero).map_err(speech_error)?;
    mouths
        .iter()
        .enumerate()
        .map(|(t, m)| {
            let d: Vec<Vector3> = m
                .iter()
                .enumerate()
                .map(|(v, p)| normaliser.map_or(p.coords, |n| n.from_reference(v, &p.coords)))
                .collect();
            let c = driver.drive(neutral, &d).map_err(speech_error)?;
            if c.identity.iter().chain(&c.expression).any(|x| !x.is_finite()) {
                return Err(Error::Invalid(format!(
                    "frame {t}: the driven head's coefficients are not finite numbers"
                )));
            }
            Ok(c)
        })
        .collect()
}

/// Evaluates `model` on every clip with audio of `session`, each clip's estimates adapted
/// to the session's speaker as `adaptation` says (by default from the visual truth of the
/// speaker's other clips, never the clip's own).
///
/// # Errors
/// As [`drive_clip`]; no clip with audio; fewer than 2 frames; scores that are not finite.
pub fn evaluate_speech(
    model: &SpeechModelFile,
    session: &str,
    normalisation: Normalisation,
    adaptation: SpeakerAdaptationChoice,
    progress: ProgressFn<'_>,
) -> Result<SpeechEvaluation> {
    let mut o = open(session)?;
    let mut warnings: Vec<Warning> = std::mem::take(&mut o.read.notices);
    check_session_model(model, &o.res, &o.read.session).map_err(|e| e.context(session))?;
    let mut fits = Vec::new();
    for clip in 0..o.read.session.clips.len() {
        let f = clip_fits(&mut o.read.session, &o.res, clip, progress, &mut warnings)
            .map_err(|e| e.context(session))?;
        fits.extend(f);
    }
    o.read.save_if_locked()?;
    if fits.is_empty() {
        return Err(Error::Invalid(format!("{session}: no clip with audio and fits")));
    }
    let speaker =
        SessionSpeaker::of(model, &o.res, &fits, adaptation).map_err(|e| e.context(session))?;
    let mut driven = Vec::new();
    for (i, c) in fits.iter().enumerate() {
        let d = drive_fitted(model, &o.read.session, &o.res, c, &speaker, i, &mut warnings)
            .map_err(|e| e.context(session))?;
        driven.push(d);
    }
    progress(Progress::Finished);
    if driven.is_empty() {
        return Err(Error::Invalid(format!("{session}: no clip with audio and fits")));
    }
    let stack = |f: fn(&DrivenClip) -> &DMatrix| {
        stack_rows(&driven.iter().map(|d| f(d).clone()).collect::<Vec<_>>())
    };
    let truth = stack(|d| &d.truth);
    let hmm = scores(&truth, &stack(|d| &d.hmm))?;
    let linear = scores(&truth, &stack(|d| &d.linear))?;
    let report = |f: fn(&DrivenClip) -> &Utterance| {
        let utterances: Vec<Utterance> = driven.iter().map(|d| f(d).clone()).collect();
        let mut r = evaluate(&utterances, &[], normalisation, 10);
        for t in [&mut r.sentences, &mut r.phonemes, &mut r.visemes, &mut r.worst_frames] {
            t.name_conditions(&normalisation.label(), None);
        }
        r
    };
    Ok(SpeechEvaluation {
        clips: driven.len(),
        adaptation,
        frames: truth.nrows(),
        hmm,
        linear,
        overlap: Overlap {
            trained_on: driven.iter().filter(|d| d.trained_on).count(),
            scored: driven.len(),
        },
        report_hmm: report(|d| &d.utterance_hmm),
        report_linear: report(|d| &d.utterance_linear),
        report_fitted: report(|d| &d.utterance_fitted),
        warnings,
    })
}

/// What [`animate_speech`] wrote.
#[derive(Clone, Debug, PartialEq)]
pub struct AnimationFiles {
    /// Frames, at `fps` (the model's frame rate).
    pub frames: usize,
    pub fps: f64,
    /// `coefficients.npy`: per frame the model's identity then expression coefficients.
    pub coefficients: PathBuf,
    /// `mouth.npy`: per frame the mouth vertices (x y z each, model space).
    pub mouth: PathBuf,
    /// `shapes.npy`: one flat 3N model shape per frame, when asked for.
    pub shapes: Option<PathBuf>,
    /// `head_shapes.npy`: the same on the transferred head, when one was given.
    pub head_shapes: Option<PathBuf>,
}

/// A head to transfer the animation to: its OBJ and its landmark map (TOML).
#[derive(Clone, Debug)]
pub struct TransferHead<'a> {
    pub obj: &'a Path,
    pub map: &'a Path,
}

/// What [`animate_speech`] writes besides the coefficients and the mouth.
#[derive(Clone, Debug, Default)]
pub struct AnimateOutputs<'a> {
    /// Every frame's whole mesh (`shapes.npy`; 85 KB a frame on the demo head, 7 GB for an
    /// hour at 24 fps).
    pub shapes: bool,
    /// The animation carried onto another head (`head_shapes.npy`).
    pub head: Option<TransferHead<'a>>,
}

/// Frames of audio inverted at once by [`animate_speech`] …
const WINDOW_S: f64 = 30.0;
/// … with this much audio on either side, whose estimates are discarded: the state
/// posteriors, the context and the smoothing of a frame this far from a window's edge are
/// those of the whole recording (a unit test compares them).
const MARGIN_S: f64 = 2.0;

/// Animates the speech model's morphable model from `audio` (any WAV at the model's rate or
/// faster) into the folder `out`: per frame at the model's frame rate, the coefficients
/// (`coefficients.npy`) and the mouth vertices (`mouth.npy`) of the reference face driven by
/// the AV-HMM, and, when asked, every frame's mesh (`shapes.npy`) and the same carried onto
/// another head through [`crate::transfer`] (`head_shapes.npy`).
///
/// The WAV is read and analysed block by block; the per-frame audio features of the whole
/// recording are kept (the normalisation is the recording's), 14 values a frame; the
/// inversion runs on windows of 30 s, and each frame goes to the files as it is made. An
/// hour of speech thus needs tens of megabytes, not the gigabytes of its samples or meshes.
/// The files appear only when complete.
///
/// # Errors
/// The WAV's one-line error; audio shorter than one frame; the bound model cannot be read;
/// the head or its map cannot be read or the transfer cannot be set up; a non-finite value
/// (the model file's damage shows there); `out` cannot be made or written.
pub fn animate_speech(
    model: &SpeechModelFile,
    audio: &Path,
    outputs: &AnimateOutputs<'_>,
    out: &Path,
    progress: ProgressFn<'_>,
) -> Result<AnimationFiles> {
    let sm = &model.speech;
    let rate = sm.features.mfcc.sample_rate.round() as u32;
    let mut stream = WavStream::open_at_rate(audio, rate)?;
    let fail = |e: SpeechError| Error::Invalid(format!("{}: {e}", audio.display()));
    let mut analyser = LogMelAnalyser::new(&sm.features.mfcc, None).map_err(fail)?;
    progress(Progress::Stage { what: format!("reading {}", audio.display()), total: 0 });
    let mut block = Vec::new();
    loop {
        block.clear();
        let more = stream.next_block(&mut block)?;
        analyser.push(&block).map_err(fail)?;
        if !more {
            break;
        }
    }
    let log_mel = analyser.finish();
    let n = log_mel.nrows();
    if n < 1 {
        return Err(Error::Invalid(format!("{}: shorter than one video frame", audio.display())));
    }
    let frame_rows =
        frame_features(&log_mel, &sm.features.mfcc, &sm.features.activity).map_err(fail)?;
    drop(log_mel);
    let mm = model.head.load_model()?;
    // The head is checked before the long inversion, so a wrong path fails at once.
    let transfer = outputs.head.as_ref().map(|h| head_transfer(model, &mm, h)).transpose()?;
    let driver =
        MouthDriver::new(&mm, &model.head.mouth_vertices, DRIVER_RIDGE).map_err(speech_error)?;
    let inverter = sm.inverter().map_err(speech_error)?;
    let neutral = model.head.neutral();
    let n_coefficients = neutral.identity.len() + neutral.expression.len();

    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let writer = |name: &str, width: usize| -> Result<(PathBuf, npy_model::NpyF32Writer)> {
        let path = out.join(name);
        let w = npy_model::NpyF32Writer::create(&path, &[n as u64, width as u64])?;
        Ok((path, w))
    };
    let (coefficients_path, mut coefficients_npy) = writer("coefficients.npy", n_coefficients)?;
    let (mouth_path, mut mouth_npy) = writer("mouth.npy", 3 * model.head.mouth_vertices.len())?;
    let mut shapes =
        outputs.shapes.then(|| writer("shapes.npy", 3 * mm.num_vertices())).transpose()?;
    // The transferred head's writer, with what names it in errors.
    let mut on_head = match (transfer, &outputs.head) {
        (Some((transfer, vertices)), Some(h)) => {
            let (path, npy) = writer("head_shapes.npy", 3 * vertices)?;
            Some((transfer, npy, path, h.obj))
        }
        _ => None,
    };
    progress(Progress::Stage { what: format!("animating {n} frames"), total: n });
    let fps = sm.features.mfcc.frame_rate;
    let (window, margin) = ((WINDOW_S * fps).ceil() as usize, (MARGIN_S * fps).ceil() as usize);
    let mut start = 0;
    while start < n {
        let end = (start + window).min(n);
        let estimate = estimate_window(sm, &inverter, &frame_rows, start, end, margin)
            .map_err(|e| Error::Invalid(format!("{}: {e}", audio.display())))?;
        let coefficients = drive_coefficients(sm, &driver, &neutral, &estimate, None)?;
        for (i, c) in coefficients.iter().enumerate() {
            let t = start + i;
            let shape = mm.shape_at(&c.identity, &c.expression);
            if let Some(v) = shape.iter().position(|x| !x.is_finite()) {
                return Err(Error::Invalid(format!(
                    "frame {t}: vertex {} of the driven head is not a finite number (is {} damaged?)",
                    v / 3,
                    model.head.model.display()
                )));
            }
            let flat: Vec<f64> = c.identity.iter().chain(&c.expression).copied().collect();
            coefficients_npy.write(&flat)?;
            let mouth = mouth_points(&shape, &model.head.mouth_vertices).map_err(speech_error)?;
            let mouth: Vec<f64> = mouth.iter().flat_map(|p| [p.x, p.y, p.z]).collect();
            mouth_npy.write(&mouth)?;
            if let Some((_, npy)) = &mut shapes {
                npy.write(shape.as_slice())?;
            }
            if let Some((transfer, npy, _, obj)) = &mut on_head {
                let moved = transfer
                    .apply(&shape)
                    .map_err(|e| Error::Invalid(format!("{}: transfer: {e}", obj.display())))?;
                npy.write(moved.as_slice())?;
            }
            progress(Progress::Steps { done: t + 1, total: n });
        }
        start = end;
    }
    coefficients_npy.finish()?;
    mouth_npy.finish()?;
    let shapes = match shapes {
        Some((path, npy)) => {
            npy.finish()?;
            Some(path)
        }
        None => None,
    };
    let head_shapes = match on_head {
        Some((_, npy, path, _)) => {
            npy.finish()?;
            Some(path)
        }
        None => None,
    };
    progress(Progress::Finished);
    Ok(AnimationFiles {
        frames: n,
        fps,
        coefficients: coefficients_path,
        mouth: mouth_path,
        shapes,
        head_shapes,
    })
}

/// The AV-HMM's estimate of frames `start..end` of a recording's per-frame audio features,
/// inverted with `margin` frames of the recording on either side (their estimates dropped).
fn estimate_window(
    model: &SpeechModel,
    inverter: &crate::speech::Inverter,
    frame_rows: &DMatrix,
    start: usize,
    end: usize,
    margin: usize,
) -> std::result::Result<DMatrix, SpeechError> {
    let from = start.saturating_sub(margin);
    let to = (end + margin).min(frame_rows.nrows());
    let audio =
        stack_context(&frame_rows.rows(from, to - from).into_owned(), model.features.context);
    let estimate = model.estimate_visual(inverter, &audio)?;
    Ok(estimate.rows(start - from, end - start).into_owned())
}

/// The transfer from the bound model's training neutral onto `head`, with the head's
/// vertex count.
fn head_transfer(
    model: &SpeechModelFile,
    mm: &MorphableModel,
    head: &TransferHead<'_>,
) -> Result<(crate::transfer::Transfer, usize)> {
    use crate::transfer::{SourceFace, TargetHead, Transfer, TransferOptions};
    let mesh = crate::io::obj::read_obj(head.obj)?;
    let target_map = crate::io::landmark_map_toml::read_landmark_map(head.map)?;
    let source_map = LandmarkMap { to_vertex: model.head.landmarks.clone() };
    let n = model.head.neutral();
    let reference = mm.shape_at(&n.identity, &n.expression);
    let skin = vec![true; mesh.vertices.len()];
    let transfer = Transfer::new(
        SourceFace {
            reference: &reference,
            triangles: &mm.triangles,
            landmarks: &source_map,
            identity: None,
            face: None,
        },
        TargetHead { mesh: &mesh, skin: &skin, landmarks: &target_map },
        &TransferOptions::default(),
    )
    .map_err(|e| Error::Invalid(format!("{}: transfer: {e}", head.obj.display())))?;
    Ok((transfer, mesh.vertices.len()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_small_corpus_shrinks_the_model_and_a_large_one_keeps_it() {
        let mut opts = SpeechOptions::new(16_000.0, 24.0);
        // 13 × 7 audio + 4 visual = 95 dimensions: 95 frames per Gaussian.
        assert_eq!(fit_model_size(&mut opts, 7_859), None);
        assert_eq!((opts.train.n_states, opts.train.n_mixtures), (16, 4));
        assert_eq!(fit_model_size(&mut opts, 734), Some((7, 1)));
        assert_eq!((opts.train.n_states, opts.train.n_mixtures), (7, 1));
        let mut opts = SpeechOptions::new(16_000.0, 24.0);
        assert_eq!(fit_model_size(&mut opts, 4_000), Some((16, 2)));
        assert_eq!(fit_model_size(&mut SpeechOptions::new(16_000.0, 24.0), 10), Some((2, 1)));
    }
}
