//! Sealed lips on a tracker that never closes them. A tracker such as dlib leaves a small
//! gap between sealed inner lips, and a fit to those landmarks keeps the fitted lips apart;
//! closures (/p b m/) then never reach H = 0. Here the clip's own distribution of the
//! tracked inner-lip gap (the video's H) is split in two clusters, the lower one is taken as
//! the tracker's "sealed" mode, and frames inside it get H = 0 in the video and the head.
//! Why this and not a closure term in the fit: `docs/closure.md`. Start at
//! [`estimate_closed_lips`].

use super::{Series, Trajectory};
use serde::{Deserialize, Serialize};

/// How sealed lips are measured.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Closure {
    /// H as measured.
    Off,
    /// H = 0 (video and head) on frames whose tracked gap lies in the clip's sealed mode.
    #[default]
    Snap,
}

impl Closure {
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }
}

/// Why no sealed mode can be estimated.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ClosureError {
    #[error("{0} frames with an inner-lip gap; at least {MIN_FRAMES} are needed")]
    TooFewFrames(usize),
    #[error("the inner-lip gap does not vary over the clip")]
    NoSpread,
}

/// Fewest measured frames a sealed mode is estimated from.
pub const MIN_FRAMES: usize = 10;

/// Robust sigmas above the sealed mode's median that still count as sealed.
pub const SEALED_SIGMAS: f64 = 1.0;

/// The clip's sealed mode of the tracked inner-lip gap (in H units).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClosedLips {
    /// Median gap of the lower cluster.
    pub mode: f64,
    /// Its robust spread, 1.4826·MAD.
    pub spread: f64,
    /// Otsu's split between the two clusters.
    pub split: f64,
    /// Gaps at or below this are sealed: `min(split, mode + SEALED_SIGMAS·spread)`.
    pub threshold: f64,
}

fn median(v: &[f64]) -> f64 {
    let n = v.len();
    if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) }
}

/// The sealed mode of `gaps` (the video's H per frame; `None` and non-finite values skipped).
/// The two clusters come from Otsu's threshold (Otsu 1979, "A threshold selection method
/// from gray-level histograms", eq. 18: the split maximising the between-class variance
/// ω₀ω₁(μ₀ − μ₁)²), here over the sorted values rather than a histogram. The threshold is
/// capped at the lower cluster's median + `SEALED_SIGMAS` robust sigmas, so that a clip that
/// is mostly half-open does not count its half-open frames as sealed.
///
/// # Errors
/// Fewer than [`MIN_FRAMES`] values; all values equal.
pub fn estimate_closed_lips(gaps: &[Option<f64>]) -> Result<ClosedLips, ClosureError> {
    let mut v: Vec<f64> = gaps.iter().flatten().copied().filter(|g| g.is_finite()).collect();
    if v.len() < MIN_FRAMES {
        return Err(ClosureError::TooFewFrames(v.len()));
    }
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len() as f64;
    if v[v.len() - 1] - v[0] <= 1e-12 {
        return Err(ClosureError::NoSpread);
    }
    let total: f64 = v.iter().sum();
    let (mut best, mut best_k, mut below) = (f64::NEG_INFINITY, 1, 0.0);
    for k in 1..v.len() {
        below += v[k - 1];
        if v[k] == v[k - 1] {
            continue;
        }
        let (w0, w1) = (k as f64 / n, 1.0 - k as f64 / n);
        let (m0, m1) = (below / k as f64, (total - below) / (n - k as f64));
        let between = w0 * w1 * (m0 - m1).powi(2);
        if between > best {
            (best, best_k) = (between, k);
        }
    }
    let low = &v[..best_k];
    let mode = median(low);
    let mut dev: Vec<f64> = low.iter().map(|g| (g - mode).abs()).collect();
    dev.sort_by(|a, b| a.total_cmp(b));
    let spread = 1.4826 * median(&dev);
    let split = 0.5 * (v[best_k - 1] + v[best_k]);
    Ok(ClosedLips { mode, spread, split, threshold: split.min(mode + SEALED_SIGMAS * spread) })
}

/// Which frames of `gaps` are sealed under `closed` (`false` where there is no value).
pub fn sealed_frames(gaps: &[Option<f64>], closed: &ClosedLips) -> Vec<bool> {
    gaps.iter().map(|g| g.is_some_and(|g| g <= closed.threshold)).collect()
}

/// Sets H to 0 on the sealed frames of `t` (frames without a value stay without one).
pub fn snap_sealed(t: &mut Trajectory, sealed: &[bool]) {
    let h: &mut Series = &mut t.h;
    for (v, &s) in h.iter_mut().zip(sealed) {
        if s && v.is_some() {
            *v = Some(0.0);
        }
    }
}

/// Applies `closure` to a clip's video and head trajectories, the sealed frames judged on
/// the video's H; returns the estimate used (`None` with `Closure::Off`).
///
/// # Errors
/// As [`estimate_closed_lips`]; the trajectories are then left as they were.
pub fn apply_closure(
    closure: Closure,
    video: &mut Trajectory,
    head: &mut Trajectory,
) -> Result<Option<ClosedLips>, ClosureError> {
    if closure == Closure::Off {
        return Ok(None);
    }
    let closed = estimate_closed_lips(&video.h)?;
    let sealed = sealed_frames(&video.h, &closed);
    snap_sealed(video, &sealed);
    snap_sealed(head, &sealed);
    Ok(Some(closed))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Sealed frames at 0.05 ± 0.01, open frames from 0.3 to 0.6.
    fn gaps() -> Vec<Option<f64>> {
        (0..40)
            .map(|f| {
                Some(if f % 4 == 0 {
                    0.3 + 0.3 * (f as f64 / 40.0)
                } else {
                    0.05 + 0.005 * (f % 3) as f64
                })
            })
            .collect()
    }

    #[test]
    fn the_lower_cluster_is_the_sealed_mode() {
        let c = estimate_closed_lips(&gaps()).unwrap();
        assert!((c.mode - 0.055).abs() < 1e-9, "{c:?}");
        assert!(c.split > 0.06 && c.split < 0.3, "{c:?}");
        assert!(c.threshold >= 0.06 && c.threshold < 0.3, "{c:?}");
        let sealed = sealed_frames(&gaps(), &c);
        assert_eq!(sealed.iter().filter(|&&s| s).count(), 30);
        assert!(!sealed[0] && sealed[1]);
    }

    #[test]
    fn snapping_zeroes_sealed_frames_of_both_trajectories() {
        let g = gaps();
        let mut video = Trajectory { w: vec![None; 40], h: g.clone(), p: Vec::new() };
        let mut head = Trajectory { w: vec![None; 40], h: vec![Some(0.2); 40], p: Vec::new() };
        head.h[5] = None;
        let c = apply_closure(Closure::Snap, &mut video, &mut head).unwrap().unwrap();
        assert!(c.threshold > 0.06);
        assert_eq!(video.h[1], Some(0.0));
        assert_eq!(head.h[1], Some(0.0));
        assert_eq!(head.h[0], Some(0.2));
        assert_eq!(head.h[5], None);
        let mut v2 = Trajectory { w: vec![None; 40], h: g.clone(), p: Vec::new() };
        assert_eq!(apply_closure(Closure::Off, &mut v2, &mut head), Ok(None));
        assert_eq!(v2.h, g);
    }

    #[test]
    fn degenerate_input_is_an_error() {
        assert_eq!(estimate_closed_lips(&[Some(0.1); 3]), Err(ClosureError::TooFewFrames(3)));
        assert_eq!(estimate_closed_lips(&[Some(0.1); 20]), Err(ClosureError::NoSpread));
    }
}
