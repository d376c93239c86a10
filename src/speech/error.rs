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
    /// A value of a model (or its file) out of its range, named by its field.
    #[error("{field}: {reason}")]
    Field { field: String, reason: String },
    /// Features computed differently from those a model was trained on.
    #[error("the model was trained on {field} = {model}, these features have {field} = {input}")]
    FeatureMismatch { field: &'static str, model: String, input: String },
}

pub(crate) fn bad(name: &'static str, reason: impl Into<String>) -> SpeechError {
    SpeechError::BadParameter { name, reason: reason.into() }
}

/// `Field` error for `field` (a path such as `visual.mean[3]`).
pub(crate) fn field_error(field: impl Into<String>, reason: impl Into<String>) -> SpeechError {
    SpeechError::Field { field: field.into(), reason: reason.into() }
}

/// Checks that every value of `values` is finite and within ±`bound`, naming the first that
/// is not as `field[i]`.
pub(crate) fn check_finite_within(
    field: &str,
    values: impl IntoIterator<Item = f64>,
    bound: f64,
) -> Result<(), SpeechError> {
    match values.into_iter().enumerate().find(|(_, v)| !v.is_finite() || v.abs() > bound) {
        Some((i, v)) => Err(field_error(
            format!("{field}[{i}]"),
            format!(
                "{} is not a finite number within ±{}",
                crate::math::short_number(v),
                crate::math::short_number(bound)
            ),
        )),
        None => Ok(()),
    }
}
