//! The trained speech-to-mouth model and the pipeline that builds and applies it: audio
//! features of each recording ([`super::features`], per-recording normalisation, speech
//! activity, co-articulation context) and visual features (mouth PCA, smoothed), joined frame
//! by frame into `o_avt = [o_atᵀ, o_vtᵀ]ᵀ`, the AV-HMM trained on them, and the linear
//! baseline beside it.
//!
//! A model records how its features were computed ([`FeatureDescription`]); applying it to
//! features computed differently (another frame rate, sample rate, context) is refused with
//! one line naming the difference, instead of silently producing nonsense.

use super::activity::ActivityOptions;
use super::adaptation::{PRIOR_FRAMES_S, SpeakerAdaptation, VisualMoments};
use super::baum_welch::{TrainOptions, TrainReport, improve_hmm, train_hmm};
use super::context::stack_context;
use super::error::{SpeechError, bad, check_finite_within, field_error};
use super::features::{LEVEL_SCALE, frame_dim, frame_features};
use super::hmm::{Hmm, MAX_PARAMETER};
use super::inversion::{InversionOptions, Inverter};
use super::mfcc::MfccOptions;
use super::regression::{LinearRegression, fit_linear_regression};
use super::smooth::smooth_rows;
use super::visual::{MouthClip, VisualBasis, fit_visual_basis};
use crate::math::DMatrix;
use serde::{Deserialize, Serialize};

/// Largest co-articulation context a model may ask for (a second each side at 25 fps).
pub const MAX_CONTEXT: usize = 25;
/// Most mouth vertices a model may describe.
pub const MAX_MOUTH_VERTICES: usize = 10_000;

/// How the features of a model were computed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FeatureDescription {
    pub mfcc: MfccOptions,
    pub activity: ActivityOptions,
    /// t_c: audio frames stacked on each side.
    pub context: usize,
    /// Visual PCA components.
    pub visual_components: usize,
    /// Mouth vertices per frame.
    pub mouth_vertices: usize,
    /// σ of the Gaussian that smooths visual features and estimates over time, seconds.
    pub smoothing_s: f64,
}

impl FeatureDescription {
    /// Width of the stacked audio vector: (n_ceps + 2) · (2 t_c + 1).
    pub fn audio_dim(&self) -> usize {
        frame_dim(&self.mfcc) * (2 * self.context + 1)
    }

    /// The smoothing σ in frames.
    pub fn smoothing_frames(&self) -> f64 {
        self.smoothing_s * self.mfcc.frame_rate
    }

    /// Checks every setting is within what the pipeline can mean (a model file's numbers
    /// size tables).
    ///
    /// # Errors
    /// The first setting out of range, named by its field.
    pub fn validate(&self) -> Result<(), SpeechError> {
        let at = |f: &str, e: SpeechError| field_error(format!("features.{f}"), e.to_string());
        self.mfcc.validate().map_err(|e| at("mfcc", e))?;
        self.activity.validate().map_err(|e| at("activity", e))?;
        if self.context > MAX_CONTEXT {
            return Err(field_error(
                "features.context",
                format!("{} frames is more than {MAX_CONTEXT}", self.context),
            ));
        }
        if !(1..=MAX_MOUTH_VERTICES).contains(&self.mouth_vertices) {
            return Err(field_error(
                "features.mouth_vertices",
                format!("{} is outside 1–{MAX_MOUTH_VERTICES}", self.mouth_vertices),
            ));
        }
        if !(1..=3 * self.mouth_vertices).contains(&self.visual_components) {
            return Err(field_error(
                "features.visual_components",
                format!("{} is outside 1–{}", self.visual_components, 3 * self.mouth_vertices),
            ));
        }
        if !(self.smoothing_s.is_finite() && (0.0..=1.0).contains(&self.smoothing_s)) {
            return Err(field_error(
                "features.smoothing_s",
                format!("{} is outside 0–1 s", crate::math::short_number(self.smoothing_s)),
            ));
        }
        Ok(())
    }

    /// `Ok` when `other` computes features exactly as `self` does.
    ///
    /// # Errors
    /// [`SpeechError::FeatureMismatch`] naming the first field that differs.
    pub fn check_matches(&self, other: &FeatureDescription) -> Result<(), SpeechError> {
        let (a, b) = (&self.mfcc, &other.mfcc);
        let (p, q) = (&self.activity, &other.activity);
        let fields: [(&'static str, String, String); 18] = [
            ("sample rate (Hz)", a.sample_rate.to_string(), b.sample_rate.to_string()),
            ("frame rate (fps)", a.frame_rate.to_string(), b.frame_rate.to_string()),
            ("window (s)", a.window_s.to_string(), b.window_s.to_string()),
            ("pre-emphasis", a.pre_emphasis.to_string(), b.pre_emphasis.to_string()),
            ("mel filters", a.n_filters.to_string(), b.n_filters.to_string()),
            ("cepstral coefficients", a.n_ceps.to_string(), b.n_ceps.to_string()),
            ("band low edge (Hz)", a.low_hz.to_string(), b.low_hz.to_string()),
            ("band high edge (Hz)", a.high_hz.to_string(), b.high_hz.to_string()),
            ("noise floor quantile", p.floor_quantile.to_string(), q.floor_quantile.to_string()),
            ("loud speech quantile", p.peak_quantile.to_string(), q.peak_quantile.to_string()),
            ("activity range (dB)", p.max_range_db.to_string(), q.max_range_db.to_string()),
            ("activity onset (dB)", p.onset_db.to_string(), q.onset_db.to_string()),
            ("activity full level (dB)", p.full_db.to_string(), q.full_db.to_string()),
            (
                "loudness range (dB)",
                p.loudness_range_db.to_string(),
                q.loudness_range_db.to_string(),
            ),
            ("context t_c", self.context.to_string(), other.context.to_string()),
            (
                "visual components",
                self.visual_components.to_string(),
                other.visual_components.to_string(),
            ),
            ("mouth vertices", self.mouth_vertices.to_string(), other.mouth_vertices.to_string()),
            ("smoothing (s)", self.smoothing_s.to_string(), other.smoothing_s.to_string()),
        ];
        match fields.into_iter().find(|(_, m, i)| m != i) {
            Some((field, model, input)) => {
                Err(SpeechError::FeatureMismatch { field, model, input })
            }
            None => Ok(()),
        }
    }
}

/// Everything training needs to know.
#[derive(Clone, Debug, PartialEq)]
pub struct SpeechOptions {
    pub mfcc: MfccOptions,
    pub activity: ActivityOptions,
    /// t_c; the paper's best results used 3.
    pub context: usize,
    /// Visual PCA components; the paper used 4.
    pub visual_components: usize,
    /// σ of the temporal smoothing, seconds ([`FeatureDescription::smoothing_s`]).
    pub smoothing_s: f64,
    pub train: TrainOptions,
    /// Relative ridge of the linear baseline.
    pub ridge: f64,
}

impl SpeechOptions {
    /// Defaults for audio at `sample_rate` Hz and video at `frame_rate` fps: t_c 3, 4 visual
    /// components, smoothing σ 40 ms (a frame at 25 fps: on held-out demo sentences, fitted
    /// motion smoothed so, and the estimate likewise, raised ACC from 0.81 to 0.84 against
    /// the fitted truth, and the estimate's agreement with the noise-free truth alike),
    /// [`TrainOptions::default`], ridge 10⁻³.
    pub fn new(sample_rate: f64, frame_rate: f64) -> Self {
        Self {
            mfcc: MfccOptions::new(sample_rate, frame_rate),
            activity: ActivityOptions::default(),
            context: 3,
            visual_components: 4,
            smoothing_s: 0.04,
            train: TrainOptions::default(),
            ridge: 1e-3,
        }
    }

    /// The description of the features these options compute for mouths of
    /// `mouth_vertices` vertices.
    pub fn features(&self, mouth_vertices: usize) -> FeatureDescription {
        FeatureDescription {
            mfcc: self.mfcc.clone(),
            activity: self.activity.clone(),
            context: self.context,
            visual_components: self.visual_components,
            mouth_vertices,
            smoothing_s: self.smoothing_s,
        }
    }
}

/// One training clip: its audio's log mel energies ([`super::mfcc::LogMelAnalyser`], one
/// row per video frame) and its mouth motion, on the reference face.
#[derive(Clone, Copy, Debug)]
pub struct TrainingClip<'a> {
    pub log_mel: &'a DMatrix,
    pub mouth: MouthClip<'a>,
}

/// A trained model: serialise it with serde; it checks itself on [`SpeechModel::validate`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SpeechModel {
    pub features: FeatureDescription,
    pub visual: VisualBasis,
    /// Covariance (K × K) of the training clips' visual features (projected and smoothed):
    /// the reference of [`super::adaptation`].
    pub visual_covariance: DMatrix,
    pub hmm: Hmm,
    pub baseline: LinearRegression,
    pub report: TrainReport,
}

/// Stacked audio features (T × audio_dim) of a recording's log mel energies.
///
/// # Errors
/// As [`frame_features`].
pub fn compute_audio_features(
    log_mel: &DMatrix,
    features: &FeatureDescription,
) -> Result<DMatrix, SpeechError> {
    Ok(stack_context(
        &frame_features(log_mel, &features.mfcc, &features.activity)?,
        features.context,
    ))
}

/// The audio and visual feature matrices of `clips`, the visual ones by `visual` (projected
/// and smoothed as [`SpeechModel::visual_features`] does).
fn clip_features(
    clips: &[TrainingClip],
    features: &FeatureDescription,
    visual: &VisualBasis,
) -> Result<(Vec<DMatrix>, Vec<DMatrix>), SpeechError> {
    let mut audio = Vec::with_capacity(clips.len());
    let mut vis = Vec::with_capacity(clips.len());
    for (i, c) in clips.iter().enumerate() {
        if c.log_mel.nrows() != c.mouth.frames.len() {
            return Err(bad(
                "training clip",
                format!(
                    "clip {i} has {} audio frames and {} mouth frames",
                    c.log_mel.nrows(),
                    c.mouth.frames.len()
                ),
            ));
        }
        audio.push(compute_audio_features(c.log_mel, features)?);
        vis.push(smooth_rows(&visual.project(&c.mouth)?, features.smoothing_frames()));
    }
    Ok((audio, vis))
}

/// Trains the AV-HMM and the baseline on `clips` with the visual basis fitted to their
/// mouths; `progress` as in [`train_hmm`].
///
/// # Errors
/// No clips, a clip without frames, any error of the feature extraction or training.
pub fn train_speech_model(
    clips: &[TrainingClip],
    opts: &SpeechOptions,
    progress: &mut dyn FnMut(usize, f64),
) -> Result<SpeechModel, SpeechError> {
    let visual = visual_basis_of(clips, opts)?;
    SpeechModel::train(clips, opts, visual, None, progress)
}

/// The visual PCA basis of `clips`' mouths.
///
/// # Errors
/// No clips, a clip without frames, and [`fit_visual_basis`]'s errors.
pub fn visual_basis_of(
    clips: &[TrainingClip],
    opts: &SpeechOptions,
) -> Result<VisualBasis, SpeechError> {
    if clips.is_empty() {
        return Err(SpeechError::Empty("training clips"));
    }
    if let Some(i) = clips.iter().position(|c| c.mouth.frames.is_empty()) {
        return Err(bad("training clip", format!("clip {i} has no frames")));
    }
    let mouths: Vec<MouthClip> = clips.iter().map(|c| c.mouth).collect();
    fit_visual_basis(&mouths, opts.visual_components)
}

/// Rows of all matrices, in order (they must share a width).
pub fn stack_rows(blocks: &[DMatrix]) -> DMatrix {
    let width = blocks.first().map_or(0, DMatrix::ncols);
    let mut out = DMatrix::zeros(blocks.iter().map(DMatrix::nrows).sum(), width);
    let mut r = 0;
    for b in blocks {
        out.rows_mut(r, b.nrows()).copy_from(b);
        r += b.nrows();
    }
    out
}

impl SpeechModel {
    /// Trains the AV-HMM (from k-means, or continuing from `start`, a model of the same
    /// features and size) and the baseline on `clips`, with the visual basis `visual`.
    ///
    /// # Errors
    /// No clips, clips whose audio and mouth frame counts differ, the features' or the
    /// training's errors, a model that fails [`SpeechModel::validate`].
    pub fn train(
        clips: &[TrainingClip],
        opts: &SpeechOptions,
        visual: VisualBasis,
        start: Option<Hmm>,
        progress: &mut dyn FnMut(usize, f64),
    ) -> Result<SpeechModel, SpeechError> {
        if clips.is_empty() {
            return Err(SpeechError::Empty("training clips"));
        }
        let features = opts.features(visual.n_vertices());
        features.validate()?;
        let (audio, vis) = clip_features(clips, &features, &visual)?;
        let joint: Vec<DMatrix> = audio
            .iter()
            .zip(&vis)
            .map(|(a, v)| {
                let mut j = DMatrix::zeros(a.nrows(), a.ncols() + v.ncols());
                j.columns_mut(0, a.ncols()).copy_from(a);
                j.columns_mut(a.ncols(), v.ncols()).copy_from(v);
                j
            })
            .collect();
        let (hmm, report) = match start {
            Some(h) => improve_hmm(h, &joint, &opts.train, progress)?,
            None => train_hmm(&joint, &opts.train, progress)?,
        };
        let baseline = fit_linear_regression(&stack_rows(&audio), &stack_rows(&vis), opts.ridge)?;
        let visual_covariance = VisualMoments::of(&stack_rows(&vis))
            .covariance()
            .ok_or(SpeechError::TooFew { what: "training frames", need: 2, got: 1 })?;
        let model = SpeechModel { features, visual, visual_covariance, hmm, baseline, report };
        model.validate()?;
        Ok(model)
    }

    /// Checks a model's every number and size (after loading, and of a model just trained):
    /// the feature settings, the visual basis (finite, within ±[`MAX_PARAMETER`],
    /// orthonormal components, positive variances), the HMM's distributions and Gaussians,
    /// the baseline's weights and the training log-likelihoods.
    ///
    /// # Errors
    /// The first fault, naming its field (`visual.mean[3]: 1e308 is not …`).
    pub fn validate(&self) -> Result<(), SpeechError> {
        self.features.validate()?;
        self.hmm.validate()?;
        let da = self.features.audio_dim();
        let dv = self.features.visual_components;
        let mismatch = |what, expected, got| SpeechError::DimensionMismatch { what, expected, got };
        if self.hmm.dim() != da + dv {
            return Err(mismatch("HMM dimension", da + dv, self.hmm.dim()));
        }
        let v = &self.visual;
        if v.components.ncols() != dv || v.variances.len() != dv {
            return Err(mismatch("visual basis components", dv, v.components.ncols()));
        }
        let dim = 3 * self.features.mouth_vertices;
        if v.mean.len() != dim || v.components.nrows() != dim {
            return Err(mismatch("visual basis rows", dim, v.mean.len()));
        }
        check_finite_within("visual.mean", v.mean.iter().copied(), MAX_PARAMETER)?;
        check_finite_within("visual.components", v.components.iter().copied(), 1.0 + 1e-6)?;
        check_finite_within("visual.variances", v.variances.iter().copied(), MAX_PARAMETER)?;
        if let Some(k) = v.variances.iter().position(|x| *x <= 0.0) {
            return Err(field_error(format!("visual.variances[{k}]"), "not positive"));
        }
        let gram = v.components.tr_mul(&v.components);
        if (gram - DMatrix::identity(dv, dv)).abs().max() > 1e-6 {
            return Err(field_error("visual.components", "the columns are not orthonormal"));
        }
        let c = &self.visual_covariance;
        if c.shape() != (dv, dv) {
            return Err(mismatch("visual covariance rows", dv, c.nrows()));
        }
        check_finite_within("visual_covariance", c.iter().copied(), MAX_PARAMETER)?;
        if (c - c.transpose()).abs().max() > 1e-9 * c.abs().max() || c.clone().cholesky().is_none()
        {
            return Err(field_error(
                "visual_covariance",
                "not a covariance (symmetric, positive definite)",
            ));
        }
        if self.baseline.weights.shape() != (da + 1, dv) {
            return Err(mismatch("baseline rows", da + 1, self.baseline.weights.nrows()));
        }
        check_finite_within(
            "baseline.weights",
            self.baseline.weights.iter().copied(),
            MAX_PARAMETER,
        )?;
        check_finite_within(
            "report.log_likelihood_per_frame",
            self.report.log_likelihood_per_frame.iter().copied(),
            MAX_PARAMETER,
        )?;
        Ok(())
    }

    /// Stacked audio features of a recording's log mel energies (one row per frame).
    ///
    /// # Errors
    /// As [`compute_audio_features`].
    pub fn audio_features(&self, log_mel: &DMatrix) -> Result<DMatrix, SpeechError> {
        compute_audio_features(log_mel, &self.features)
    }

    /// Visual features (T × K) of a mouth clip on the reference face: projected on the basis
    /// and smoothed.
    ///
    /// # Errors
    /// As [`VisualBasis::project`].
    pub fn visual_features(&self, mouth: &MouthClip) -> Result<DMatrix, SpeechError> {
        Ok(smooth_rows(&self.visual.project(mouth)?, self.features.smoothing_frames()))
    }

    /// The inverter of this model's HMM (build once, invert many clips).
    ///
    /// # Errors
    /// As [`Inverter::new`].
    pub fn inverter(&self) -> Result<Inverter, SpeechError> {
        Inverter::new(&self.hmm, self.features.audio_dim())
    }

    /// Visual features (T × K) estimated from stacked audio features by HMM inversion, then
    /// smoothed.
    ///
    /// # Errors
    /// As [`Inverter::invert`]; a non-finite estimate.
    pub fn estimate_visual(
        &self,
        inverter: &Inverter,
        audio: &DMatrix,
    ) -> Result<DMatrix, SpeechError> {
        let raw = inverter.invert(audio, &InversionOptions::default())?;
        self.finish_estimate(raw, audio, "AV-HMM")
    }

    /// The linear baseline's estimate (T × K), at rest in silence and smoothed as the
    /// AV-HMM's is.
    ///
    /// # Errors
    /// Audio of the wrong width; a non-finite estimate.
    pub fn estimate_linear(&self, audio: &DMatrix) -> Result<DMatrix, SpeechError> {
        let raw = self.baseline.predict(audio)?;
        self.finish_estimate(raw, audio, "linear baseline")
    }

    /// The map of the training speakers' visual parameters onto those of a speaker whose
    /// fitted clips have the visual features `speaker` ([`super::adaptation`]; the prior
    /// worth [`PRIOR_FRAMES_S`] of frames at the model's rate).
    ///
    /// # Errors
    /// As [`SpeakerAdaptation::new`].
    pub fn adaptation(&self, speaker: &VisualMoments) -> Result<SpeakerAdaptation, SpeechError> {
        SpeakerAdaptation::new(&self.visual_covariance, speaker, self.prior_frames())
    }

    /// Per clip of one speaker, the adaptation from the visual truth of the speaker's other
    /// clips (`truths`, T × K each).
    ///
    /// # Errors
    /// As [`SpeakerAdaptation::new`].
    pub fn adaptations_leaving_out(
        &self,
        truths: &[DMatrix],
    ) -> Result<Vec<SpeakerAdaptation>, SpeechError> {
        super::adaptation::leave_one_out(&self.visual_covariance, truths, self.prior_frames())
    }

    /// `estimate` (T × K) as the speaker's of `adaptation`.
    ///
    /// # Errors
    /// An estimate of another width.
    pub fn adapt(
        &self,
        adaptation: &SpeakerAdaptation,
        estimate: &DMatrix,
    ) -> Result<DMatrix, SpeechError> {
        adaptation.apply(estimate, &self.visual.rest())
    }

    fn prior_frames(&self) -> f64 {
        PRIOR_FRAMES_S * self.features.mfcc.frame_rate
    }

    /// An estimate brought to rest where the audio has no speech, then smoothed.
    ///
    /// Each frame is blended with the rest pose (the reference face's neutral, whose visual
    /// features are the projection of no displacement) by `1 − w_t`, `w_t` the largest
    /// squared speech activity `a²` ([`super::activity`], read from the centre frame of the
    /// stacked features) from frame t to [`REST_MARGIN_S`] after it. The model sees silence
    /// too, but through a context window that reaches into the neighbouring words; a frame
    /// with no speech ahead is a mouth at rest. Looking ahead leaves the model the lips'
    /// anticipation of the next sound; the release of the last is the smoothing's, since a
    /// fading tail held open by its neighbours kept real voices open in their trailing
    /// silence. The square rests the half-active frames of a fading tail more than the
    /// fully active ones of speech (on held-out demo sentences ACC moved by 0.003).
    fn finish_estimate(
        &self,
        mut estimate: DMatrix,
        audio: &DMatrix,
        who: &str,
    ) -> Result<DMatrix, SpeechError> {
        let fd = frame_dim(&self.features.mfcc);
        let column = self.features.context * fd + fd - 1;
        if audio.ncols() <= column || audio.nrows() != estimate.nrows() {
            return Err(bad("audio features", format!("{} columns", audio.ncols())));
        }
        let activity: Vec<f64> =
            audio.column(column).iter().map(|v| (v / LEVEL_SCALE).clamp(0.0, 1.0)).collect();
        let reach = (REST_MARGIN_S * self.features.mfcc.frame_rate).round() as usize;
        let rest = self.visual.rest();
        for (t, w) in speech_weights(&activity, reach).into_iter().enumerate() {
            for k in 0..estimate.ncols() {
                estimate[(t, k)] = w * estimate[(t, k)] + (1.0 - w) * rest[k];
            }
        }
        finite_estimate(smooth_rows(&estimate, self.features.smoothing_frames()), who)
    }
}

/// How far before speech a frame's estimate is left to the model rather than brought to
/// rest ([`SpeechModel::estimate_visual`]): about the lips' anticipation of a sound.
pub const REST_MARGIN_S: f64 = 0.04;

/// The weight of the model's estimate against the rest pose per frame: the largest `a²` of
/// `activity` from the frame to `reach` frames after it.
fn speech_weights(activity: &[f64], reach: usize) -> Vec<f64> {
    (0..activity.len())
        .map(|t| {
            activity[t..(t + reach + 1).min(activity.len())]
                .iter()
                .fold(0.0, |m: f64, a| m.max(a * a))
        })
        .collect()
}

/// `m`, or an error naming the first frame where `who`'s estimate is not finite.
fn finite_estimate(m: DMatrix, who: &str) -> Result<DMatrix, SpeechError> {
    match m.row_iter().position(|r| r.iter().any(|v| !v.is_finite())) {
        Some(t) => Err(SpeechError::Degenerate(format!(
            "{who} estimate (not a finite number at frame {t})"
        ))),
        None => Ok(m),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn description(fps: f64) -> FeatureDescription {
        SpeechOptions::new(16_000.0, fps).features(20)
    }

    #[test]
    fn frames_rest_unless_speech_is_at_them_or_just_ahead() {
        let activity = [0.0, 0.0, 0.0, 1.0, 1.0, 0.5, 0.0, 0.0];
        let w = speech_weights(&activity, 1);
        // Anticipation: the frame before the onset is the model's; the one before that rests.
        assert_eq!(&w[..4], &[0.0, 0.0, 1.0, 1.0]);
        // A half-active fading tail weighs a quarter, and nothing reaches back after it.
        assert_eq!(&w[4..], &[1.0, 0.25, 0.0, 0.0]);
        assert_eq!(speech_weights(&activity, 0)[2], 0.0);
    }

    #[test]
    fn a_different_frame_rate_is_named_in_one_line() {
        let a = description(25.0);
        let b = description(30.0);
        assert!(a.check_matches(&a).is_ok());
        let e = a.check_matches(&b).unwrap_err().to_string();
        assert_eq!(
            e,
            "the model was trained on frame rate (fps) = 25, these features have frame rate (fps) = 30"
        );
        let c = FeatureDescription { context: 2, ..a.clone() };
        assert!(a.check_matches(&c).unwrap_err().to_string().contains("context t_c"));
    }

    #[test]
    fn settings_out_of_range_are_named() {
        let ok = description(25.0);
        assert!(ok.validate().is_ok());
        for (wrong, field) in [
            (FeatureDescription { context: 1_000_000, ..ok.clone() }, "features.context"),
            (
                FeatureDescription { visual_components: 0, ..ok.clone() },
                "features.visual_components",
            ),
            (FeatureDescription { smoothing_s: f64::NAN, ..ok.clone() }, "features.smoothing_s"),
            (
                FeatureDescription {
                    activity: ActivityOptions { onset_db: -1.0, ..ActivityOptions::default() },
                    ..ok.clone()
                },
                "features.activity",
            ),
        ] {
            let e = wrong.validate().unwrap_err().to_string();
            assert!(e.starts_with(field), "{e}");
        }
    }
}
