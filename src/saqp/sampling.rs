//! Per-phone representative samples and the reverse, frames from per-phone keys.
//!
//! The paper takes a viseme's middle frame as its representative sample (§5.1). At 25 fps a
//! consonant can cover one frame or none, so a middle frame need not exist; the trajectory
//! is instead interpolated linearly at the phone's midpoint time (frame `f` is at `f/fps`).

use crate::alignment::Phone;
use crate::math::DVector;

/// The trajectory at fractional frame `x` (linear between neighbours, held at the ends).
/// `frames` must not be empty.
pub fn sample_at(frames: &[DVector], x: f64) -> DVector {
    let last = frames.len() - 1;
    if x.is_nan() || x <= 0.0 {
        return frames[0].clone();
    }
    if x >= last as f64 {
        return frames[last].clone();
    }
    let i = x.floor() as usize;
    let w = x - i as f64;
    &frames[i] * (1.0 - w) + &frames[i + 1] * w
}

/// The midpoint time of a phone, seconds.
pub fn midpoint(phone: &Phone) -> f64 {
    0.5 * (phone.start + phone.end)
}

/// One representative sample per phone: the trajectory at the phone's midpoint.
pub fn phone_midpoint_samples(frames: &[DVector], fps: f64, phones: &[Phone]) -> Vec<DVector> {
    phones.iter().map(|p| sample_at(frames, midpoint(p) * fps)).collect()
}

/// Frames `0..n_frames` from keys at times `key_times` (seconds, ascending): linear between
/// keys, held before the first and after the last. `keys` must not be empty.
pub fn interpolate_keys(
    key_times: &[f64],
    keys: &[DVector],
    fps: f64,
    n_frames: usize,
) -> Vec<DVector> {
    let mut k = 0;
    (0..n_frames)
        .map(|f| {
            let t = f as f64 / fps;
            while k + 1 < key_times.len() && key_times[k + 1] <= t {
                k += 1;
            }
            if t <= key_times[0] {
                return keys[0].clone();
            }
            if k + 1 >= keys.len() {
                return keys[keys.len() - 1].clone();
            }
            let span = key_times[k + 1] - key_times[k];
            let w = if span > 0.0 { (t - key_times[k]) / span } else { 1.0 };
            &keys[k] * (1.0 - w) + &keys[k + 1] * w
        })
        .collect()
}

/// `frames` convolved with a Gaussian of standard deviation `sigma` frames (cut at 3σ,
/// renormalised at the ends so a constant stays constant); σ ≤ 0 returns them unchanged.
pub fn smooth_gaussian(frames: &[DVector], sigma: f64) -> Vec<DVector> {
    if sigma.is_nan() || sigma <= 0.0 || frames.is_empty() {
        return frames.to_vec();
    }
    let reach = (3.0 * sigma).ceil() as usize;
    let weights: Vec<f64> =
        (0..=reach).map(|d| (-0.5 * (d as f64 / sigma).powi(2)).exp()).collect();
    let n = frames.len();
    (0..n)
        .map(|f| {
            let (lo, hi) = (f.saturating_sub(reach), (f + reach).min(n - 1));
            let mut acc = DVector::zeros(frames[f].len());
            let mut total = 0.0;
            for (g, frame) in frames.iter().enumerate().take(hi + 1).skip(lo) {
                let w = weights[g.abs_diff(f)];
                acc.axpy(w, frame, 1.0);
                total += w;
            }
            acc / total
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn v(x: f64) -> DVector {
        DVector::from_vec(vec![x])
    }

    #[test]
    fn midpoint_sample_of_a_zero_frame_phone_interpolates() {
        // Frames at 0, 0.04, 0.08 s hold 0, 1, 2; a phone 0.045–0.055 s covers no frame.
        let frames = vec![v(0.0), v(1.0), v(2.0)];
        let p = Phone { start: 0.045, end: 0.055, label: "B".into() };
        let s = phone_midpoint_samples(&frames, 25.0, &[p]);
        assert!((s[0][0] - 1.25).abs() < 1e-12);
    }

    #[test]
    fn keys_interpolate_and_hold() {
        let out = interpolate_keys(&[0.1, 0.3], &[v(0.0), v(2.0)], 10.0, 5);
        let got: Vec<f64> = out.iter().map(|x| x[0]).collect();
        let want = [0.0, 0.0, 1.0, 2.0, 2.0];
        for (g, w) in got.iter().zip(want) {
            assert!((g - w).abs() < 1e-12, "{got:?}");
        }
    }

    #[test]
    fn smoothing_keeps_constants_and_lines_and_damps_alternation() {
        let line: Vec<DVector> = (0..9).map(|i| v(2.0 * i as f64 + 1.0)).collect();
        let out = smooth_gaussian(&line, 1.0);
        // Away from the ends a symmetric kernel leaves a line unchanged.
        for f in 3..6 {
            assert!((out[f][0] - line[f][0]).abs() < 1e-12, "{f}: {}", out[f][0]);
        }
        let flat = smooth_gaussian(&vec![v(3.0); 5], 0.7);
        assert!(flat.iter().all(|x| (x[0] - 3.0).abs() < 1e-12));
        let zigzag: Vec<DVector> =
            (0..20).map(|i| v(if i % 2 == 0 { 1.0 } else { -1.0 })).collect();
        let damped = smooth_gaussian(&zigzag, 0.5);
        // σ = ½ frame: neighbours weigh e⁻², the next e⁻⁸ (3σ reaches two frames).
        let (w1, w2) = ((-2.0f64).exp(), (-8.0f64).exp());
        let want = (1.0 - 2.0 * w1 + 2.0 * w2) / (1.0 + 2.0 * w1 + 2.0 * w2);
        assert!((damped[10][0] - want).abs() < 1e-12, "{} vs {want}", damped[10][0]);
        assert!(want < 0.6);
        assert_eq!(smooth_gaussian(&zigzag, 0.0), zigzag);
    }
}
