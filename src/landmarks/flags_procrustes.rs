//! Head-motion removal for the flags: the 2D least-squares similarity (scale, rotation,
//! translation) between two landmark sets, and the shape check that uses it — a frame whose
//! landmarks, once aligned to the mean of its aligned neighbours, still sit far from them.
//!
//! The similarity is the 2D case of Umeyama's closed form (Umeyama 1991, "Least-squares
//! estimation of transformation parameters between two point patterns", eq. 40–42): with the
//! points as complex numbers `a_i`, `b_i` centred on their means, `s·R = Σ conj(a_i)·b_i /
//! Σ|a_i|²`. Start at [`shape_flags`].

use super::flags::{FlagReason, FlagThresholds, face_sizes, median_sigma};
use super::track::Track;
use crate::math::{Point2, Vector2};

/// Points that move with the head but not with speech: the nose (27–35) and the eyes (36–47).
/// Aligning on them removes head motion without removing articulation.
pub const STABLE_POINTS: std::ops::Range<usize> = 27..48;

/// `y ≈ s·R·x + t` in 2D, stored as the complex factor `s·R = (c, d)` and `t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Similarity2 {
    c: f64,
    d: f64,
    t: Vector2,
}

impl Similarity2 {
    pub fn apply(&self, p: &Point2) -> Point2 {
        Point2::new(self.c * p.x - self.d * p.y + self.t.x, self.d * p.x + self.c * p.y + self.t.y)
    }
}

/// The similarity that maps `from[i]` onto `to[i]` best in the least-squares sense; `None`
/// with fewer than two pairs, unequal lengths or coincident `from` points.
pub fn estimate_similarity_2d(from: &[Point2], to: &[Point2]) -> Option<Similarity2> {
    let n = from.len();
    if n < 2 || to.len() != n {
        return None;
    }
    let mean = |v: &[Point2]| v.iter().fold(Vector2::zeros(), |a, p| a + p.coords) / n as f64;
    let (ma, mb) = (mean(from), mean(to));
    let (mut c, mut d, mut var) = (0.0, 0.0, 0.0);
    for (a, b) in from.iter().zip(to) {
        let (a, b) = (a.coords - ma, b.coords - mb);
        // conj(a)·b = (a.x·b.x + a.y·b.y) + i(a.x·b.y − a.y·b.x)
        c += a.x * b.x + a.y * b.y;
        d += a.x * b.y - a.y * b.x;
        var += a.norm_squared();
    }
    if var.is_nan() || var <= 1e-12 {
        return None;
    }
    let (c, d) = (c / var, d / var);
    let t = mb - Vector2::new(c * ma.x - d * ma.y, d * ma.x + c * ma.y);
    Some(Similarity2 { c, d, t })
}

/// The visible points of `STABLE_POINTS` common to both frames, as (from, to) lists.
fn stable_pairs(track: &Track, from: usize, to: usize) -> (Vec<Point2>, Vec<Point2>) {
    let (a, b) = (&track.frames[from].points, &track.frames[to].points);
    STABLE_POINTS
        .filter_map(|i| {
            let (p, q) = (a.get(i)?, b.get(i)?);
            (p.visible && q.visible).then(|| (p.pos(), q.pos()))
        })
        .unzip()
}

/// The head motion from frame index `from` to `to` (indices into `track.frames`), estimated
/// on the stable points; `None` when fewer than three of them are visible in both.
pub fn head_motion(track: &Track, from: usize, to: usize) -> Option<Similarity2> {
    let (a, b) = stable_pairs(track, from, to);
    if a.len() < 3 {
        return None;
    }
    estimate_similarity_2d(&a, &b)
}

/// Frames whose lip shape breaks from their neighbours' once head motion is removed: each
/// neighbour (previous and next frame) is mapped into the frame by its head motion, the frame's
/// lip points (48–67) are Procrustes-aligned to the neighbours' mean, and the RMS distance,
/// as a fraction of the face size, is compared with the clip's robust spread of the same
/// number (median + `shape_sigmas`·σ, at least `shape_min_face_fraction`), and must be the
/// largest among its immediate neighbours'. A smooth opening or closing keeps the frame near
/// the mean of its neighbours; a mis-tracked frame does not.
pub fn shape_flags(track: &Track, th: &FlagThresholds) -> Vec<(usize, FlagReason)> {
    let sizes = face_sizes(track);
    let n = track.frames.len();
    let mut breaks: Vec<(usize, f64)> = Vec::new();
    for (k, &size) in sizes.iter().enumerate().take(n.saturating_sub(1)).skip(1) {
        let frame = track.frames[k].frame;
        if track.frames[k - 1].frame + 1 != frame || track.frames[k + 1].frame != frame + 1 {
            continue;
        }
        let Some(size) = size else { continue };
        let (Some(prev), Some(next)) = (head_motion(track, k - 1, k), head_motion(track, k + 1, k))
        else {
            continue;
        };
        let mut own = Vec::new();
        let mut around = Vec::new();
        for i in LIP_POINTS {
            let p = |j: usize| track.frames[j].points.get(i).filter(|p| p.visible).map(|p| p.pos());
            if let (Some(a), Some(b), Some(c)) = (p(k - 1), p(k), p(k + 1)) {
                own.push(b);
                around.push(nalgebra::center(&prev.apply(&a), &next.apply(&c)));
            }
        }
        let Some(fit) = estimate_similarity_2d(&own, &around) else { continue };
        let ss: f64 = own.iter().zip(&around).map(|(a, b)| (fit.apply(a) - b).norm_squared()).sum();
        breaks.push((frame, (ss / own.len() as f64).sqrt() / size));
    }
    let values: Vec<f64> = breaks.iter().map(|b| b.1).collect();
    let Some((med, sigma)) = median_sigma(&values) else { return Vec::new() };
    let limit = (med + th.shape_sigmas * sigma).max(th.shape_min_face_fraction);
    // A one-frame error also pulls its neighbours' references (the mean of the frames
    // around them) half-way off; only the frame that breaks most locally is the error.
    let break_of =
        |frame: usize| breaks.binary_search_by_key(&frame, |b| b.0).ok().map(|i| breaks[i].1);
    let local_peak = |&(frame, value): &(usize, f64)| {
        [frame.checked_sub(1), Some(frame + 1)]
            .into_iter()
            .flatten()
            .all(|f| break_of(f).is_none_or(|other| value >= other))
    };
    breaks
        .iter()
        .filter(|b| b.1 > limit && local_peak(b))
        .map(|&(frame, face_fraction)| (frame, FlagReason::ShapeBreak { face_fraction }))
        .collect()
}

/// The lip points, outer (48–59) and inner (60–67).
pub const LIP_POINTS: std::ops::Range<usize> = 48..68;

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn similarity_recovers_a_known_transform() {
        let from = [Point2::new(0.0, 0.0), Point2::new(2.0, 0.0), Point2::new(0.0, 1.0)];
        // s = 2, 90° rotation, t = (5, −1)
        let map = |p: &Point2| Point2::new(-2.0 * p.y + 5.0, 2.0 * p.x - 1.0);
        let to: Vec<Point2> = from.iter().map(map).collect();
        let s = estimate_similarity_2d(&from, &to).unwrap();
        let q = Point2::new(3.0, -4.0);
        assert!((s.apply(&q) - map(&q)).norm() < 1e-12);
        assert!(estimate_similarity_2d(&[from[0], from[0]], &to[..2]).is_none());
        assert!(estimate_similarity_2d(&from[..1], &to[..1]).is_none());
    }
}
