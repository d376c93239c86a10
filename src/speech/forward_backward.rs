//! The forward–backward pass with scaling (Rabiner 1989, §III-A and §V-A, eq. 91–93), giving
//! state and mixture-component posteriors, expected transition counts and the sequence's
//! log-likelihood.
//!
//! Emissions arrive as logs; each frame's are shifted by their maximum before
//! exponentiating, so the scaled recursion never underflows however small the densities of
//! an 81-dimensional observation are, and `ln P(O|λ) = Σ_t (ln c_t + m_t)` with c_t the
//! scale factor and m_t the shift.

use super::error::SpeechError;
use super::gaussian::log_sum_exp;
use crate::math::DMatrix;

/// What one forward–backward pass yields.
#[derive(Clone, Debug, PartialEq)]
pub struct Posteriors {
    /// γ_t(j), T × N.
    pub states: DMatrix,
    /// γ_t(j, k), T × N·M, state-major.
    pub components: DMatrix,
    /// Σ_t ξ_t(i, j), N × N.
    pub transitions: DMatrix,
    /// ln P(O | λ).
    pub log_likelihood: f64,
}

/// Runs forward–backward for one sequence.
///
/// `initial` is π (N), `transitions` A (N × N), `component_log` the T × N·M matrix of
/// `ln c_jk + ln N(o_t; μ_jk, Σ_jk)` from [`super::hmm::Hmm::component_log_densities`], with
/// `n_mixtures` = M components per state.
///
/// # Errors
/// No frames, inconsistent sizes, or a sequence impossible under the model.
pub fn forward_backward(
    initial: &[f64],
    transitions: &DMatrix,
    component_log: &DMatrix,
    n_mixtures: usize,
) -> Result<Posteriors, SpeechError> {
    let n = initial.len();
    let (t_len, nm) = component_log.shape();
    if t_len == 0 {
        return Err(SpeechError::Empty("frames in the sequence"));
    }
    if n_mixtures == 0 || nm != n * n_mixtures || transitions.shape() != (n, n) {
        return Err(SpeechError::DimensionMismatch {
            what: "emission columns (states × mixtures)",
            expected: n * n_mixtures,
            got: nm,
        });
    }
    // ln b_t(j) and the per-frame shift m_t.
    let mut log_b = DMatrix::zeros(t_len, n);
    for t in 0..t_len {
        for j in 0..n {
            log_b[(t, j)] =
                log_sum_exp((0..n_mixtures).map(|k| component_log[(t, j * n_mixtures + k)]));
        }
    }
    let shift: Vec<f64> = (0..t_len).map(|t| log_b.row(t).max()).collect();
    let impossible = || SpeechError::Degenerate("sequence (impossible under the model)".into());
    if shift.iter().any(|m| !m.is_finite()) {
        return Err(impossible());
    }
    let b = DMatrix::from_fn(t_len, n, |t, j| (log_b[(t, j)] - shift[t]).exp());

    let mut alpha = DMatrix::zeros(t_len, n);
    let mut scale = vec![0.0; t_len];
    for t in 0..t_len {
        for j in 0..n {
            let prior = if t == 0 {
                initial[j]
            } else {
                (0..n).map(|i| alpha[(t - 1, i)] * transitions[(i, j)]).sum()
            };
            alpha[(t, j)] = prior * b[(t, j)];
        }
        scale[t] = alpha.row(t).sum();
        if !(scale[t] > 0.0 && scale[t].is_finite()) {
            return Err(impossible());
        }
        let inv = 1.0 / scale[t];
        alpha.row_mut(t).scale_mut(inv);
    }
    let mut beta = DMatrix::zeros(t_len, n);
    beta.row_mut(t_len - 1).fill(1.0);
    for t in (0..t_len - 1).rev() {
        for i in 0..n {
            beta[(t, i)] =
                (0..n).map(|j| transitions[(i, j)] * b[(t + 1, j)] * beta[(t + 1, j)]).sum::<f64>()
                    / scale[t + 1];
        }
    }
    let mut states = alpha.component_mul(&beta);
    for mut row in states.row_iter_mut() {
        // Exactly 1 in exact arithmetic; renormalising stops rounding drift over long clips.
        let s = row.sum();
        row /= s;
    }
    let mut xi = DMatrix::zeros(n, n);
    for t in 0..t_len - 1 {
        for i in 0..n {
            for j in 0..n {
                xi[(i, j)] +=
                    alpha[(t, i)] * transitions[(i, j)] * b[(t + 1, j)] * beta[(t + 1, j)]
                        / scale[t + 1];
            }
        }
    }
    let components = DMatrix::from_fn(t_len, nm, |t, c| {
        let j = c / n_mixtures;
        states[(t, j)] * (component_log[(t, c)] - log_b[(t, j)]).exp()
    });
    let log_likelihood = scale.iter().zip(&shift).map(|(c, m)| c.ln() + m).sum();
    Ok(Posteriors { states, components, transitions: xi, log_likelihood })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Everything by enumerating all N^T state paths and, per frame, the mixture component.
    #[test]
    fn equals_brute_force_enumeration_on_a_tiny_model() {
        let (n, m, t_len) = (3usize, 2usize, 4usize);
        let pi = [0.5, 0.3, 0.2];
        let a = DMatrix::from_row_slice(3, 3, &[0.6, 0.3, 0.1, 0.2, 0.5, 0.3, 0.25, 0.25, 0.5]);
        // Arbitrary but fixed ln(c_jk N_jk(o_t)), of realistic magnitudes.
        let comp_log =
            DMatrix::from_fn(t_len, n * m, |t, c| -40.0 - ((t * 7 + c * 3) % 11) as f64 * 0.9);
        let got = forward_backward(&pi, &a, &comp_log, m).unwrap();

        let bt = |t: usize, j: usize| (0..m).map(|k| comp_log[(t, j * m + k)].exp()).sum::<f64>();
        let mut total = 0.0;
        let mut gamma = DMatrix::zeros(t_len, n);
        let mut xi = DMatrix::zeros(n, n);
        for code in 0..n.pow(t_len as u32) {
            let path: Vec<usize> = (0..t_len).map(|t| code / n.pow(t as u32) % n).collect();
            let mut p = pi[path[0]] * bt(0, path[0]);
            for t in 1..t_len {
                p *= a[(path[t - 1], path[t])] * bt(t, path[t]);
            }
            total += p;
            for t in 0..t_len {
                gamma[(t, path[t])] += p;
                if t + 1 < t_len {
                    xi[(path[t], path[t + 1])] += p;
                }
            }
        }
        assert!(
            (got.log_likelihood - total.ln()).abs() < 1e-9,
            "{} vs {}",
            got.log_likelihood,
            total.ln()
        );
        assert!((got.states - gamma.clone() / total).abs().max() < 1e-12);
        assert!((got.transitions - xi / total).abs().max() < 1e-12);
        // Component posteriors: γ_t(j) split in proportion to c_jk N_jk(o_t).
        let t = 2;
        let j = 1;
        let want = gamma[(t, j)] / total * comp_log[(t, j * m)].exp() / bt(t, j);
        assert!((got.components[(t, j * m)] - want).abs() < 1e-12);
    }

    #[test]
    fn impossible_or_empty_sequences_are_errors() {
        let a = DMatrix::identity(2, 2);
        let none = DMatrix::from_element(2, 2, f64::NEG_INFINITY);
        assert!(forward_backward(&[0.5, 0.5], &a, &none, 1).is_err());
        assert!(forward_backward(&[0.5, 0.5], &a, &DMatrix::zeros(0, 2), 1).is_err());
        assert!(forward_backward(&[0.5, 0.5], &a, &DMatrix::zeros(3, 3), 1).is_err());
    }
}
