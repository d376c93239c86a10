//! Speech-driven mouth motion (Terissi et al. 2011, §3–4; `docs/speech.md`): a joint
//! audio-visual HMM trained on clips with audio and fitted mouth motion, inverted to estimate
//! mouth motion from new audio, with a linear-regression baseline and the paper's accuracy
//! measures.
//!
//! Plain values in and out: samples as `&[f32]` with their rate, mouth vertices as
//! [`Point3`](crate::math::Point3) arrays, features as nalgebra matrices with one row per
//! video frame. Start with [`train_speech_model`] and [`SpeechModel::estimate_visual`];
//! the steps are one file each: [`mfcc`] (log mel energies as the audio streams in, cepstra)
//! → [`activity`] (speech or not, against the recording's own noise floor) → [`features`]
//! (per-recording normalisation) → [`context`] (audio); [`speaker`] (a speaker's mouth motion
//! on the reference face) → [`visual`] (mouth PCA) → [`smooth`] → [`adaptation`] (what is left
//! of another face, from the speaker's own statistics); [`kmeans`] → [`baum_welch`]
//! (with [`forward_backward`]) (the AV-HMM), [`inversion`], [`regression`] (baseline),
//! [`measures`] (AMSE, ACC); [`resample`] brings audio to the model's rate; [`drive`] turns
//! estimated mouth motion into a morphable model's coefficients. `docs/speech.md` describes
//! the method and its departures from the paper.

pub mod activity;
pub mod adaptation;
pub mod baum_welch;
pub mod context;
pub mod drive;
pub mod error;
pub mod features;
pub mod forward_backward;
pub mod gaussian;
pub mod hmm;
pub mod inversion;
pub mod kmeans;
pub mod measures;
pub mod mfcc;
pub mod model;
pub mod regression;
pub mod resample;
pub mod smooth;
pub mod speaker;
pub mod visual;

pub use activity::{ActivityOptions, speech_activity};
pub use adaptation::{SpeakerAdaptation, VisualMoments};
pub use baum_welch::{TrainOptions, TrainReport, improve_hmm, train_hmm};
pub use context::stack_context;
pub use drive::{Coefficients, MouthDriver, mouth_points, neutral_coefficients};
pub use error::SpeechError;
pub use features::{audio_features, frame_features};
pub use forward_backward::{Posteriors, forward_backward};
pub use gaussian::Gaussian;
pub use hmm::{Component, Hmm};
pub use inversion::{InversionOptions, Inverter};
pub use measures::{average_correlation, average_mse};
pub use mfcc::{LogMelAnalyser, MfccOptions, compute_log_mel, frame_count};
pub use model::{
    FeatureDescription, SpeechModel, SpeechOptions, TrainingClip, compute_audio_features,
    stack_rows, train_speech_model, visual_basis_of,
};
pub use regression::{LinearRegression, fit_linear_regression};
pub use resample::{Resampler, resample};
pub use smooth::smooth_rows;
pub use speaker::{FaceRegion, SpeakerNormaliser};
pub use visual::{MouthClip, VisualBasis, fit_visual_basis};
