//! A full-covariance multivariate Gaussian evaluated on many frames at once.
//!
//! `ln N(o; μ, Σ) = −½ (d ln 2π + ln|Σ| + (o − μ)ᵀ Σ⁻¹ (o − μ))`. The quadratic form of all
//! T frames is one T × d by d × d product `(O − 1μᵀ) Σ⁻¹` followed by a row-wise dot product,
//! which keeps the work in nalgebra's blocked matrix product rather than T triangular solves.

use super::error::SpeechError;
use crate::math::{DMatrix, DVector};
use serde::{Deserialize, Serialize};

/// A Gaussian with its precision and log-determinant cached. Deserialising checks the
/// covariance and rebuilds the cache, so a loaded Gaussian is as usable as a new one.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "GaussianParams")]
pub struct Gaussian {
    pub mean: DVector,
    pub cov: DMatrix,
    #[serde(skip)]
    cache: Option<Cache>,
}

/// A Gaussian as a file holds it.
#[derive(Deserialize)]
pub(crate) struct GaussianParams {
    pub(crate) mean: DVector,
    pub(crate) cov: DMatrix,
}

impl TryFrom<GaussianParams> for Gaussian {
    type Error = SpeechError;
    fn try_from(p: GaussianParams) -> Result<Self, SpeechError> {
        Self::new(p.mean, p.cov)
    }
}

#[derive(Clone, Debug, PartialEq)]
struct Cache {
    precision: DMatrix,
    log_norm: f64,
}

impl Gaussian {
    /// # Errors
    /// Sizes that disagree, or a covariance that is not symmetric positive definite.
    pub fn new(mean: DVector, cov: DMatrix) -> Result<Self, SpeechError> {
        let mut g = Self { mean, cov, cache: None };
        g.prepare()?;
        Ok(g)
    }

    fn prepare(&mut self) -> Result<(), SpeechError> {
        let d = self.mean.len();
        if self.cov.shape() != (d, d) {
            return Err(SpeechError::DimensionMismatch {
                what: "covariance size",
                expected: d,
                got: self.cov.nrows(),
            });
        }
        // A Cholesky factorisation does not see NaN (every comparison with it is false), and
        // an asymmetric matrix is factorised from its lower half only.
        if self.mean.iter().chain(self.cov.iter()).any(|v| !v.is_finite()) {
            return Err(SpeechError::Degenerate(
                "Gaussian (a mean or covariance value is not finite)".into(),
            ));
        }
        let scale = self.cov.diagonal().abs().max().max(f64::MIN_POSITIVE);
        if (&self.cov - self.cov.transpose()).abs().max() > 1e-9 * scale {
            return Err(SpeechError::Degenerate("covariance (not symmetric)".into()));
        }
        let chol =
            self.cov.clone().cholesky().ok_or_else(|| {
                SpeechError::Degenerate("covariance (not positive definite)".into())
            })?;
        let log_det = 2.0 * chol.l_dirty().diagonal().iter().map(|v| v.ln()).sum::<f64>();
        let log_norm = -0.5 * (d as f64 * (2.0 * std::f64::consts::PI).ln() + log_det);
        let precision = chol.inverse();
        if !log_norm.is_finite() || precision.iter().any(|v| !v.is_finite()) {
            return Err(SpeechError::Degenerate(
                "covariance (too close to singular to invert)".into(),
            ));
        }
        self.cache = Some(Cache { precision, log_norm });
        Ok(())
    }

    pub fn dim(&self) -> usize {
        self.mean.len()
    }

    /// The precision Σ⁻¹.
    pub fn precision(&self) -> &DMatrix {
        &self.cache().precision
    }

    fn cache(&self) -> &Cache {
        // Every constructor (new, deserialisation) fills the cache or fails.
        self.cache.as_ref().expect("a Gaussian is only built through Gaussian::new")
    }

    /// `ln N(o_t; μ, Σ)` for every row o_t of `obs` (T × d).
    pub fn log_density_rows(&self, obs: &DMatrix) -> DVector {
        let cache = self.cache();
        // Column by column: the matrices are column-major, so a row walk would touch a cache
        // line per element, which on a whole corpus costs more than the product itself.
        let mut centred = obs.clone();
        for (mut col, m) in centred.column_iter_mut().zip(self.mean.iter()) {
            col.add_scalar_mut(-m);
        }
        let weighted = &centred * &cache.precision;
        let mut quad = DVector::zeros(obs.nrows());
        for (c, w) in centred.column_iter().zip(weighted.column_iter()) {
            quad += c.component_mul(&w);
        }
        quad.map(|q| cache.log_norm - 0.5 * q)
    }
}

/// `ln Σ exp(x_i)` without overflow; −∞ for an empty or all −∞ input.
pub fn log_sum_exp(xs: impl IntoIterator<Item = f64> + Clone) -> f64 {
    let m = xs.clone().into_iter().fold(f64::NEG_INFINITY, f64::max);
    if m == f64::NEG_INFINITY {
        return m;
    }
    m + xs.into_iter().map(|x| (x - m).exp()).sum::<f64>().ln()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn matches_the_closed_form_in_two_dimensions() {
        let g = Gaussian::new(
            DVector::from_vec(vec![1.0, -1.0]),
            DMatrix::from_row_slice(2, 2, &[2.0, 0.5, 0.5, 1.0]),
        )
        .unwrap();
        let o = DMatrix::from_row_slice(1, 2, &[0.5, 0.0]);
        // |Σ| = 1.75; Σ⁻¹ = [1 −0.5; −0.5 2]/1.75; d = (−0.5, 1): dᵀΣ⁻¹d = (0.25+0.5+2)/1.75.
        let q = 2.75 / 1.75;
        let want = -0.5 * (2.0 * (2.0 * std::f64::consts::PI).ln() + 1.75f64.ln() + q);
        assert!((g.log_density_rows(&o)[0] - want).abs() < 1e-12);
    }

    #[test]
    fn singular_covariances_are_refused() {
        let r =
            Gaussian::new(DVector::zeros(2), DMatrix::from_row_slice(2, 2, &[1.0, 1.0, 1.0, 1.0]));
        assert!(matches!(r, Err(SpeechError::Degenerate(_))));
    }

    #[test]
    fn log_sum_exp_is_stable() {
        assert!((log_sum_exp([1000.0, 1000.0]) - (1000.0 + 2f64.ln())).abs() < 1e-9);
        assert_eq!(log_sum_exp(Vec::<f64>::new()), f64::NEG_INFINITY);
    }
}
