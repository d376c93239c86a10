//! Profile curves sampled per row: despiking, smoothing, interior peaks with their
//! prominence, and sub-pixel refinement of a maximum by a least-squares parabola.

use crate::math::Real;

/// 3-sample running median (ends kept): a single-row spike (a speck stuck to the edge) is
/// replaced, while monotone runs pass unchanged.
pub(super) fn median_of_three(y: &[Real]) -> Vec<Real> {
    (0..y.len())
        .map(|i| {
            if i == 0 || i + 1 == y.len() {
                return y[i];
            }
            let (a, b, c) = (y[i - 1], y[i], y[i + 1]);
            a.max(b).min(a.min(b).max(c))
        })
        .collect()
}

/// A local maximum of a sampled curve and its topographic prominence (the height above the
/// higher of the two lowest points reached before the curve climbs above the peak or ends).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Peak {
    pub index: usize,
    pub prominence: Real,
}

/// Interior local maxima of `y` (plateaus reported at their middle) with their prominence,
/// in index order. The ends are never peaks: a curve still rising at the crop edge belongs to
/// something outside it (the nose underside).
pub fn find_peaks(y: &[Real]) -> Vec<Peak> {
    let n = y.len();
    let mut peaks = Vec::new();
    let mut i = 1;
    while i + 1 < n {
        if y[i] > y[i - 1] {
            let mut j = i;
            while j + 1 < n && y[j + 1] == y[i] {
                j += 1;
            }
            if j + 1 < n && y[j + 1] < y[i] {
                let mid = (i + j) / 2;
                let left = y[..i]
                    .iter()
                    .rev()
                    .take_while(|&&v| v <= y[i])
                    .fold(Real::INFINITY, |m, &v| m.min(v));
                let right = y[j + 1..]
                    .iter()
                    .take_while(|&&v| v <= y[i])
                    .fold(Real::INFINITY, |m, &v| m.min(v));
                peaks.push(Peak { index: mid, prominence: y[i] - left.max(right) });
            }
            i = j + 1;
        } else {
            i += 1;
        }
    }
    peaks
}

/// Binomial [1 4 6 4 1]/16 smoothing (≈ Gaussian σ = 1 sample), ends replicated: removes
/// pixel-level ripple before peaks are judged, without moving a lip-sized bump.
pub(super) fn smooth(y: &[Real]) -> Vec<Real> {
    let n = y.len();
    let at = |i: isize| y[i.clamp(0, n as isize - 1) as usize];
    (0..n as isize)
        .map(|i| (at(i - 2) + 4.0 * at(i - 1) + 6.0 * at(i) + 4.0 * at(i + 1) + at(i + 2)) / 16.0)
        .collect()
}

/// The parabola window around a maximum: rows either side, and depth (px) below it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct ApexWindow {
    pub(super) rows: usize,
    pub(super) drop_px: Real,
}

/// For anti-aliased edges (sub-pixel per row): a few rows, so a sharp corner is not cut.
pub(super) const APEX_SOFT: ApexWindow = ApexWindow { rows: 6, drop_px: 1.5 };
/// For hard-edged renders, where each row's edge is quantised to ±½ px: about twenty rows,
/// which average the quantisation out while a lip is still near a parabola over them; a
/// wider window bends with the lip's shape away from its apex and biases the vertex
/// (`docs/protrusion.md` records the windows compared against rendered ground truth).
pub(super) const APEX_HARD: ApexWindow = ApexWindow { rows: 10, drop_px: 3.0 };

/// Rows either side of a smoothed peak where the raw maximum is looked for: smoothing moves
/// a peak by a row or two, never more for a lip-sized bump.
const APEX_SEARCH_ROWS: usize = 3;

/// A parabola flatter than this (px per row²) has no vertex worth trusting.
const MIN_CURVATURE: Real = 1e-9;

/// Refines a maximum of `y` near `index`: the vertex of a least-squares parabola through the
/// contiguous samples within `window.rows` of the raw maximum and within `window.drop_px`
/// of its value. Falls back to the raw maximum when the fit is flat or its vertex leaves
/// the window.
pub(super) fn refine_maximum(y: &[Real], index: usize, window: ApexWindow) -> (Real, Real) {
    let n = y.len();
    let lo = index.saturating_sub(APEX_SEARCH_ROWS);
    let hi = (index + APEX_SEARCH_ROWS).min(n - 1);
    let m = (lo..=hi).max_by(|&a, &b| y[a].total_cmp(&y[b])).unwrap_or(index);
    let (apex_rows, apex_drop) = (window.rows, window.drop_px);
    let keep = |i: usize| y[i] >= y[m] - apex_drop;
    let first =
        (m.saturating_sub(apex_rows)..=m).rev().take_while(|&i| keep(i)).last().unwrap_or(m);
    let last = (m..=(m + apex_rows).min(n - 1)).take_while(|&i| keep(i)).last().unwrap_or(m);
    let window: Vec<usize> = (first..=last).collect();
    if window.len() >= 3 {
        // Fit y = c0 + c1 t + c2 t² with t = i − m.
        let mut ata = nalgebra::Matrix3::<Real>::zeros();
        let mut atb = nalgebra::Vector3::<Real>::zeros();
        for &i in &window {
            let t = i as Real - m as Real;
            let row = nalgebra::Vector3::new(1.0, t, t * t);
            ata += row * row.transpose();
            atb += row * y[i];
        }
        if let Some(c) = ata.lu().solve(&atb) {
            let (t0, t1) =
                (window[0] as Real - m as Real, *window.last().unwrap() as Real - m as Real);
            if c[2] < -MIN_CURVATURE {
                let t = -c[1] / (2.0 * c[2]);
                if t >= t0 && t <= t1 {
                    return (m as Real + t, c[0] + c[1] * t + c[2] * t * t);
                }
            }
        }
    }
    (m as Real, y[m])
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn peaks_and_their_prominence() {
        let y = [0.0, 2.0, 1.0, 5.0, 5.0, 5.0, 3.0, 4.0, 0.0];
        let peaks = find_peaks(&y);
        assert_eq!(
            peaks,
            vec![
                Peak { index: 1, prominence: 1.0 },
                Peak { index: 4, prominence: 5.0 },
                Peak { index: 7, prominence: 1.0 },
            ]
        );
        // Still rising at the end: no peak there.
        assert!(find_peaks(&[0.0, 1.0, 2.0]).is_empty());
    }

    #[test]
    fn the_parabola_vertex_is_recovered_to_sub_sample() {
        let (t0, v0) = (20.37, 7.5);
        let y: Vec<Real> = (0..40).map(|i| v0 - 0.05 * (i as Real - t0).powi(2)).collect();
        for window in [APEX_SOFT, APEX_HARD] {
            let (t, v) = refine_maximum(&y, 19, window);
            assert!((t - t0).abs() < 1e-9 && (v - v0).abs() < 1e-9, "{t} {v}");
        }
        // A flat run has no vertex: a raw sample near the index comes back.
        let (t, v) = refine_maximum(&[1.0; 9], 4, APEX_SOFT);
        assert!(v == 1.0 && t.fract() == 0.0 && (1.0..=7.0).contains(&t), "{t} {v}");
    }

    #[test]
    fn despiking_and_smoothing_keep_slopes() {
        let ramp: Vec<Real> = (0..10).map(|i| i as Real * 0.5).collect();
        assert_eq!(median_of_three(&ramp), ramp);
        let mut spiked = ramp.clone();
        spiked[5] = 9.0;
        assert_eq!(median_of_three(&spiked)[5], 3.0);
        // The binomial kernel is symmetric: a straight line is unchanged away from the ends.
        let s = smooth(&ramp);
        assert!((2..8).all(|i| (s[i] - ramp[i]).abs() < 1e-12));
    }
}
