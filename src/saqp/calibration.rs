//! What maps a sentence's inputs (E and its context coverage) to a predicted Likert score:
//! the paper's GP, or the straight line it must beat — ordinary least squares on the same
//! inputs, with the usual predictive variance. The cross-validation fits both and keeps the
//! GP only when its leave-one-sentence-out error on the training pairs is lower than the
//! line's by more than one standard error.

use super::SaqpError;
use super::gp::{GaussianProcess, GpPrediction};
use crate::math::{DMatrix, DVector};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// Which calibration a predictor uses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub enum CalibrationKind {
    Gp,
    Linear,
}

impl CalibrationKind {
    pub fn name(self) -> &'static str {
        match self {
            CalibrationKind::Gp => "GP",
            CalibrationKind::Linear => "linear",
        }
    }
}

/// Least squares of the score on the inputs: `score = b₀ + Σ b_d·x_d`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct LinearCalibration {
    /// b₀, then one coefficient per input.
    pub coefficients: Vec<f64>,
    /// `(XᵀX)⁻¹` of the design with its column of ones, row by row: the variance of a
    /// prediction's mean is `s²·x̃ᵀ(XᵀX)⁻¹x̃`.
    pub inverse_gram: Vec<Vec<f64>>,
    /// s², the residuals' variance (n − p degrees of freedom).
    pub residual_variance: f64,
}

fn design_row(x: &[f64]) -> DVector {
    DVector::from_iterator(x.len() + 1, std::iter::once(1.0).chain(x.iter().copied()))
}

impl LinearCalibration {
    /// Fits the line to (input, score) pairs.
    ///
    /// # Errors
    /// Fewer pairs than coefficients + 1, inputs of different lengths, non-finite values, or
    /// inputs that do not vary (a singular design).
    pub fn fit(inputs: &[Vec<f64>], targets: &[f64]) -> Result<Self, SaqpError> {
        let n = inputs.len();
        let p = inputs.first().map_or(0, Vec::len) + 1;
        if n != targets.len() || n <= p || inputs.iter().any(|x| x.len() + 1 != p) {
            return Err(SaqpError::Gp(format!(
                "{n} training pairs for a line of {p} coefficients"
            )));
        }
        if inputs.iter().flatten().chain(targets).any(|v| !v.is_finite()) {
            return Err(SaqpError::Gp("a training value is not finite".into()));
        }
        let x = DMatrix::from_fn(n, p, |r, c| if c == 0 { 1.0 } else { inputs[r][c - 1] });
        let y = DVector::from_column_slice(targets);
        let gram = x.transpose() * &x;
        let inverse = gram
            .cholesky()
            .ok_or_else(|| SaqpError::Gp("the inputs do not vary: no line to fit".into()))?
            .inverse();
        let b = &inverse * (x.transpose() * &y);
        let residual = &y - &x * &b;
        Ok(Self {
            coefficients: b.iter().copied().collect(),
            inverse_gram: (0..p).map(|r| inverse.row(r).iter().copied().collect()).collect(),
            residual_variance: residual.norm_squared() / (n - p) as f64,
        })
    }

    /// The predicted score and its uncertainty at `x`.
    pub fn predict(&self, x: &[f64]) -> GpPrediction {
        let row = design_row(x);
        let p = row.len();
        let inverse = DMatrix::from_fn(p, p, |r, c| self.inverse_gram[r][c]);
        let mean = self.coefficients.iter().zip(row.iter()).map(|(b, v)| b * v).sum();
        GpPrediction {
            mean,
            variance: (self.residual_variance * row.dot(&(inverse * &row))).max(0.0),
            noise_variance: self.residual_variance,
        }
    }

    /// Residuals of the training targets when each group of pairs is left out and the line
    /// refitted without it (`groups[i]` names pair i's group).
    ///
    /// # Errors
    /// A group whose removal leaves too few pairs or a singular design.
    pub fn group_residuals(
        inputs: &[Vec<f64>],
        targets: &[f64],
        groups: &[usize],
    ) -> Result<Vec<f64>, SaqpError> {
        let mut members: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
        for (i, &g) in groups.iter().enumerate() {
            members.entry(g).or_default().push(i);
        }
        let mut out = vec![0.0; targets.len()];
        for idx in members.values() {
            let keep: Vec<usize> = (0..targets.len()).filter(|i| !idx.contains(i)).collect();
            let fit = Self::fit(
                &keep.iter().map(|&i| inputs[i].clone()).collect::<Vec<_>>(),
                &keep.iter().map(|&i| targets[i]).collect::<Vec<_>>(),
            )?;
            for &i in idx {
                out[i] = targets[i] - fit.predict(&inputs[i]).mean;
            }
        }
        Ok(out)
    }

    /// Checks a line read from a file: one coefficient per input and the intercept, a
    /// square `inverse_gram` of that size, every value finite, the residual variance
    /// positive.
    ///
    /// # Errors
    /// The field at fault.
    pub fn validate(&self, inputs: usize) -> Result<(), String> {
        let p = inputs + 1;
        if self.coefficients.len() != p {
            return Err(format!(
                "linear.coefficients: {} values for {inputs} inputs and the intercept",
                self.coefficients.len()
            ));
        }
        if self.inverse_gram.len() != p || self.inverse_gram.iter().any(|r| r.len() != p) {
            return Err(format!("linear.inverse_gram must be {p} × {p}"));
        }
        if self
            .coefficients
            .iter()
            .chain(self.inverse_gram.iter().flatten())
            .any(|v| !v.is_finite())
        {
            return Err("linear: a coefficient is not finite".into());
        }
        if !(self.residual_variance.is_finite() && self.residual_variance > 0.0) {
            return Err("linear.residual_variance must be positive".into());
        }
        Ok(())
    }
}

impl LinearCalibration {
    /// Whether `other` holds the same line (to a relative 1e-6): how a line read from a file
    /// is checked against the one its training pairs give.
    pub fn agrees_with(&self, other: &Self) -> bool {
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-6 * a.abs().max(b.abs()).max(1.0);
        let values = |c: &Self| {
            let mut v = c.coefficients.clone();
            v.extend(c.inverse_gram.iter().flatten());
            v.push(c.residual_variance);
            v
        };
        let (a, b) = (values(self), values(other));
        a.len() == b.len() && a.iter().zip(&b).all(|(x, y)| close(*x, *y))
    }
}

/// A fitted calibration of either kind, as a predictor uses it.
pub fn predict_with(
    kind: CalibrationKind,
    gp: &GaussianProcess,
    linear: &LinearCalibration,
    at: &[Vec<f64>],
) -> Result<Vec<GpPrediction>, SaqpError> {
    match kind {
        CalibrationKind::Gp => gp.predict(at),
        CalibrationKind::Linear => Ok(at.iter().map(|x| linear.predict(x)).collect()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_a_line_and_its_leave_out_residuals() {
        let inputs: Vec<Vec<f64>> = (0..20).map(|i| vec![i as f64, ((i * 7) % 5) as f64]).collect();
        let noise = |i: usize| if i.is_multiple_of(2) { 0.01 } else { -0.01 };
        let targets: Vec<f64> = inputs
            .iter()
            .enumerate()
            .map(|(i, x)| 2.0 + 0.5 * x[0] - 0.3 * x[1] + noise(i))
            .collect();
        let fit = LinearCalibration::fit(&inputs, &targets).unwrap();
        for (b, want) in fit.coefficients.iter().zip([2.0, 0.5, -0.3]) {
            assert!((b - want).abs() < 0.01, "{:?}", fit.coefficients);
        }
        let p = fit.predict(&[30.0, 1.0]);
        assert!((p.mean - (2.0 + 15.0 - 0.3)).abs() < 0.05);
        // Far from the data the mean is less certain than near it.
        assert!(p.variance > fit.predict(&[10.0, 2.0]).variance);
        assert_eq!(fit.validate(2), Ok(()));
        assert!(fit.validate(1).unwrap_err().starts_with("linear.coefficients"));
        let groups: Vec<usize> = (0..20).map(|i| i / 4).collect();
        let r = LinearCalibration::group_residuals(&inputs, &targets, &groups).unwrap();
        assert!(r.iter().all(|v| v.abs() < 0.05), "{r:?}");
        let flat = vec![vec![1.0, 1.0]; 5];
        assert!(LinearCalibration::fit(&flat, &[1.0, 2.0, 3.0, 4.0, 5.0]).is_err());
    }
}
