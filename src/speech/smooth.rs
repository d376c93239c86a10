//! Gaussian smoothing of feature trajectories over time.
//!
//! Two places use it, with one width ([`super::FeatureDescription::smoothing_s`]): the visual
//! features of fitted clips, whose frame-to-frame jitter is the tracker's and the per-frame
//! fit's, not the mouth's (the paper's tracker, a model-based one, smooths by construction);
//! and the inversion's estimate, which switches between states frame by frame where a mouth,
//! a mass moved by muscles, cannot.

use crate::math::DMatrix;

/// Each column of `m` (rows are frames) convolved with a Gaussian of `sigma_frames`,
/// truncated at 3σ and renormalised, the first and last rows repeated past the ends (so a
/// constant stays constant and a clip's edges are not pulled towards zero). σ ≤ 0 returns
/// `m` unchanged.
pub fn smooth_rows(m: &DMatrix, sigma_frames: f64) -> DMatrix {
    if sigma_frames.is_nan() || sigma_frames <= 0.0 || m.nrows() < 2 {
        return m.clone();
    }
    let radius = (3.0 * sigma_frames).ceil() as usize;
    let kernel: Vec<f64> = (0..=2 * radius)
        .map(|i| {
            let d = i as f64 - radius as f64;
            (-d * d / (2.0 * sigma_frames * sigma_frames)).exp()
        })
        .collect();
    let total: f64 = kernel.iter().sum();
    let last = m.nrows() - 1;
    DMatrix::from_fn(m.nrows(), m.ncols(), |t, k| {
        kernel
            .iter()
            .enumerate()
            .map(|(i, w)| w * m[((t + i).saturating_sub(radius).min(last), k)])
            .sum::<f64>()
            / total
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn constants_stay_and_an_impulse_spreads_as_a_gaussian() {
        let c = DMatrix::from_element(9, 2, 3.5);
        assert!((smooth_rows(&c, 1.5) - &c).abs().max() < 1e-12);
        let mut x = DMatrix::zeros(21, 1);
        x[(10, 0)] = 1.0;
        let y = smooth_rows(&x, 1.0);
        // Weights e^{−d²/2} over d = −3 … 3, normalised.
        let total: f64 = (-3..=3).map(|d: i32| (-(d * d) as f64 / 2.0).exp()).sum();
        assert!((y[(10, 0)] - 1.0 / total).abs() < 1e-12);
        assert!((y[(11, 0)] - (-0.5f64).exp() / total).abs() < 1e-12);
        assert_eq!(y[(14, 0)], 0.0);
        assert!((y.sum() - 1.0).abs() < 1e-12);
        assert_eq!(smooth_rows(&x, 0.0), x);
    }
}
