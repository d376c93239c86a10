//! The joint audio-visual HMM λ_av = (A, B, π) of Terissi et al. 2011, §4: N ergodic states,
//! each emitting the joint vector `o_avt = [o_atᵀ, o_vtᵀ]ᵀ` from a mixture of M
//! full-covariance Gaussians, `b_j(o) = Σ_k c_jk N(o; μ_jk, Σ_jk)` (eq. 1).
//!
//! Training is in [`super::baum_welch`], the forward–backward pass in
//! [`super::forward_backward`], inversion in [`super::inversion`].

use super::error::{SpeechError, check_finite_within, field_error};
use super::gaussian::{Gaussian, GaussianParams};
use crate::math::DMatrix;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// One mixture component: weight c_jk and its Gaussian.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Component {
    pub weight: f64,
    pub gaussian: Gaussian,
}

/// A continuous-density HMM with Gaussian-mixture emissions. Read from a file, every
/// Gaussian is checked as it is built and a fault is named by its place
/// (`hmm.states[3][1].gaussian.mean[7]: …`).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "HmmParams")]
pub struct Hmm {
    /// π_j, initial state probabilities.
    pub initial: Vec<f64>,
    /// A, N × N; row i holds P(s_{t+1} = j | s_t = i).
    pub transitions: DMatrix,
    /// B: `states[j][k]` is component k of state j; every state has the same M.
    pub states: Vec<Vec<Component>>,
}

/// Largest magnitude of a mean or covariance value a model file may hold. Features are
/// normalised (cepstra to unit variance) or in model units (mouth motion, millimetres for
/// the usual models), so anything near this is a damaged file, not a model.
pub const MAX_PARAMETER: f64 = 1e6;

#[derive(Deserialize)]
struct ComponentParams {
    weight: f64,
    gaussian: GaussianParams,
}

#[derive(Deserialize)]
struct HmmParams {
    initial: Vec<f64>,
    transitions: DMatrix,
    states: Vec<Vec<ComponentParams>>,
}

impl TryFrom<HmmParams> for Hmm {
    type Error = SpeechError;
    fn try_from(p: HmmParams) -> Result<Self, SpeechError> {
        let mut states = Vec::with_capacity(p.states.len());
        for (j, state) in p.states.into_iter().enumerate() {
            let mut comps = Vec::with_capacity(state.len());
            for (k, c) in state.into_iter().enumerate() {
                let at = format!("hmm.states[{j}][{k}]");
                check_finite_within(
                    &format!("{at}.gaussian.mean"),
                    c.gaussian.mean.iter().copied(),
                    MAX_PARAMETER,
                )?;
                check_finite_within(
                    &format!("{at}.gaussian.cov"),
                    c.gaussian.cov.iter().copied(),
                    MAX_PARAMETER,
                )?;
                let gaussian = Gaussian::new(c.gaussian.mean, c.gaussian.cov)
                    .map_err(|e| field_error(format!("{at}.gaussian"), e.to_string()))?;
                comps.push(Component { weight: c.weight, gaussian });
            }
            states.push(comps);
        }
        let hmm = Hmm { initial: p.initial, transitions: p.transitions, states };
        hmm.validate()?;
        Ok(hmm)
    }
}

impl Hmm {
    pub fn n_states(&self) -> usize {
        self.states.len()
    }

    pub fn n_mixtures(&self) -> usize {
        self.states.first().map_or(0, Vec::len)
    }

    /// Dimension of the observations.
    pub fn dim(&self) -> usize {
        self.components().next().map_or(0, |c| c.gaussian.dim())
    }

    /// All components, state-major: component k of state j is number j·M + k.
    pub fn components(&self) -> impl Iterator<Item = &Component> {
        self.states.iter().flatten()
    }

    /// Checks shapes and probabilities (after loading; the Gaussians check themselves).
    ///
    /// # Errors
    /// Inconsistent sizes, probabilities that are negative or do not sum to 1, a covariance
    /// that is not positive definite.
    pub fn validate(&self) -> Result<(), SpeechError> {
        let n = self.states.len();
        if n == 0 {
            return Err(SpeechError::Empty("HMM states"));
        }
        let m = self.n_mixtures();
        let d = self.dim();
        let mismatch = |what, expected, got| SpeechError::DimensionMismatch { what, expected, got };
        if self.initial.len() != n {
            return Err(mismatch("initial probabilities", n, self.initial.len()));
        }
        if self.transitions.shape() != (n, n) {
            return Err(mismatch("transition matrix rows", n, self.transitions.nrows()));
        }
        let is_distribution = |p: &mut dyn Iterator<Item = f64>| -> bool {
            let v: Vec<f64> = p.collect();
            v.iter().all(|x| x.is_finite() && *x >= 0.0)
                && (v.iter().sum::<f64>() - 1.0).abs() < 1e-6
        };
        let not_distribution = "not a probability distribution (values in [0, 1] summing to 1)";
        if !is_distribution(&mut self.initial.iter().copied()) {
            return Err(field_error("hmm.initial", not_distribution));
        }
        for (i, row) in self.transitions.row_iter().enumerate() {
            if !is_distribution(&mut row.iter().copied()) {
                return Err(field_error(format!("hmm.transitions row {i}"), not_distribution));
            }
        }
        for (j, state) in self.states.iter().enumerate() {
            if state.len() != m {
                return Err(mismatch("mixture components per state", m, state.len()));
            }
            if !is_distribution(&mut state.iter().map(|c| c.weight)) {
                return Err(field_error(format!("hmm.states[{j}] weights"), not_distribution));
            }
            if let Some(c) = state.iter().find(|c| c.gaussian.dim() != d) {
                return Err(mismatch("component dimension", d, c.gaussian.dim()));
            }
        }
        Ok(())
    }

    /// `ln c_jk + ln N(o_t; μ_jk, Σ_jk)` for every frame (rows of `obs`, T × d) and component
    /// (columns, state-major): T × N·M.
    ///
    /// # Errors
    /// `obs` has the wrong number of columns.
    pub fn component_log_densities(&self, obs: &DMatrix) -> Result<DMatrix, SpeechError> {
        if obs.ncols() != self.dim() {
            return Err(SpeechError::DimensionMismatch {
                what: "observation dimension",
                expected: self.dim(),
                got: obs.ncols(),
            });
        }
        let comps: Vec<&Component> = self.components().collect();
        let cols: Vec<_> = comps
            .par_iter()
            .map(|c| {
                let mut l = c.gaussian.log_density_rows(obs);
                l.add_scalar_mut(c.weight.ln());
                l
            })
            .collect();
        Ok(DMatrix::from_columns(&cols))
    }
}
