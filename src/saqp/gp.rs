//! Gaussian-process regression of quality on the SATF metric (Ma & Deng §5.2.1, eq. 9–11;
//! Rasmussen & Williams, "Gaussian Processes for Machine Learning", 2006, Alg. 2.1 and eq.
//! 5.9). Kernel `k(E, E') = θ₂·exp(−‖E − E'‖² / (2θ₁²))` (eq. 10) plus noise σ²·I.
//!
//! Unlike the paper, σ² is learned with θ₁ and θ₂: with its fixed σ² = 0.014 the optimum can
//! let θ₁ grow until the GP is a constant predictor. The hyperparameters minimise the
//! negative log marginal likelihood (eq. 9) over their logarithms with its analytic gradient
//! `∂L/∂θ_j = ½·tr((K⁻¹ − ααᵀ) ∂K/∂θ_j)`, α = K⁻¹Q, by L-BFGS from several starts. Targets
//! are centred on their mean (a constant prior mean), as a zero-mean prior on Likert scores
//! would be pulled toward 0 away from the data.

use super::SaqpError;
use super::lbfgs::{LbfgsOptions, minimize};
use crate::math::{DMatrix, DVector};
use nalgebra::Cholesky;
use serde::{Deserialize, Serialize};

/// θ₁ (length-scale), θ₂ (signal variance) and σ² (noise variance).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GpHyper {
    pub length_scale: f64,
    pub signal_variance: f64,
    pub noise_variance: f64,
}

impl GpHyper {
    fn from_log(t: &[f64]) -> Self {
        Self { length_scale: t[0].exp(), signal_variance: t[1].exp(), noise_variance: t[2].exp() }
    }

    fn to_log(self) -> [f64; 3] {
        [self.length_scale.ln(), self.signal_variance.ln(), self.noise_variance.ln()]
    }
}

/// The predictive distribution at a new input (eq. 11's U(e) and V(e)).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct GpPrediction {
    pub mean: f64,
    /// Variance of the latent function, V(e).
    pub variance: f64,
    /// σ², added for the distribution of an observed score.
    pub noise_variance: f64,
}

impl GpPrediction {
    /// Standard deviation of an observed score: √(V(e) + σ²).
    pub fn std(&self) -> f64 {
        (self.variance + self.noise_variance).max(0.0).sqrt()
    }
}

/// A trained GP.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GaussianProcess {
    pub hyper: GpHyper,
    pub inputs: Vec<f64>,
    pub targets: Vec<f64>,
    pub target_mean: f64,
    /// The negative log marginal likelihood (eq. 9) at `hyper`, of the centred targets.
    pub nlml: f64,
}

/// Keeps the factorisation defined when σ² → 0 (relative to θ₂).
const JITTER: f64 = 1e-10;
/// Log-hyperparameters are kept within ±this, where the likelihood is numerically sound.
const LOG_BOUND: f64 = 25.0;

fn kernel_matrix(x: &[f64], h: &GpHyper) -> (DMatrix, DMatrix) {
    let n = x.len();
    let se = DMatrix::from_fn(n, n, |i, j| {
        h.signal_variance * (-(x[i] - x[j]).powi(2) / (2.0 * h.length_scale.powi(2))).exp()
    });
    let mut k = se.clone();
    for i in 0..n {
        k[(i, i)] += h.noise_variance + JITTER * h.signal_variance;
    }
    (se, k)
}

/// Eq. 9 and its gradient with respect to `theta = [ln θ₁, ln θ₂, ln σ²]`, for inputs `x`
/// and (centred) targets `y`. `None` where K is not positive definite or θ out of range.
pub fn negative_log_marginal_likelihood(
    x: &[f64],
    y: &[f64],
    theta: &[f64],
) -> Option<(f64, Vec<f64>)> {
    if theta.iter().any(|t| !t.is_finite() || t.abs() > LOG_BOUND) {
        return None;
    }
    let h = GpHyper::from_log(theta);
    let n = x.len();
    let (se, k) = kernel_matrix(x, &h);
    let chol = Cholesky::new(k)?;
    let yv = DVector::from_column_slice(y);
    let alpha = chol.solve(&yv);
    let logdet: f64 = chol.l_dirty().diagonal().iter().map(|d| d.ln()).sum();
    let value = 0.5 * yv.dot(&alpha) + logdet + 0.5 * n as f64 * (2.0 * std::f64::consts::PI).ln();
    let inv = chol.inverse();
    // tr((K⁻¹ − ααᵀ)·∂K) for symmetric ∂K is the sum of the elementwise product.
    let (mut g_len, mut g_sig, mut g_noise) = (0.0, 0.0, 0.0);
    for i in 0..n {
        for j in 0..n {
            let a = inv[(i, j)] - alpha[i] * alpha[j];
            let r2 = (x[i] - x[j]).powi(2);
            g_len += a * se[(i, j)] * r2 / h.length_scale.powi(2);
            g_sig += a * se[(i, j)];
        }
        g_noise += (inv[(i, i)] - alpha[i] * alpha[i]) * h.noise_variance;
    }
    Some((value, vec![0.5 * g_len, 0.5 * g_sig, 0.5 * g_noise]))
}

impl GaussianProcess {
    /// Fits θ₁, θ₂, σ² to (E, Q) pairs by minimising eq. 9 from `restarts` starting points
    /// (length-scales spread over the inputs' range, noise from a tenth to half the targets'
    /// variance), keeping the best.
    ///
    /// # Errors
    /// Fewer than 3 pairs, non-finite values, or no start where eq. 9 is defined.
    pub fn fit(inputs: &[f64], targets: &[f64], restarts: usize) -> Result<Self, SaqpError> {
        let n = inputs.len();
        if n < 3 || targets.len() != n {
            return Err(SaqpError::Gp(format!("{n} training pairs; at least 3 are needed")));
        }
        if inputs.iter().chain(targets).any(|v| !v.is_finite()) {
            return Err(SaqpError::Gp("a training value is not finite".into()));
        }
        let target_mean = targets.iter().sum::<f64>() / n as f64;
        let y: Vec<f64> = targets.iter().map(|t| t - target_mean).collect();
        let var = (y.iter().map(|v| v * v).sum::<f64>() / n as f64).max(1e-12);
        let (lo, hi) = inputs
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
        let range = (hi - lo).max(1e-9);
        let starts: Vec<GpHyper> = (0..restarts.max(1))
            .map(|r| {
                let frac = [0.3, 0.08, 1.0, 0.02, 3.0][r % 5];
                let noise = [0.2, 0.5, 0.1, 0.3, 0.05][r % 5];
                GpHyper {
                    length_scale: frac * range,
                    signal_variance: var,
                    noise_variance: noise * var,
                }
            })
            .collect();
        let options = LbfgsOptions { max_iterations: 300, ..LbfgsOptions::default() };
        let best = starts
            .iter()
            .filter_map(|h| {
                minimize(|t| negative_log_marginal_likelihood(inputs, &y, t), &h.to_log(), options)
            })
            .min_by(|a, b| a.f.total_cmp(&b.f))
            .ok_or_else(|| {
                SaqpError::Gp("the marginal likelihood is undefined at every start".into())
            })?;
        Ok(Self {
            hyper: GpHyper::from_log(&best.x),
            inputs: inputs.to_vec(),
            targets: targets.to_vec(),
            target_mean,
            nlml: best.f,
        })
    }

    /// Predictions at new inputs (eq. 11: U(e) = κᵀ(K + σ²I)⁻¹Q, V(e) = k(e,e) − κᵀ(K + σ²I)⁻¹κ).
    ///
    /// # Errors
    /// A kernel matrix that is not positive definite (corrupted hyperparameters).
    pub fn predict(&self, at: &[f64]) -> Result<Vec<GpPrediction>, SaqpError> {
        let h = &self.hyper;
        let (_, k) = kernel_matrix(&self.inputs, h);
        let chol = Cholesky::new(k)
            .ok_or_else(|| SaqpError::Gp("kernel matrix not positive definite".into()))?;
        let y = DVector::from_iterator(
            self.targets.len(),
            self.targets.iter().map(|t| t - self.target_mean),
        );
        let alpha = chol.solve(&y);
        Ok(at
            .iter()
            .map(|&e| {
                let kappa = DVector::from_iterator(
                    self.inputs.len(),
                    self.inputs.iter().map(|&x| {
                        h.signal_variance
                            * (-(x - e).powi(2) / (2.0 * h.length_scale.powi(2))).exp()
                    }),
                );
                let v = chol.solve(&kappa);
                GpPrediction {
                    mean: self.target_mean + kappa.dot(&alpha),
                    variance: (h.signal_variance - kappa.dot(&v)).max(0.0),
                    noise_variance: h.noise_variance,
                }
            })
            .collect())
    }

    /// Leave-one-out residuals of the training targets in closed form (Rasmussen & Williams
    /// eq. 5.12): `Q_i − μ_{−i} = [K⁻¹Q]_i / [K⁻¹]_ii`.
    /// Checks a process read from a file: as many targets as inputs, at least one, every
    /// value finite and the hyperparameters positive.
    ///
    /// # Errors
    /// The first inconsistency found, naming the field.
    pub fn validate(&self) -> Result<(), String> {
        if self.inputs.is_empty() || self.inputs.len() != self.targets.len() {
            return Err(format!(
                "gp: {} inputs and {} targets (they must match and not be empty)",
                self.inputs.len(),
                self.targets.len()
            ));
        }
        if self.inputs.iter().chain(&self.targets).any(|v| !v.is_finite())
            || !self.target_mean.is_finite()
        {
            return Err("gp: an input or target is not finite".into());
        }
        let h = &self.hyper;
        if [h.length_scale, h.signal_variance, h.noise_variance]
            .iter()
            .any(|v| !(v.is_finite() && *v > 0.0))
        {
            return Err(
                "gp.hyper: length_scale, signal_variance and noise_variance must be positive"
                    .into(),
            );
        }
        Ok(())
    }

    pub fn loo_residuals(&self) -> Result<Vec<f64>, SaqpError> {
        let (_, k) = kernel_matrix(&self.inputs, &self.hyper);
        let chol = Cholesky::new(k)
            .ok_or_else(|| SaqpError::Gp("kernel matrix not positive definite".into()))?;
        let y = DVector::from_iterator(
            self.targets.len(),
            self.targets.iter().map(|t| t - self.target_mean),
        );
        let alpha = chol.solve(&y);
        let inv = chol.inverse();
        Ok((0..y.len()).map(|i| alpha[i] / inv[(i, i)]).collect())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::rngs::StdRng;
    use rand::{Rng, SeedableRng};
    use rand_distr::StandardNormal;

    #[test]
    fn gradient_equals_finite_differences() {
        let x: Vec<f64> = (0..25).map(|i| (i as f64 * 0.37).sin() * 3.0).collect();
        let y: Vec<f64> = x.iter().map(|v| (v * 1.3).cos() + 0.1 * v).collect();
        for theta in [[0.2, -0.3, -2.0], [-0.5, 0.4, -4.0], [1.0, 0.0, -1.0]] {
            let (_, g) = negative_log_marginal_likelihood(&x, &y, &theta).unwrap();
            for j in 0..3 {
                let h = 1e-5;
                let (mut p, mut m) = (theta, theta);
                p[j] += h;
                m[j] -= h;
                let fd = (negative_log_marginal_likelihood(&x, &y, &p).unwrap().0
                    - negative_log_marginal_likelihood(&x, &y, &m).unwrap().0)
                    / (2.0 * h);
                assert!(
                    (fd - g[j]).abs() < 1e-6 * g[j].abs().max(1.0),
                    "θ={theta:?} j={j}: {fd} vs {}",
                    g[j]
                );
            }
        }
    }

    #[test]
    fn hyperparameters_of_a_known_gp_are_recovered() {
        let truth = GpHyper { length_scale: 0.7, signal_variance: 1.0, noise_variance: 0.01 };
        let mut rng = StdRng::seed_from_u64(11);
        let x: Vec<f64> = (0..300).map(|_| rng.random_range(0.0..15.0)).collect();
        let (_, k) = kernel_matrix(&x, &truth);
        let l = Cholesky::new(k).unwrap().unpack();
        let z = DVector::from_fn(x.len(), |_, _| rng.sample::<f64, _>(StandardNormal));
        let y = l * z;
        let gp = GaussianProcess::fit(&x, y.as_slice(), 4).unwrap();
        let h = gp.hyper;
        assert!((h.length_scale / truth.length_scale - 1.0).abs() < 0.25, "{h:?}");
        assert!((h.signal_variance / truth.signal_variance - 1.0).abs() < 0.5, "{h:?}");
        // The mean follows the data and the variance shrinks near training inputs.
        let p = gp.predict(&[x[0], 100.0]).unwrap();
        assert!((p[0].mean - y[0]).abs() < 0.3);
        assert!(p[0].variance < 0.1 * p[1].variance);
    }

    #[test]
    fn too_few_pairs_is_an_error() {
        assert!(GaussianProcess::fit(&[1.0, 2.0], &[1.0, 2.0], 3).is_err());
    }
}
