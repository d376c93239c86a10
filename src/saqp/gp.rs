//! Gaussian-process regression of quality on the SATF metric and the sentence's context
//! coverage (Ma & Deng §5.2.1, eq. 9–11; Rasmussen & Williams, "Gaussian Processes for
//! Machine Learning", 2006, Alg. 2.1 and eq. 5.9). The kernel is eq. 10's ARD covariance,
//! one length-scale per input: `k(x, x') = θ₂·exp(−½ Σ_d (x_d − x'_d)² / θ₁d²)`, plus noise
//! σ²·I.
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

/// θ₁ (one length-scale per input), θ₂ (signal variance) and σ² (noise variance).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GpHyper {
    pub length_scales: Vec<f64>,
    pub signal_variance: f64,
    pub noise_variance: f64,
}

impl GpHyper {
    fn from_log(t: &[f64]) -> Self {
        let d = t.len() - 2;
        Self {
            length_scales: t[..d].iter().map(|v| v.exp()).collect(),
            signal_variance: t[d].exp(),
            noise_variance: t[d + 1].exp(),
        }
    }

    fn to_log(&self) -> Vec<f64> {
        let mut t: Vec<f64> = self.length_scales.iter().map(|v| v.ln()).collect();
        t.push(self.signal_variance.ln());
        t.push(self.noise_variance.ln());
        t
    }

    /// The kernel without noise between two inputs.
    fn covariance(&self, a: &[f64], b: &[f64]) -> f64 {
        let r2: f64 =
            a.iter().zip(b).zip(&self.length_scales).map(|((x, y), l)| ((x - y) / l).powi(2)).sum();
        self.signal_variance * (-0.5 * r2).exp()
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
    /// One input vector per training pair, all of the length of `hyper.length_scales`.
    pub inputs: Vec<Vec<f64>>,
    pub targets: Vec<f64>,
    pub target_mean: f64,
    /// The negative log marginal likelihood (eq. 9) at `hyper`, of the centred targets.
    pub nlml: f64,
}

/// Keeps the factorisation defined when σ² → 0 (relative to θ₂).
const JITTER: f64 = 1e-10;
/// Log-hyperparameters are kept within ±this, where the likelihood is numerically sound.
pub const LOG_BOUND: f64 = 25.0;

fn kernel_matrix(x: &[Vec<f64>], h: &GpHyper) -> (DMatrix, DMatrix) {
    let n = x.len();
    let se = DMatrix::from_fn(n, n, |i, j| h.covariance(&x[i], &x[j]));
    let mut k = se.clone();
    for i in 0..n {
        k[(i, i)] += h.noise_variance + JITTER * h.signal_variance;
    }
    (se, k)
}

/// Eq. 9 and its gradient with respect to `theta = [ln θ₁₁ … ln θ₁d, ln θ₂, ln σ²]`, for
/// inputs `x` and (centred) targets `y`. `None` where K is not positive definite or θ out of
/// range.
pub fn negative_log_marginal_likelihood(
    x: &[Vec<f64>],
    y: &[f64],
    theta: &[f64],
) -> Option<(f64, Vec<f64>)> {
    if theta.len() < 3 || theta.iter().any(|t| !t.is_finite() || t.abs() > LOG_BOUND) {
        return None;
    }
    let h = GpHyper::from_log(theta);
    let d = h.length_scales.len();
    let n = x.len();
    let (se, k) = kernel_matrix(x, &h);
    let chol = Cholesky::new(k)?;
    let yv = DVector::from_column_slice(y);
    let alpha = chol.solve(&yv);
    let logdet: f64 = chol.l_dirty().diagonal().iter().map(|d| d.ln()).sum();
    let value = 0.5 * yv.dot(&alpha) + logdet + 0.5 * n as f64 * (2.0 * std::f64::consts::PI).ln();
    let inv = chol.inverse();
    // tr((K⁻¹ − ααᵀ)·∂K) for symmetric ∂K is the sum of the elementwise product.
    let mut g = vec![0.0; d + 2];
    for i in 0..n {
        for j in 0..n {
            let a = (inv[(i, j)] - alpha[i] * alpha[j]) * se[(i, j)];
            for (gl, (xi, (xj, l))) in
                g.iter_mut().zip(x[i].iter().zip(x[j].iter().zip(&h.length_scales)))
            {
                *gl += a * ((xi - xj) / l).powi(2);
            }
            g[d] += a;
        }
        g[d + 1] += (inv[(i, i)] - alpha[i] * alpha[i]) * h.noise_variance;
    }
    Some((value, g.into_iter().map(|v| 0.5 * v).collect()))
}

impl GaussianProcess {
    /// Fits θ₁, θ₂, σ² to (input, score) pairs by minimising eq. 9 from `restarts` starting
    /// points (length-scales spread over each input's range, noise from a twentieth to half
    /// the targets' variance), keeping the best.
    ///
    /// # Errors
    /// Fewer than 3 pairs, inputs of different lengths, non-finite values, or no start where
    /// eq. 9 is defined.
    pub fn fit(inputs: &[Vec<f64>], targets: &[f64], restarts: usize) -> Result<Self, SaqpError> {
        let n = inputs.len();
        if n < 3 || targets.len() != n {
            return Err(SaqpError::Gp(format!("{n} training pairs; at least 3 are needed")));
        }
        let d = inputs[0].len();
        if d == 0 || inputs.iter().any(|x| x.len() != d) {
            return Err(SaqpError::Gp("training inputs of different lengths".into()));
        }
        if inputs.iter().flatten().chain(targets).any(|v| !v.is_finite()) {
            return Err(SaqpError::Gp("a training value is not finite".into()));
        }
        let target_mean = targets.iter().sum::<f64>() / n as f64;
        let y: Vec<f64> = targets.iter().map(|t| t - target_mean).collect();
        let var = (y.iter().map(|v| v * v).sum::<f64>() / n as f64).max(1e-12);
        let ranges: Vec<f64> = (0..d)
            .map(|k| {
                let (lo, hi) =
                    inputs.iter().fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), x| {
                        (a.min(x[k]), b.max(x[k]))
                    });
                (hi - lo).max(1e-9)
            })
            .collect();
        let starts: Vec<GpHyper> = (0..restarts.max(1))
            .map(|r| {
                let frac = [0.3, 0.08, 1.0, 0.02, 3.0][r % 5];
                let noise = [0.2, 0.5, 0.1, 0.3, 0.05][r % 5];
                GpHyper {
                    length_scales: ranges.iter().map(|range| frac * range).collect(),
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

    fn factor(&self) -> Result<(Cholesky<f64, nalgebra::Dyn>, DVector), SaqpError> {
        let (_, k) = kernel_matrix(&self.inputs, &self.hyper);
        let chol = Cholesky::new(k)
            .ok_or_else(|| SaqpError::Gp("kernel matrix not positive definite".into()))?;
        let y = DVector::from_iterator(
            self.targets.len(),
            self.targets.iter().map(|t| t - self.target_mean),
        );
        let alpha = chol.solve(&y);
        Ok((chol, alpha))
    }

    /// Predictions at new inputs (eq. 11: U(e) = κᵀ(K + σ²I)⁻¹Q, V(e) = k(e,e) − κᵀ(K + σ²I)⁻¹κ).
    ///
    /// # Errors
    /// A kernel matrix that is not positive definite (corrupted hyperparameters), or an input
    /// of another length than the training inputs.
    pub fn predict(&self, at: &[Vec<f64>]) -> Result<Vec<GpPrediction>, SaqpError> {
        let h = &self.hyper;
        if at.iter().any(|x| x.len() != h.length_scales.len()) {
            return Err(SaqpError::Gp(format!(
                "an input of another length than the model's {}",
                h.length_scales.len()
            )));
        }
        let (chol, alpha) = self.factor()?;
        Ok(at
            .iter()
            .map(|e| {
                let kappa = DVector::from_iterator(
                    self.inputs.len(),
                    self.inputs.iter().map(|x| h.covariance(x, e)),
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

    /// Residuals of the training targets when each group of pairs is left out in turn, at
    /// the fitted hyperparameters, in closed form (Rasmussen & Williams §5.4.2 for one pair;
    /// for a group G, `r_G = [K⁻¹]_GG⁻¹ [K⁻¹Q]_G`). `groups[i]` names pair i's group: pairs
    /// of one sentence scored in several sub-corpora are near copies, and leaving out one
    /// copy while its twins stay would flatter a flexible model.
    ///
    /// # Errors
    /// A kernel matrix that is not positive definite, or `groups` of the wrong length.
    pub fn group_residuals(&self, groups: &[usize]) -> Result<Vec<f64>, SaqpError> {
        if groups.len() != self.targets.len() {
            return Err(SaqpError::Gp("one group per training pair is needed".into()));
        }
        let (chol, alpha) = self.factor()?;
        let inv = chol.inverse();
        let mut out = vec![0.0; groups.len()];
        let mut members: std::collections::BTreeMap<usize, Vec<usize>> = Default::default();
        for (i, &g) in groups.iter().enumerate() {
            members.entry(g).or_default().push(i);
        }
        for idx in members.values() {
            let m = idx.len();
            let block = DMatrix::from_fn(m, m, |a, b| inv[(idx[a], idx[b])]);
            let a = DVector::from_iterator(m, idx.iter().map(|&i| alpha[i]));
            let r = block
                .cholesky()
                .ok_or_else(|| SaqpError::Gp("kernel matrix not positive definite".into()))?
                .solve(&a);
            for (k, &i) in idx.iter().enumerate() {
                out[i] = r[k];
            }
        }
        Ok(out)
    }

    /// Checks a process read from a file: as many targets as inputs, at least one, every
    /// input of the hyperparameters' length, every value finite and the hyperparameters
    /// positive within the range the fit keeps them in.
    ///
    /// # Errors
    /// The first inconsistency found, naming the field.
    pub fn validate(&self) -> Result<(), String> {
        let d = self.hyper.length_scales.len();
        if self.inputs.is_empty() || self.inputs.len() != self.targets.len() {
            return Err(format!(
                "gp: {} inputs and {} targets (they must match and not be empty)",
                self.inputs.len(),
                self.targets.len()
            ));
        }
        if d == 0 || self.inputs.iter().any(|x| x.len() != d) {
            return Err(format!(
                "gp.inputs: every input must have {d} values, one per length scale"
            ));
        }
        if self.inputs.iter().flatten().any(|v| !(v.is_finite() && v.abs() <= 1e9)) {
            return Err("gp.inputs: a value is not finite or beyond ±1e9".into());
        }
        if self.targets.iter().any(|v| !v.is_finite()) {
            return Err("gp.targets: a value is not finite".into());
        }
        if !self.nlml.is_finite() {
            return Err("gp.nlml is not finite".into());
        }
        let h = &self.hyper;
        let (lo, hi) = ((-LOG_BOUND).exp(), LOG_BOUND.exp());
        for (name, v) in h
            .length_scales
            .iter()
            .map(|&v| ("length_scales", v))
            .chain([("signal_variance", h.signal_variance), ("noise_variance", h.noise_variance)])
        {
            if !(v.is_finite() && (lo..=hi).contains(&v)) {
                return Err(format!(
                    "gp.hyper.{name} {} is not within e^-25–e^25",
                    crate::math::short_number(v)
                ));
            }
        }
        Ok(())
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
        let x: Vec<Vec<f64>> =
            (0..25).map(|i| vec![(i as f64 * 0.37).sin() * 3.0, (i as f64 * 0.11).cos()]).collect();
        let y: Vec<f64> = x.iter().map(|v| (v[0] * 1.3).cos() + 0.1 * v[0] + v[1]).collect();
        for theta in [[0.2, 0.5, -0.3, -2.0], [-0.5, -0.2, 0.4, -4.0], [1.0, 0.1, 0.0, -1.0]] {
            let (_, g) = negative_log_marginal_likelihood(&x, &y, &theta).unwrap();
            for j in 0..4 {
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
        let truth =
            GpHyper { length_scales: vec![0.7], signal_variance: 1.0, noise_variance: 0.01 };
        let mut rng = StdRng::seed_from_u64(11);
        let x: Vec<Vec<f64>> = (0..300).map(|_| vec![rng.random_range(0.0..15.0)]).collect();
        let (_, k) = kernel_matrix(&x, &truth);
        let l = Cholesky::new(k).unwrap().unpack();
        let z = DVector::from_fn(x.len(), |_, _| rng.sample::<f64, _>(StandardNormal));
        let y = l * z;
        let gp = GaussianProcess::fit(&x, y.as_slice(), 4).unwrap();
        let h = &gp.hyper;
        assert!((h.length_scales[0] / truth.length_scales[0] - 1.0).abs() < 0.25, "{h:?}");
        assert!((h.signal_variance / truth.signal_variance - 1.0).abs() < 0.5, "{h:?}");
        // The mean follows the data and the variance shrinks near training inputs.
        let p = gp.predict(&[x[0].clone(), vec![100.0]]).unwrap();
        assert!((p[0].mean - y[0]).abs() < 0.3);
        assert!(p[0].variance < 0.1 * p[1].variance);
    }

    #[test]
    fn an_irrelevant_input_gets_a_long_length_scale() {
        // The target follows input 0; input 1 is noise: ARD should switch it off.
        let mut rng = StdRng::seed_from_u64(3);
        let x: Vec<Vec<f64>> = (0..120)
            .map(|_| vec![rng.random_range(0.0..10.0), rng.random_range(0.0..10.0)])
            .collect();
        let y: Vec<f64> = x
            .iter()
            .map(|v| (v[0] * 0.6).sin() + 0.05 * rng.sample::<f64, _>(StandardNormal))
            .collect();
        let gp = GaussianProcess::fit(&x, &y, 3).unwrap();
        let l = &gp.hyper.length_scales;
        assert!(l[1] > 5.0 * l[0], "{l:?}");
    }

    #[test]
    fn leaving_out_a_group_matches_refitting_without_it() {
        let x: Vec<Vec<f64>> = (0..30).map(|i| vec![(i as f64 * 0.31).sin() * 4.0]).collect();
        let y: Vec<f64> = x.iter().map(|v| v[0].cos() + 0.3 * v[0]).collect();
        let gp = GaussianProcess::fit(&x, &y, 2).unwrap();
        let groups: Vec<usize> = (0..30).map(|i| i / 3).collect();
        let r = gp.group_residuals(&groups).unwrap();
        // Group 4 (pairs 12–14) by hand: the same hyperparameters and prior mean, the
        // other 27 pairs.
        let keep: Vec<usize> = (0..30).filter(|i| i / 3 != 4).collect();
        let rest = GaussianProcess {
            inputs: keep.iter().map(|&i| x[i].clone()).collect(),
            targets: keep.iter().map(|&i| y[i]).collect(),
            ..gp.clone()
        };
        let p = rest.predict(&[x[12].clone(), x[13].clone(), x[14].clone()]).unwrap();
        for (k, i) in (12..15).enumerate() {
            assert!(
                (r[i] - (y[i] - p[k].mean)).abs() < 1e-8,
                "{i}: {} vs {}",
                r[i],
                y[i] - p[k].mean
            );
        }
    }

    #[test]
    fn too_few_pairs_is_an_error() {
        assert!(GaussianProcess::fit(&[vec![1.0], vec![2.0]], &[1.0, 2.0], 3).is_err());
    }
}
