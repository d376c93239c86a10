//! The trained speech-to-mouth model and the pipeline that builds and applies it: audio
//! features (MFCC + context) and visual features (mouth PCA) of each training clip, joined
//! frame by frame into `o_avt = [o_atᵀ, o_vtᵀ]ᵀ`, the AV-HMM trained on them, and the linear
//! baseline beside it.
//!
//! A model records how its features were computed ([`FeatureDescription`]); applying it to
//! features computed differently (another frame rate, sample rate, context) is refused with
//! one line naming the difference, instead of silently producing nonsense.

use super::baum_welch::{TrainOptions, TrainReport, train_hmm};
use super::context::stack_context;
use super::error::{SpeechError, bad};
use super::hmm::Hmm;
use super::inversion::{InversionOptions, Inverter};
use super::mfcc::{MfccOptions, compute_mfcc};
use super::regression::{LinearRegression, fit_linear_regression};
use super::visual::{MouthClip, VisualBasis, fit_visual_basis};
use crate::math::DMatrix;
use serde::{Deserialize, Serialize};

/// How the features of a model were computed.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FeatureDescription {
    pub mfcc: MfccOptions,
    /// t_c: audio frames stacked on each side.
    pub context: usize,
    /// Visual PCA components.
    pub visual_components: usize,
    /// Mouth vertices per frame.
    pub mouth_vertices: usize,
}

impl FeatureDescription {
    /// Width of the stacked audio vector: n_ceps · (2 t_c + 1).
    pub fn audio_dim(&self) -> usize {
        self.mfcc.n_ceps * (2 * self.context + 1)
    }

    /// `Ok` when `other` computes features exactly as `self` does.
    ///
    /// # Errors
    /// [`SpeechError::FeatureMismatch`] naming the first field that differs.
    pub fn check_matches(&self, other: &FeatureDescription) -> Result<(), SpeechError> {
        let (a, b) = (&self.mfcc, &other.mfcc);
        let fields: [(&'static str, String, String); 12] = [
            ("sample rate (Hz)", a.sample_rate.to_string(), b.sample_rate.to_string()),
            ("frame rate (fps)", a.frame_rate.to_string(), b.frame_rate.to_string()),
            ("window (s)", a.window_s.to_string(), b.window_s.to_string()),
            ("pre-emphasis", a.pre_emphasis.to_string(), b.pre_emphasis.to_string()),
            ("mel filters", a.n_filters.to_string(), b.n_filters.to_string()),
            ("cepstral coefficients", a.n_ceps.to_string(), b.n_ceps.to_string()),
            ("band low edge (Hz)", a.low_hz.to_string(), b.low_hz.to_string()),
            ("band high edge (Hz)", a.high_hz.to_string(), b.high_hz.to_string()),
            (
                "cepstral mean normalisation",
                a.mean_normalise.to_string(),
                b.mean_normalise.to_string(),
            ),
            ("context t_c", self.context.to_string(), other.context.to_string()),
            (
                "visual components",
                self.visual_components.to_string(),
                other.visual_components.to_string(),
            ),
            ("mouth vertices", self.mouth_vertices.to_string(), other.mouth_vertices.to_string()),
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
    /// t_c; the paper's best results used 3.
    pub context: usize,
    /// Visual PCA components; the paper used 4.
    pub visual_components: usize,
    pub train: TrainOptions,
    /// Relative ridge of the linear baseline.
    pub ridge: f64,
}

impl SpeechOptions {
    /// Defaults for audio at `sample_rate` Hz and video at `frame_rate` fps: t_c 3, 4 visual
    /// components, [`TrainOptions::default`], ridge 10⁻³.
    pub fn new(sample_rate: f64, frame_rate: f64) -> Self {
        Self {
            mfcc: MfccOptions::new(sample_rate, frame_rate),
            context: 3,
            visual_components: 4,
            train: TrainOptions::default(),
            ridge: 1e-3,
        }
    }
}

/// One training clip: its audio (mono, at the options' sample rate) and its mouth motion.
/// Frame f of the mouth is at time f / fps in the audio.
#[derive(Clone, Copy, Debug)]
pub struct TrainingClip<'a> {
    pub samples: &'a [f32],
    pub mouth: MouthClip<'a>,
}

/// A trained model: serialise it with serde; it checks itself on [`SpeechModel::validate`].
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SpeechModel {
    pub features: FeatureDescription,
    pub visual: VisualBasis,
    pub hmm: Hmm,
    pub baseline: LinearRegression,
    pub report: TrainReport,
}

/// Stacked audio features (T × n_ceps(2t_c + 1)) of `samples` for `n_frames` video frames.
///
/// # Errors
/// As [`compute_mfcc`].
pub fn compute_audio_features(
    samples: &[f32],
    mfcc: &MfccOptions,
    context: usize,
    n_frames: usize,
) -> Result<DMatrix, SpeechError> {
    Ok(stack_context(&compute_mfcc(samples, mfcc, n_frames)?, context))
}

/// Trains the AV-HMM and the baseline on `clips`; `progress` as in [`train_hmm`].
///
/// # Errors
/// No clips, a clip without frames, any error of the feature extraction or training.
pub fn train_speech_model(
    clips: &[TrainingClip],
    opts: &SpeechOptions,
    progress: &mut dyn FnMut(usize, f64),
) -> Result<SpeechModel, SpeechError> {
    if clips.is_empty() {
        return Err(SpeechError::Empty("training clips"));
    }
    if let Some(i) = clips.iter().position(|c| c.mouth.frames.is_empty()) {
        return Err(bad("training clip", format!("clip {i} has no frames")));
    }
    let mouths: Vec<MouthClip> = clips.iter().map(|c| c.mouth).collect();
    let visual = fit_visual_basis(&mouths, opts.visual_components)?;
    let mut audio_all = Vec::with_capacity(clips.len());
    let mut visual_all = Vec::with_capacity(clips.len());
    let mut joint = Vec::with_capacity(clips.len());
    for c in clips {
        let a = compute_audio_features(c.samples, &opts.mfcc, opts.context, c.mouth.frames.len())?;
        let v = visual.project(&c.mouth)?;
        let mut j = DMatrix::zeros(a.nrows(), a.ncols() + v.ncols());
        j.columns_mut(0, a.ncols()).copy_from(&a);
        j.columns_mut(a.ncols(), v.ncols()).copy_from(&v);
        joint.push(j);
        audio_all.push(a);
        visual_all.push(v);
    }
    let (hmm, report) = train_hmm(&joint, &opts.train, progress)?;
    let baseline =
        fit_linear_regression(&stack_rows(&audio_all), &stack_rows(&visual_all), opts.ridge)?;
    let features = FeatureDescription {
        mfcc: opts.mfcc.clone(),
        context: opts.context,
        visual_components: opts.visual_components,
        mouth_vertices: visual.n_vertices(),
    };
    Ok(SpeechModel { features, visual, hmm, baseline, report })
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
    /// Checks a loaded model's internal consistency.
    ///
    /// # Errors
    /// Sizes that disagree between the feature description, the basis, the HMM and the
    /// baseline, or an invalid HMM.
    pub fn validate(&self) -> Result<(), SpeechError> {
        self.features.mfcc.validate()?;
        self.hmm.validate()?;
        let da = self.features.audio_dim();
        let dv = self.features.visual_components;
        let mismatch = |what, expected, got| SpeechError::DimensionMismatch { what, expected, got };
        if self.hmm.dim() != da + dv {
            return Err(mismatch("HMM dimension", da + dv, self.hmm.dim()));
        }
        if self.visual.n_components() != dv {
            return Err(mismatch("visual basis components", dv, self.visual.n_components()));
        }
        if self.visual.n_vertices() != self.features.mouth_vertices {
            return Err(mismatch(
                "visual basis vertices",
                self.features.mouth_vertices,
                self.visual.n_vertices(),
            ));
        }
        if self.baseline.weights.shape() != (da + 1, dv) {
            return Err(mismatch("baseline rows", da + 1, self.baseline.weights.nrows()));
        }
        Ok(())
    }

    /// Stacked audio features of `samples` (at the model's sample rate) for `n_frames`.
    ///
    /// # Errors
    /// As [`compute_mfcc`].
    pub fn audio_features(&self, samples: &[f32], n_frames: usize) -> Result<DMatrix, SpeechError> {
        compute_audio_features(samples, &self.features.mfcc, self.features.context, n_frames)
    }

    /// The inverter of this model's HMM (build once, invert many clips).
    ///
    /// # Errors
    /// As [`Inverter::new`].
    pub fn inverter(&self) -> Result<Inverter, SpeechError> {
        Inverter::new(&self.hmm, self.features.audio_dim())
    }

    /// Visual features (T × K) estimated from `samples` by HMM inversion.
    ///
    /// # Errors
    /// As [`SpeechModel::audio_features`] and [`Inverter::invert`].
    pub fn estimate_visual(
        &self,
        samples: &[f32],
        n_frames: usize,
        opts: &InversionOptions,
    ) -> Result<DMatrix, SpeechError> {
        self.inverter()?.invert(&self.audio_features(samples, n_frames)?, opts)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_different_frame_rate_is_named_in_one_line() {
        let a = FeatureDescription {
            mfcc: MfccOptions::new(16_000.0, 25.0),
            context: 3,
            visual_components: 4,
            mouth_vertices: 20,
        };
        let b = FeatureDescription { mfcc: MfccOptions::new(16_000.0, 30.0), ..a.clone() };
        assert!(a.check_matches(&a).is_ok());
        let e = a.check_matches(&b).unwrap_err().to_string();
        assert_eq!(
            e,
            "the model was trained on frame rate (fps) = 25, these features have frame rate (fps) = 30"
        );
        let c = FeatureDescription { context: 2, ..a.clone() };
        assert!(a.check_matches(&c).unwrap_err().to_string().contains("context t_c"));
    }
}
