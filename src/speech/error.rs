//! The one error type of the speech core: what was wrong with the values given, never a panic.

use thiserror::Error;

/// Why a speech computation could not be done.
#[derive(Clone, Debug, Error, PartialEq)]
pub enum SpeechError {
    /// A required input was empty (no samples, no frames, no sequences).
    #[error("no {0}")]
    Empty(&'static str),
    /// A parameter outside its valid range.
    #[error("invalid {name}: {reason}")]
    BadParameter { name: &'static str, reason: String },
    /// Arrays whose sizes do not agree.
    #[error("{what}: expected {expected}, got {got}")]
    DimensionMismatch { what: &'static str, expected: usize, got: usize },
    /// Too little data for what was asked (e.g. fewer frames than clusters).
    #[error("too few {what}: need at least {need}, got {got}")]
    TooFew { what: &'static str, need: usize, got: usize },
    /// A numerically degenerate case: a constant signal, a singular covariance.
    #[error("degenerate {0}")]
    Degenerate(String),
    /// Features computed differently from those a model was trained on.
    #[error("the model was trained on {field} = {model}, these features have {field} = {input}")]
    FeatureMismatch { field: &'static str, model: String, input: String },
}

pub(crate) fn bad(name: &'static str, reason: impl Into<String>) -> SpeechError {
    SpeechError::BadParameter { name, reason: reason.into() }
}
