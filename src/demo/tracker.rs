//! The demo's simulated tracker: the true landmark projections with pixel noise and a few
//! gross errors (swapped or jumped mouth points), recorded so tests know which frames are bad.

use crate::landmarks::{FrameLandmarks, LandmarkPoint, Track};
use crate::math::Point2;
use rand::Rng;
use rand::rngs::StdRng;
use rand_distr::{Distribution, Normal};
use serde::Serialize;

/// One injected tracker error.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct InjectedError {
    pub frame: usize,
    /// `swap` (two points exchanged) or `jump` (one point displaced).
    pub kind: String,
    pub point: usize,
    /// The other point of a swap.
    pub other: Option<usize>,
    /// Displacement of a jump, pixels.
    pub dx: f64,
    pub dy: f64,
}

/// Adds tracker noise and gross errors to the true landmarks of a clip; returns the tracked
/// track and the errors injected.
pub(super) fn simulate_tracker(
    truth: &[Vec<Point2>],
    fps: f64,
    noise_px: f64,
    error_rate: f64,
    rng: &mut StdRng,
) -> (Track, Vec<InjectedError>) {
    let n = truth.len();
    let normal = Normal::new(0.0, noise_px.max(0.0))
        .unwrap_or_else(|_| Normal::new(0.0, 0.0).expect("σ = 0"));
    let mut frames: Vec<Vec<Point2>> = truth
        .iter()
        .map(|pts| {
            pts.iter()
                .map(|p| Point2::new(p.x + normal.sample(rng), p.y + normal.sample(rng)))
                .collect()
        })
        .collect();
    let mut errors = Vec::new();
    if n >= 5 && error_rate > 0.0 {
        let count = ((error_rate * n as f64).round() as usize).max(1);
        let mut candidates: Vec<usize> = (2..n - 2).collect();
        for _ in 0..count.min(candidates.len()) {
            let frame = candidates.swap_remove(rng.random_range(0..candidates.len()));
            let pts = &mut frames[frame];
            const PAIRS: [(usize, usize); 8] =
                [(61, 67), (62, 66), (63, 65), (51, 57), (50, 58), (52, 56), (48, 54), (60, 64)];
            let (a, b) = PAIRS[rng.random_range(0..PAIRS.len())];
            // A swap of two points that nearly coincide (a closed mouth) is no error at all:
            // jump a point instead.
            let err = if rng.random_bool(0.5) && (pts[a] - pts[b]).norm() > 4.0 {
                pts.swap(a, b);
                InjectedError {
                    frame,
                    kind: "swap".into(),
                    point: a,
                    other: Some(b),
                    dx: 0.0,
                    dy: 0.0,
                }
            } else {
                let point = rng.random_range(48..68);
                let dist = rng.random_range(10.0..25.0);
                let angle = rng.random_range(0.0..std::f64::consts::TAU);
                let (dx, dy) = (dist * angle.cos(), dist * angle.sin());
                pts[point] += crate::math::Vector2::new(dx, dy);
                InjectedError { frame, kind: "jump".into(), point, other: None, dx, dy }
            };
            errors.push(err);
        }
        errors.sort_by_key(|e| e.frame);
    }
    (points_to_track(&frames, fps), errors)
}

/// Frames of points as a track, rounded to 1/1000 px as the CSV keeps them.
pub(super) fn points_to_track(frames: &[Vec<Point2>], fps: f64) -> Track {
    let round = |v: f64| (v * 1000.0).round() / 1000.0;
    Track::new(
        frames
            .iter()
            .enumerate()
            .map(|(f, pts)| {
                let points =
                    pts.iter().map(|p| LandmarkPoint::tracked(round(p.x), round(p.y))).collect();
                let mut fl = FrameLandmarks::new(f, points);
                fl.timestamp = Some(f as f64 / fps);
                fl
            })
            .collect(),
    )
}
