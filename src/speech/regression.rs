//! The baseline beside the HMM: ridge regression from the stacked audio vector to the visual
//! vector, `Y ≈ [X 1] W`, `W = (X̃ᵀX̃ + λ·diag(s, …, s, 0))⁻¹ X̃ᵀY` with the intercept
//! unpenalised. It shows what a single global linear map already achieves, so the HMM's gain
//! is visible.

use super::error::{SpeechError, bad};
use crate::math::DMatrix;
use serde::{Deserialize, Serialize};

/// A fitted linear map: `weights` is (da + 1) × dv, the last row the intercept.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LinearRegression {
    pub weights: DMatrix,
}

/// Fits `visual` (T × dv) from `audio` (T × da). `ridge` λ is relative: the penalty is
/// λ · (mean diagonal of XᵀX), so it means the same whatever the features' units.
///
/// # Errors
/// Row counts that disagree, no rows, negative λ, a singular system (λ = 0 with collinear
/// features).
pub fn fit_linear_regression(
    audio: &DMatrix,
    visual: &DMatrix,
    ridge: f64,
) -> Result<LinearRegression, SpeechError> {
    if audio.nrows() != visual.nrows() {
        return Err(SpeechError::DimensionMismatch {
            what: "visual rows",
            expected: audio.nrows(),
            got: visual.nrows(),
        });
    }
    if audio.nrows() == 0 {
        return Err(SpeechError::Empty("training frames"));
    }
    if !(ridge >= 0.0 && ridge.is_finite()) {
        return Err(bad("ridge", ridge.to_string()));
    }
    let x = augment(audio);
    let mut gram = x.tr_mul(&x);
    let da = audio.ncols();
    let scale = (0..da).map(|i| gram[(i, i)]).sum::<f64>() / da.max(1) as f64;
    for i in 0..da {
        gram[(i, i)] += ridge * scale;
    }
    let weights = gram
        .cholesky()
        .ok_or_else(|| SpeechError::Degenerate("regression (collinear audio features)".into()))?
        .solve(&x.tr_mul(visual));
    Ok(LinearRegression { weights })
}

impl LinearRegression {
    /// Visual estimates (T × dv) for `audio` (T × da).
    ///
    /// # Errors
    /// Audio of the wrong width.
    pub fn predict(&self, audio: &DMatrix) -> Result<DMatrix, SpeechError> {
        if audio.ncols() + 1 != self.weights.nrows() {
            return Err(SpeechError::DimensionMismatch {
                what: "audio feature dimension",
                expected: self.weights.nrows() - 1,
                got: audio.ncols(),
            });
        }
        Ok(augment(audio) * &self.weights)
    }
}

fn augment(x: &DMatrix) -> DMatrix {
    x.clone().insert_column(x.ncols(), 1.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_an_exact_linear_map() {
        let x = DMatrix::from_fn(30, 2, |i, j| ((i * 7 + j * 3) % 11) as f64 - 5.0);
        let y = DMatrix::from_fn(30, 1, |i, _| 2.0 * x[(i, 0)] - 0.5 * x[(i, 1)] + 3.0);
        let r = fit_linear_regression(&x, &y, 0.0).unwrap();
        assert!((r.predict(&x).unwrap() - &y).abs().max() < 1e-9);
        assert!((r.weights[(2, 0)] - 3.0).abs() < 1e-9);
        // A ridge shrinks the slopes, never the intercept's role of matching the mean.
        let shrunk = fit_linear_regression(&x, &y, 1.0).unwrap();
        assert!(shrunk.weights[(0, 0)].abs() < 2.0);
    }

    #[test]
    fn mismatched_or_collinear_input_is_an_error() {
        let x = DMatrix::from_element(5, 2, 1.0);
        assert!(fit_linear_regression(&x, &DMatrix::zeros(4, 1), 0.0).is_err());
        assert!(fit_linear_regression(&x, &DMatrix::zeros(5, 1), 0.0).is_err());
    }
}
