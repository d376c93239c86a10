//! The SATF metric (Ma & Deng §5.1, eq. 1–7), after Ezzat et al.'s trajectory synthesis:
//!
//! `E = (y − U)ᵀ DᵀV⁻¹D (y − U) + λ yᵀWᵀW y`, minimised by
//! `(DᵀV⁻¹D + λWᵀW) y = DᵀV⁻¹D U` (eq. 4),
//!
//! with per phone i the context mean U_i and diagonal variance V_i (K coefficients), the
//! duration weight `D_i = √(1 − D_Pi/D_P)` (eq. 6; phone and utterance lengths in frames) and
//! W the difference operator of order p between consecutive phones (eq. 7; order 2 is
//! `(WW)ᵀ(WW)`, §5.1.2). V and D are diagonal, so the system splits into K independent
//! T×T band systems of half-bandwidth p, solved by [`super::banded`]. E is eq. 1 at the
//! optimum y.

use super::SaqpError;
use super::banded::BandMatrix;
use super::context::{ContextLevel, ContextStats, PhoneStats};
use super::prepared::PhoneSet;
use crate::alignment::Phone;
use crate::math::{DVector, short_number};
use serde::{Deserialize, Serialize};

/// λ and the order of W.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct SatfParams {
    pub lambda: f64,
    pub order: usize,
}

/// Largest λ accepted. The weights of the data term are at most 1 (V is normalised, D ≤ 1),
/// so past a million the solution is the smoothest curve already, and larger values only cost
/// the band solver its precision (λ = 10²⁰⁰ makes the system numerically singular).
pub const MAX_LAMBDA: f64 = 1e6;

impl SatfParams {
    /// The one rule for λ and the order, wherever they come from (flags, a model file):
    /// 0 ≤ λ ≤ [`MAX_LAMBDA`], order 1 or 2. The message starts with the field's name.
    ///
    /// # Errors
    /// The field at fault.
    pub fn check(&self) -> Result<(), String> {
        if !(self.lambda.is_finite() && (0.0..=MAX_LAMBDA).contains(&self.lambda)) {
            return Err(format!(
                "lambda {} is not within 0–{}",
                short_number(self.lambda),
                short_number(MAX_LAMBDA)
            ));
        }
        if !(1..=2).contains(&self.order) {
            return Err(format!("order {} is not 1 or 2", self.order));
        }
        Ok(())
    }
}

impl Default for SatfParams {
    /// The paper's choice (§5.1.2): λ = 0.5, first order.
    fn default() -> Self {
        Self { lambda: 0.5, order: 1 }
    }
}

/// The optimum of eq. 1 for one phone sequence.
#[derive(Clone, Debug, PartialEq)]
pub struct SatfFit {
    /// y_i per phone (K values each).
    pub y: Vec<DVector>,
    /// E at the optimum.
    pub e: f64,
    /// The context level each phone's statistics came from.
    pub levels: Vec<ContextLevel>,
}

/// Binomial coefficients with alternating sign: the rows of the order-p difference operator.
fn difference_stencil(order: usize) -> Vec<f64> {
    let mut c = vec![1.0];
    for _ in 0..order {
        let mut next = vec![0.0; c.len() + 1];
        for (j, &x) in c.iter().enumerate() {
            next[j] -= x;
            next[j + 1] += x;
        }
        c = next;
    }
    c
}

/// Solves eq. 4 and evaluates eq. 1 for phones with statistics `stats` and durations
/// `frames` (in frames).
///
/// # Errors
/// A system that is not positive definite (a variance of 0, a negative λ).
pub fn solve_satf(
    stats: &[PhoneStats],
    frames: &[f64],
    params: SatfParams,
) -> Result<SatfFit, SaqpError> {
    let t = stats.len();
    let k = stats.first().map_or(0, |s| s.mean.len());
    let total: f64 = frames.iter().sum();
    let d2: Vec<f64> = frames
        .iter()
        .map(|&f| if total > 0.0 { (1.0 - f / total).max(0.0) } else { 1.0 })
        .collect();
    let c = difference_stencil(params.order);
    let p = params.order.min(t.saturating_sub(1));
    let mut smooth = BandMatrix::zeros(t, p);
    if t > params.order {
        for r in 0..t - params.order {
            for (a, ca) in c.iter().enumerate() {
                for (b, cb) in c.iter().enumerate().take(a + 1) {
                    smooth.add(r + a, r + b, params.lambda * ca * cb);
                }
            }
        }
    }
    let mut y = vec![DVector::zeros(k); t];
    let mut e = 0.0;
    for j in 0..k {
        let w: Vec<f64> = (0..t).map(|i| d2[i] / stats[i].variance[j]).collect();
        let mut a = smooth.clone();
        for (i, wi) in w.iter().enumerate() {
            a.add(i, i, *wi);
        }
        let u: Vec<f64> = stats.iter().map(|s| s.mean[j]).collect();
        let rhs: Vec<f64> = (0..t).map(|i| w[i] * u[i]).collect();
        let yj = a.cholesky()?.solve(&rhs);
        let sy = smooth.mul(&yj);
        let fit: f64 = (0..t).map(|i| w[i] * (yj[i] - u[i]).powi(2)).sum();
        let rough: f64 = yj.iter().zip(&sy).map(|(a, b)| a * b).sum();
        e += fit + rough;
        for (yi, &v) in y.iter_mut().zip(&yj) {
            yi[j] = v;
        }
    }
    Ok(SatfFit { y, e, levels: stats.iter().map(|s| s.level).collect() })
}

/// The context statistics of every phone of a sequence.
///
/// # Errors
/// `AllPhonesUnseen` when no phone other than silence has at least monophone statistics,
/// `TooFewPhones` for fewer than two phones.
pub fn sequence_stats(
    name: &str,
    stats: &ContextStats,
    phones: &PhoneSet,
    ids: &[u16],
) -> Result<Vec<PhoneStats>, SaqpError> {
    if ids.len() < 2 {
        return Err(SaqpError::TooFewPhones(name.to_string()));
    }
    let out: Vec<PhoneStats> = (0..ids.len())
        .map(|i| stats.lookup(phones, ids, i))
        .collect::<Option<_>>()
        .ok_or_else(|| SaqpError::AllPhonesUnseen(name.to_string()))?;
    let seen = out
        .iter()
        .zip(ids)
        .any(|(s, &id)| phones.is_speech(id) && s.level <= ContextLevel::Monophone);
    if !seen {
        return Err(SaqpError::AllPhonesUnseen(name.to_string()));
    }
    Ok(out)
}

/// The SATF fit of a timed phone sequence (ids from `phones`) against a corpus's statistics.
///
/// # Errors
/// As [`sequence_stats`] and [`solve_satf`].
pub fn fit_trajectory(
    name: &str,
    stats: &ContextStats,
    phones: &PhoneSet,
    ids: &[u16],
    timing: &[Phone],
    fps: f64,
    params: SatfParams,
) -> Result<SatfFit, SaqpError> {
    let st = sequence_stats(name, stats, phones, ids)?;
    let frames: Vec<f64> = timing.iter().map(|p| (p.end - p.start).max(0.0) * fps).collect();
    solve_satf(&st, &frames, params)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::DMatrix;

    fn stats(means: &[[f64; 2]], vars: &[[f64; 2]]) -> Vec<PhoneStats> {
        means
            .iter()
            .zip(vars)
            .map(|(m, v)| PhoneStats {
                mean: DVector::from_row_slice(m),
                variance: DVector::from_row_slice(v),
                level: ContextLevel::Monophone,
                count: 1,
            })
            .collect()
    }

    #[test]
    fn lambda_and_order_are_bounded() {
        assert_eq!(SatfParams::default().check(), Ok(()));
        assert_eq!(SatfParams { lambda: MAX_LAMBDA, order: 2 }.check(), Ok(()));
        for bad in [-1.0, 1e200, f64::NAN] {
            let e = SatfParams { lambda: bad, order: 1 }.check().unwrap_err();
            assert!(e.starts_with("lambda"), "{e}");
        }
        assert!(SatfParams { lambda: 1.0, order: 3 }.check().unwrap_err().starts_with("order"));
    }

    #[test]
    fn stencils() {
        assert_eq!(difference_stencil(1), vec![-1.0, 1.0]);
        assert_eq!(difference_stencil(2), vec![1.0, -2.0, 1.0]);
    }

    #[test]
    fn lambda_zero_gives_the_means() {
        let s =
            stats(&[[1.0, -2.0], [3.0, 0.5], [-1.0, 4.0]], &[[0.5, 1.0], [2.0, 0.1], [1.0, 1.0]]);
        let fit = solve_satf(&s, &[3.0, 1.0, 6.0], SatfParams { lambda: 0.0, order: 1 }).unwrap();
        for (y, st) in fit.y.iter().zip(&s) {
            assert!((y - &st.mean).norm() < 1e-12);
        }
        assert!(fit.e.abs() < 1e-20);
    }

    #[test]
    fn matches_the_dense_normal_equations_and_objective() {
        let s = stats(
            &[[1.0, -2.0], [3.0, 0.5], [-1.0, 4.0], [0.0, 1.0], [2.0, 2.0]],
            &[[0.5, 1.0], [2.0, 0.1], [1.0, 1.0], [0.3, 0.7], [1.5, 0.2]],
        );
        let frames = [3.0, 1.0, 6.0, 2.0, 4.0];
        for order in [1, 2] {
            let params = SatfParams { lambda: 0.7, order };
            let fit = solve_satf(&s, &frames, params).unwrap();
            let t = s.len();
            let total: f64 = frames.iter().sum();
            let c = difference_stencil(order);
            let mut w = DMatrix::zeros(t - order, t);
            for r in 0..t - order {
                for (j, cj) in c.iter().enumerate() {
                    w[(r, r + j)] = *cj;
                }
            }
            for k in 0..2 {
                let dvd = DMatrix::from_fn(t, t, |i, j| {
                    if i == j { (1.0 - frames[i] / total) / s[i].variance[k] } else { 0.0 }
                });
                let u = DVector::from_fn(t, |i, _| s[i].mean[k]);
                let a = &dvd + w.transpose() * &w * params.lambda;
                let y = a.clone().cholesky().unwrap().solve(&(&dvd * &u));
                for i in 0..t {
                    assert!((fit.y[i][k] - y[i]).abs() < 1e-10);
                }
            }
            // E is eq. 1 at the optimum: summed over both coefficients.
            let mut e = 0.0;
            for k in 0..2 {
                let y = DVector::from_fn(t, |i, _| fit.y[i][k]);
                let u = DVector::from_fn(t, |i, _| s[i].mean[k]);
                let dvd = DMatrix::from_fn(t, t, |i, j| {
                    if i == j { (1.0 - frames[i] / total) / s[i].variance[k] } else { 0.0 }
                });
                let r = &y - &u;
                e += (r.transpose() * &dvd * &r)[0] + params.lambda * (&w * &y).norm_squared();
            }
            assert!((fit.e - e).abs() < 1e-10 * e.max(1.0));
        }
    }
}
