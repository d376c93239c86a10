//! Speech-animation quality prediction (SAQP) after Ma & Deng, "A Statistical Quality Model
//! for Data-Driven Speech Animation", IEEE TVCG 2012: a phoneme-context trajectory-fitting
//! error (the SATF metric, §5.1) is mapped to a synthesizer's ground-truth quality (eq. 8) by
//! Gaussian-process regression (eq. 9–11), trained and checked by the paper's
//! cross-validation (§5.2–5.3).
//!
//! Plain values in and out. Start with a [`Corpus`] (fitted clips as per-frame model
//! coefficients plus phone timings), then [`cross_validate`] for the paper's experiment or
//! [`train`] for a [`Predictor`] that scores new phone sequences. The pieces, one algorithm
//! per file: [`motion`] (region PCA), [`sampling`] (phone-midpoint samples and key
//! interpolation), [`context`] (context statistics with back-off), [`banded`] (the banded
//! Cholesky solve), [`satf`] (eq. 1–7), [`synth`] (the built-in synthesizers), [`quality`]
//! (markers, eq. 8, Likert), [`lbfgs`] and [`gp`] (eq. 9–11), [`cv`] (§5.2–5.3) and
//! [`predictor`]. `docs/saqp.md` gives the equations and every departure from the paper.

pub mod banded;
pub mod calibration;
pub mod context;
mod corpus;
pub mod coverage;
pub mod cv;
mod error;
pub mod gp;
pub mod lbfgs;
pub mod motion;
pub mod predictor;
mod prepared;
pub mod quality;
pub mod sampling;
pub mod satf;
pub mod skill;
pub mod synth;

pub use calibration::{CalibrationKind, LinearCalibration};
pub use context::{ContextLevel, ContextOptions, ContextStats, PhoneStats};
pub use corpus::{Corpus, LinearShapes, Sentence};
pub use coverage::{ContextIndex, INPUT_NAMES};
pub use cv::{CvOptions, CvReport, HeldOut, OmegaScore, SynthReport, cross_validate};
pub use error::SaqpError;
pub use gp::{GaussianProcess, GpHyper, GpPrediction};
pub use motion::{MotionBasis, Region, RegionSummary};
pub use predictor::{Predictor, QualityEstimate, TrainOptions, train};
pub use prepared::{PhoneSet, Prepared};
pub use quality::{MarkerSet, QualityParts};
pub use satf::{SatfFit, SatfParams, fit_trajectory};
pub use skill::{Skill, Verdict};
pub use synth::{External, SynthKind, SynthParams};
