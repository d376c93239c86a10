//! Speech-driven animation use cases: train the AV-HMM on the clips of sessions that carry
//! audio, evaluate a trained model on a session (AMSE, ACC, and the W/H tables of the
//! speech-driven head against the video), and animate the session's model from new audio.
//!
//! A clip's training pair is its audio (aligned by the clip's audio offset) and its fitted
//! mouth: the model-space vertices of the mapped lip landmarks (iBUG 48–67) and chin (7–9),
//! minus the clip's neutral (the mean fitted coefficients over its silent frames,
//! [`neutral_coefficients`]). Frames whose fit failed hold the last good fit, so the audio
//! and visual sequences stay frame-aligned.
//!
//! Start with [`train_speech`], [`evaluate_speech`] and [`animate_speech`]; model files are
//! [`SpeechModelFile`]s, read with [`load_speech_model`].

use super::error::{Error, Result, Warning};
use super::evaluate::{EvalReport, Normalisation, evaluate, utterance_of_clip};
use super::fit::fit_clip_cached;
use super::resources::Resources;
use super::session::{ReadSession, clip_length, open_for_read};
use super::{Progress, ProgressFn};
use crate::eval::Utterance;
use crate::fit::{FrameFit, GapError, fill_gaps, fitted_shape};
use crate::io::npy_model;
use crate::io::wav::read_wav_at_rate;
use crate::math::{DMatrix, Point3, Vector3};
use crate::measure::MeshMeasureOptions;
use crate::model::{LandmarkMap, MorphableModel};
use crate::session::{ClipAudio, Session};
use crate::speech::{
    Coefficients, InversionOptions, MouthClip, MouthDriver, SpeechError, SpeechModel,
    SpeechOptions, TrainingClip, average_correlation, average_mse, frame_count, mouth_points,
    neutral_coefficients, stack_rows, train_speech_model,
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

/// The iBUG landmarks whose vertices make the mouth: outer and inner lips and the chin,
/// which carries the jaw.
pub fn mouth_landmarks() -> impl Iterator<Item = usize> {
    (48..68).chain(7..10)
}

/// A trained model as saved: the speech model and the morphable model it drives.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SpeechModelFile {
    pub format: String,
    pub version: u32,
    pub speech: SpeechModel,
    pub head: HeadBinding,
}

/// The morphable model whose mouth the speech model learnt, and its neutral.
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
    /// Mean neutral coefficients over the training clips: the face animation starts from.
    pub neutral_identity: Vec<f64>,
    pub neutral_expression: Vec<f64>,
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
}

/// Reads a speech model file: format, version, then [`SpeechModel::validate`].
///
/// # Errors
/// One line naming the file: unreadable, not a speech model, another version, inconsistent.
pub fn load_speech_model(path: &Path) -> Result<SpeechModelFile> {
    let fail = |msg: String| Error::Invalid(format!("{}: {msg}", path.display()));
    let head = crate::io::json_model::read_json_model(path, &crate::io::json_model::SPEECH_MODEL)?;
    let file: SpeechModelFile =
        serde_json::from_value(head).map_err(|e| fail(format!("bad speech model: {e}")))?;
    file.speech.validate().map_err(|e| fail(format!("inconsistent speech model: {e}")))?;
    if file.speech.features.mouth_vertices != file.head.mouth_vertices.len() {
        return Err(fail("the mouth vertices disagree with the visual basis".into()));
    }
    Ok(file)
}

/// Writes a speech model file atomically (a failed write leaves the old one).
///
/// # Errors
/// The file cannot be written.
pub fn save_speech_model(path: &Path, file: &SpeechModelFile) -> Result<()> {
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
    /// The paper's t_c 3 with [`crate::speech::TrainOptions`]' N 16, M 2.
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
    pub warnings: Vec<Warning>,
}

/// One clip made ready for the speech model.
struct ClipData {
    clip: usize,
    fps: f64,
    samples: Vec<f32>,
    /// Per frame 0..n: the fit used (failed frames hold the last good one).
    fits: Vec<FrameFit>,
    mouth: Vec<Vec<Point3>>,
    neutral: Coefficients,
    neutral_mouth: Vec<Point3>,
}

/// The model's vertices of the mouth landmarks.
fn mouth_vertices(map: &LandmarkMap) -> Result<Vec<usize>> {
    mouth_landmarks()
        .map(|l| {
            map.vertex(l).ok_or_else(|| {
                Error::Invalid(format!(
                    "the landmark map has no vertex for iBUG point {l}; the speech model needs the lips (48–67) and chin (7–9)"
                ))
            })
        })
        .collect()
}

/// The clip's audio as mono samples at `rate`, shifted so sample 0 is at the front view's
/// frame 0 (silence where the recording starts later).
///
/// # Errors
/// The WAV's one-line error; an offset that starts the audio after the clip's end.
pub fn clip_samples(audio: &ClipAudio, rate: u32, clip_seconds: f64) -> Result<Vec<f32>> {
    // An offset is only meaningful while audio and frames overlap; checked before any
    // padding is allocated, so a wild offset in a session file cannot size it.
    if !(audio.offset_s.is_finite() && audio.offset_s < clip_seconds) {
        return Err(Error::Invalid(format!(
            "audio offset {} s starts the audio after the clip's end ({clip_seconds:.2} s)",
            audio.offset_s
        )));
    }
    let samples = read_wav_at_rate(&audio.file, rate)?;
    let shift = (audio.offset_s * f64::from(rate)).round();
    Ok(if shift >= 0.0 {
        let mut out = vec![0.0; shift as usize];
        out.extend_from_slice(&samples);
        out
    } else {
        samples.get((-shift) as usize..).unwrap_or_default().to_vec()
    })
}

/// Fits (from cache) clip `clip` and pairs its audio with its mouth; `Ok(None)` with a
/// warning when the clip has no audio or no good fit.
fn clip_data(
    session: &mut Session,
    res: &Resources,
    clip: usize,
    mouth: &[usize],
    progress: ProgressFn<'_>,
    warnings: &mut Vec<Warning>,
) -> Result<Option<ClipData>> {
    let c = session.clip(clip)?;
    let name = c.name.clone();
    let fps = c.front.fps;
    let Some(audio) = c.audio.clone() else {
        warnings.push(Warning(format!("clip `{name}` has no audio; not used")));
        return Ok(None);
    };
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
    let fits = fit_clip_cached(session, res, clip, &settings, Some(&steps))?.fits;
    // Frames without a usable fit are filled in by the fit's gap policy (too long a gap is
    // not speech); checked before the audio is sized by the clip's length.
    let fits = match fill_gaps(&fits, n, fps, &[]) {
        Ok(filled) => filled.fits,
        Err(GapError::NoUsableFit) => {
            warnings.push(Warning(format!("clip `{name}` has no successful fit; not used")));
            return Ok(None);
        }
        Err(why) => {
            warnings.push(Warning(format!("clip `{name}`: {why}; not used")));
            return Ok(None);
        }
    };
    let samples = clip_samples(&audio, SPEECH_SAMPLE_RATE, n as f64 / fps)
        .map_err(|e| Error::Invalid(format!("clip `{name}`: {e}")))?;
    let coefficients: Vec<Coefficients> = fits
        .iter()
        .map(|f| Coefficients { identity: f.identity.clone(), expression: f.expression.clone() })
        .collect();
    let neutral = neutral_coefficients(&coefficients, &silent).map_err(speech_error)?;
    let shape_mouth = |c: &Coefficients| {
        mouth_points(&res.model.shape_at(&c.identity, &c.expression), mouth).map_err(speech_error)
    };
    let neutral_mouth = shape_mouth(&neutral)?;
    let mouth_frames = fits
        .iter()
        .map(|f| mouth_points(&fitted_shape(&res.model, f), mouth).map_err(speech_error))
        .collect::<Result<_>>()?;
    Ok(Some(ClipData { clip, fps, samples, fits, mouth: mouth_frames, neutral, neutral_mouth }))
}

fn speech_error(e: SpeechError) -> Error {
    Error::Invalid(e.to_string())
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

/// Trains a speech model on every clip with audio of `sessions` (which must share their
/// morphable model and frame rate). Progress: a stage per clip fit, then one step per
/// Baum–Welch iteration.
///
/// # Errors
/// A session, model or WAV that cannot be read; no clip with audio; sessions of different
/// models or frame rates; the training's error.
pub fn train_speech(
    sessions: &[String],
    settings: &SpeechTrainSettings,
    progress: ProgressFn<'_>,
) -> Result<SpeechTrained> {
    let mut warnings = Vec::new();
    let mut data: Vec<ClipData> = Vec::new();
    let mut binding: Option<(HeadBinding, PathBuf)> = None;
    for s in sessions {
        let mut o = open(s)?;
        warnings.append(&mut o.read.notices);
        let mref = o.read.session.model.clone().ok_or(Error::NoModel)?;
        match &binding {
            Some((b, first)) if b.mouth_vertices != o.mouth => {
                return Err(Error::Invalid(format!(
                    "{s}: its model or landmark map differs from {}'s; train on sessions of one model",
                    first.display()
                )));
            }
            Some(_) => {}
            None => {
                binding = Some((
                    HeadBinding {
                        model: mref.path,
                        blendshapes: mref.blendshapes,
                        model_vertices: o.res.model.num_vertices(),
                        mouth_vertices: o.mouth.clone(),
                        landmarks: o.res.map.to_vertex.clone(),
                        neutral_identity: Vec::new(),
                        neutral_expression: Vec::new(),
                    },
                    o.read.path.clone(),
                ));
            }
        }
        for clip in 0..o.read.session.clips.len() {
            let d = clip_data(&mut o.read.session, &o.res, clip, &o.mouth, progress, &mut warnings)
                .map_err(|e| e.context(s))?;
            data.extend(d);
        }
        o.read.save_if_locked()?;
    }
    let (mut head, _) = binding.ok_or_else(|| Error::Invalid("no sessions given".into()))?;
    let fps = data
        .first()
        .map(|d| d.fps)
        .ok_or_else(|| Error::Invalid("no clip with audio and fits to train on".into()))?;
    if let Some(d) = data.iter().find(|d| (d.fps - fps).abs() > 1e-9) {
        return Err(Error::Invalid(format!(
            "clip {} runs at {} fps, the first at {fps}: train on clips of one frame rate",
            d.clip, d.fps
        )));
    }
    let neutrals: Vec<Coefficients> = data.iter().map(|d| d.neutral.clone()).collect();
    let mean = neutral_coefficients(&neutrals, &[]).map_err(speech_error)?;
    (head.neutral_identity, head.neutral_expression) = (mean.identity, mean.expression);

    let mut opts = SpeechOptions::new(f64::from(SPEECH_SAMPLE_RATE), fps);
    opts.context = settings.context;
    opts.train.n_states = settings.states;
    opts.train.n_mixtures = settings.mixtures;
    let clips: Vec<TrainingClip> = data
        .iter()
        .map(|d| TrainingClip {
            samples: &d.samples,
            mouth: MouthClip { frames: &d.mouth, neutral: &d.neutral_mouth },
        })
        .collect();
    let frames = clips.iter().map(|c| c.mouth.frames.len()).sum();
    let total = opts.train.max_iterations;
    progress(Progress::Stage {
        what: format!("training the AV-HMM on {} clips, {frames} frames", clips.len()),
        total,
    });
    let speech = train_speech_model(&clips, &opts, &mut |i, _| {
        progress(Progress::Steps { done: i, total });
    })
    .map_err(|e| Error::Invalid(format!("training: {e}")))?;
    progress(Progress::Finished);
    let file = SpeechModelFile {
        format: SPEECH_MODEL_FORMAT.into(),
        version: SPEECH_MODEL_VERSION,
        speech,
        head,
    };
    Ok(SpeechTrained { file, clips: clips.len(), frames, warnings })
}

/// AMSE (eq. 6) and ACC (eq. 7) of one estimator.
#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct SpeechScores {
    pub amse: f64,
    pub acc: f64,
}

/// How a speech model does on a session.
#[derive(Clone, Debug)]
pub struct SpeechEvaluation {
    pub clips: usize,
    pub frames: usize,
    pub hmm: SpeechScores,
    pub linear: SpeechScores,
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
    /// Utterances (video vs head) with the head driven by the AV-HMM, the baseline, the fit.
    pub utterance_hmm: Utterance,
    pub utterance_linear: Utterance,
    pub utterance_fitted: Utterance,
}

/// Drives the session's head from clip `clip`'s audio with `model`; `Ok(None)` with a
/// warning for a clip without audio or fits. Used by `speech eval` and the TUI's charts.
///
/// # Errors
/// The model was trained on other features (frame rate) or another morphable model; the
/// WAV's, the fit's or the inversion's error.
pub fn drive_clip(
    model: &SpeechModelFile,
    session: &mut Session,
    res: &Resources,
    clip: usize,
    progress: ProgressFn<'_>,
    warnings: &mut Vec<Warning>,
) -> Result<Option<DrivenClip>> {
    let mouth = mouth_vertices(&res.map)?;
    if mouth != model.head.mouth_vertices {
        return Err(Error::Invalid(
            "the session's model or landmark map is not the one the speech model was trained on"
                .into(),
        ));
    }
    model.head.check_model(&res.model, session.base_dir())?;
    let Some(d) = clip_data(session, res, clip, &mouth, progress, warnings)? else {
        return Ok(None);
    };
    let sm = &model.speech;
    let here = crate::speech::FeatureDescription {
        mfcc: crate::speech::MfccOptions::new(f64::from(SPEECH_SAMPLE_RATE), d.fps),
        ..sm.features.clone()
    };
    sm.features.check_matches(&here).map_err(speech_error)?;
    let audio = sm.audio_features(&d.samples, d.mouth.len()).map_err(speech_error)?;
    let truth = sm
        .visual
        .project(&MouthClip { frames: &d.mouth, neutral: &d.neutral_mouth })
        .map_err(speech_error)?;
    let hmm = sm
        .inverter()
        .and_then(|inv| inv.invert(&audio, &InversionOptions::default()))
        .map_err(speech_error)?;
    let linear = sm.baseline.predict(&audio).map_err(speech_error)?;
    let driver = MouthDriver::new(&res.model, &mouth, DRIVER_RIDGE).map_err(speech_error)?;
    let drive = |features: &DMatrix| -> Result<Vec<FrameFit>> {
        let coefficients = drive_coefficients(sm, &driver, &d.neutral, features)?;
        Ok(d.fits
            .iter()
            .zip(coefficients)
            .map(|(f, c)| FrameFit { identity: c.identity, expression: c.expression, ..f.clone() })
            .collect())
    };
    let opts = MeshMeasureOptions::default();
    let utterance = |fits: &[FrameFit]| -> Result<Utterance> {
        Ok(utterance_of_clip(session, res, d.clip, fits, &opts)?.0)
    };
    let utterance_hmm = utterance(&drive(&hmm)?)?;
    let utterance_linear = utterance(&drive(&linear)?)?;
    let utterance_fitted = utterance(&d.fits)?;
    Ok(Some(DrivenClip { truth, hmm, linear, utterance_hmm, utterance_linear, utterance_fitted }))
}

/// Coefficients per frame that move the neutral's mouth as `features` (T × K) say.
fn drive_coefficients(
    model: &SpeechModel,
    driver: &MouthDriver,
    neutral: &Coefficients,
    features: &DMatrix,
) -> Result<Vec<Coefficients>> {
    let zero = vec![Point3::origin(); model.visual.n_vertices()];
    let mouths = model.visual.reconstruct(features, &zero).map_err(speech_error)?;
    mouths
        .iter()
        .map(|m| {
            let d: Vec<Vector3> = m.iter().map(|p| p.coords).collect();
            driver.drive(neutral, &d).map_err(speech_error)
        })
        .collect()
}

/// Evaluates `model` on every clip with audio of `session`.
///
/// # Errors
/// As [`drive_clip`]; no clip with audio; fewer than 2 frames.
pub fn evaluate_speech(
    model: &SpeechModelFile,
    session: &str,
    normalisation: Normalisation,
    progress: ProgressFn<'_>,
) -> Result<SpeechEvaluation> {
    let mut o = open(session)?;
    let mut warnings: Vec<Warning> = std::mem::take(&mut o.read.notices);
    let mut driven = Vec::new();
    for clip in 0..o.read.session.clips.len() {
        let d = drive_clip(model, &mut o.read.session, &o.res, clip, progress, &mut warnings)
            .map_err(|e| e.context(session))?;
        driven.extend(d);
    }
    o.read.save_if_locked()?;
    progress(Progress::Finished);
    if driven.is_empty() {
        return Err(Error::Invalid(format!("{session}: no clip with audio and fits")));
    }
    let stack = |f: fn(&DrivenClip) -> &DMatrix| {
        stack_rows(&driven.iter().map(|d| f(d).clone()).collect::<Vec<_>>())
    };
    let truth = stack(|d| &d.truth);
    let scores = |est: &DMatrix| -> Result<SpeechScores> {
        Ok(SpeechScores {
            amse: average_mse(&truth, est).map_err(speech_error)?,
            acc: average_correlation(&truth, est).map_err(speech_error)?,
        })
    };
    let hmm = scores(&stack(|d| &d.hmm))?;
    let linear = scores(&stack(|d| &d.linear))?;
    let report = |f: fn(&DrivenClip) -> &Utterance| {
        let utterances: Vec<Utterance> = driven.iter().map(|d| f(d).clone()).collect();
        evaluate(&utterances, &[], normalisation, 10)
    };
    Ok(SpeechEvaluation {
        clips: driven.len(),
        frames: truth.nrows(),
        hmm,
        linear,
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
    /// `shapes.npy`: one flat 3N model shape per frame (rows, f32).
    pub shapes: PathBuf,
    /// `head_shapes.npy`: the same on the transferred head, when one was given.
    pub head_shapes: Option<PathBuf>,
}

/// A head to transfer the animation to: its OBJ and its landmark map (TOML).
#[derive(Clone, Debug)]
pub struct TransferHead<'a> {
    pub obj: &'a Path,
    pub map: &'a Path,
}

/// Animates the speech model's morphable model from `audio` (any WAV at the model's rate or
/// faster) into the folder `out`: per frame at the model's frame rate, the AV-HMM's mouth on
/// the training neutral as `shapes.npy`, and the same on `head`, through
/// [`crate::transfer`], as `head_shapes.npy`.
///
/// Each frame's mesh goes to the files as it is made: whole meshes of a minute of speech on
/// a real head take gigabytes, the coefficients a few hundred kilobytes. The files appear only
/// when complete.
///
/// # Errors
/// The WAV's one-line error; audio shorter than one frame; the bound model cannot be read;
/// the head or its map cannot be read or the transfer cannot be set up; `out` cannot be made
/// or written.
pub fn animate_speech(
    model: &SpeechModelFile,
    audio: &Path,
    head: Option<TransferHead<'_>>,
    out: &Path,
    progress: ProgressFn<'_>,
) -> Result<AnimationFiles> {
    let sm = &model.speech;
    let rate = sm.features.mfcc.sample_rate.round() as u32;
    let samples = read_wav_at_rate(audio, rate)?;
    let n = frame_count(samples.len(), &sm.features.mfcc);
    if n < 1 {
        return Err(Error::Invalid(format!("{}: shorter than one video frame", audio.display())));
    }
    let mm = model.head.load_model()?;
    // The head is checked before the long inversion, so a wrong path fails at once.
    let transfer = head.as_ref().map(|h| head_transfer(model, &mm, h)).transpose()?;
    progress(Progress::Stage { what: format!("inverting {n} frames"), total: 0 });
    let estimate = sm.estimate_visual(&samples, n, &InversionOptions::default());
    let estimate = estimate.map_err(|e| Error::Invalid(format!("{}: {e}", audio.display())))?;
    let driver =
        MouthDriver::new(&mm, &model.head.mouth_vertices, DRIVER_RIDGE).map_err(speech_error)?;
    let coefficients = drive_coefficients(sm, &driver, &model.head.neutral(), &estimate)?;

    std::fs::create_dir_all(out).map_err(|e| Error::io(out, e))?;
    let shapes = out.join("shapes.npy");
    let mut shapes_npy =
        npy_model::NpyF32Writer::create(&shapes, &[n as u64, 3 * mm.num_vertices() as u64])?;
    // The transferred head's writer, with what names it in errors.
    let mut on_head = match (transfer, &head) {
        (Some((transfer, vertices)), Some(h)) => {
            let path = out.join("head_shapes.npy");
            let npy = npy_model::NpyF32Writer::create(&path, &[n as u64, 3 * vertices as u64])?;
            Some((transfer, npy, path, h.obj))
        }
        _ => None,
    };
    progress(Progress::Stage { what: format!("writing {n} frames"), total: n });
    for (t, c) in coefficients.iter().enumerate() {
        let shape = mm.shape_at(&c.identity, &c.expression);
        shapes_npy.write(shape.as_slice())?;
        if let Some((transfer, npy, _, obj)) = &mut on_head {
            let moved = transfer
                .apply(&shape)
                .map_err(|e| Error::Invalid(format!("{}: transfer: {e}", obj.display())))?;
            npy.write(moved.as_slice())?;
        }
        progress(Progress::Steps { done: t + 1, total: n });
    }
    shapes_npy.finish()?;
    let head_shapes = match on_head {
        Some((_, npy, path, _)) => {
            npy.finish()?;
            Some(path)
        }
        None => None,
    };
    progress(Progress::Finished);
    Ok(AnimationFiles { frames: n, fps: sm.features.mfcc.frame_rate, shapes, head_shapes })
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
