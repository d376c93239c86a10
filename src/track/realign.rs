//! Re-aligning a frame from the points a user corrected: the cascade is run again from the
//! frame's current shape, in the box of that shape, with the corrected points *held* (reset
//! to the user's positions after every stage). Each stage's trees then read their feature
//! pixels around a face whose held points are right, and move the other points to agree
//! with them and with the image: fixing two points of a lower lip that rides on the tongue
//! brings the rest of that lip down with them.
//!
//! [`propagate_realignment`] carries a correction forward: each next frame is re-run from
//! the re-aligned frame before it, until the result agrees with what the tracker had there.

use super::cascade::{CascadeStart, GrayImage, GrayView, run_cascade};
use super::predictor_file::ShapePredictor;
use super::similarity::box_from_shape;
use super::tracker::shape_disagreement;
use nalgebra::Vector2;

/// The shape of a frame re-aligned to the `held` points (pixel positions, by point index):
/// `current` with the held points moved, run through the cascade from its own box. The held
/// points come back exactly as given. `None` when `current` is not a shape of the
/// predictor's size or has no extent.
pub fn realign_shape(
    predictor: &ShapePredictor,
    image: GrayView<'_>,
    current: &[Vector2<f64>],
    held: &[(usize, Vector2<f64>)],
) -> Option<Vec<Vector2<f64>>> {
    if current.len() != predictor.num_parts() {
        return None;
    }
    let mut start = current.to_vec();
    let n = start.len();
    let held: Vec<(usize, Vector2<f64>)> = held.iter().copied().filter(|(i, _)| *i < n).collect();
    let held = held.as_slice();
    carry_corrections(&mut start, held, DRAG_RADIUS_EYE_DISTANCES);
    let face = box_from_shape(&predictor.mean_shape, &start)?;
    let mut out = run_cascade(predictor, image, &face, &CascadeStart { shape: Some(&start), held });
    // The box round trip (pixels → normalised f32 → pixels) moves a held point by ~1e-5 px;
    // give the user's values back exactly.
    for &(i, p) in held.iter().filter(|(i, _)| *i < n) {
        out[i] = p;
    }
    Some(out)
}

/// Radius of the neighbourhood a corrected point drags along before the cascade runs, in
/// outer eye-corner distances: a quarter reaches a lip's own points from its midline (half a
/// mouth width is ≈ 0.3) and leaves the eyes and the jaw's sides alone.
pub const DRAG_RADIUS_EYE_DISTANCES: f64 = 0.25;

/// Moves every point not held by the held points' displacements, each weighted by a
/// Gaussian of its distance to the held point (σ = `radius` eye-corner distances; the sum
/// of weights capped at 1): a lip point next to the corrected ones moves almost as they did,
/// a point far away stays. This is the cascade's start; its stages then fit the points to
/// the image. A departure from dlib, whose cascade always starts from the mean shape: the
/// trees were trained from starts near the truth, and a start that keeps the tracker's
/// error in the uncorrected points (a whole lip on the tongue) is far from it.
pub fn carry_corrections(shape: &mut [Vector2<f64>], held: &[(usize, Vector2<f64>)], radius: f64) {
    let scale = if shape.len() == 68 { (shape[36] - shape[45]).norm() } else { 0.0 };
    if held.is_empty() || scale <= 0.0 || !scale.is_finite() {
        for &(i, p) in held {
            shape[i] = p;
        }
        return;
    }
    let sigma2 = (radius * scale).powi(2);
    let moves: Vec<(Vector2<f64>, Vector2<f64>)> =
        held.iter().map(|&(i, p)| (shape[i], p - shape[i])).collect();
    for (i, q) in shape.iter_mut().enumerate() {
        if let Some(&(_, p)) = held.iter().find(|(h, _)| *h == i) {
            *q = p;
            continue;
        }
        let (mut w_sum, mut m) = (0.0, Vector2::zeros());
        for (from, d) in &moves {
            let w = (-(*q - from).norm_squared() / (2.0 * sigma2)).exp();
            w_sum += w;
            m += w * d;
        }
        *q += m / w_sum.max(1.0);
    }
}

/// When a propagated frame is close enough to the tracker's to stop.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PropagateOptions {
    /// Stop once the re-aligned frame is within this mean distance of the tracker's
    /// landmarks, in eye-corner distances (36–45)...
    pub agree_disagreement: f64,
    /// ...or after this many frames.
    pub max_frames: usize,
}

impl Default for PropagateOptions {
    fn default() -> Self {
        Self { agree_disagreement: 0.02, max_frames: 100 }
    }
}

/// Re-aligns the frames after a corrected one: frame k+1 runs the cascade from frame k's
/// re-aligned shape (in its box, nothing held). `frames` yields each following frame's image
/// and the tracker's shape there, in order (lazily: only the frames walked are decoded); the
/// walk stops at the first frame whose result agrees with the tracker's (that frame is not
/// returned: the tracker already had it) or after `max_frames`. Returns the re-aligned
/// shapes, one per frame changed.
pub fn propagate_realignment<I>(
    predictor: &ShapePredictor,
    corrected: &[Vector2<f64>],
    frames: I,
    opts: &PropagateOptions,
) -> Vec<Vec<Vector2<f64>>>
where
    I: IntoIterator<Item = (GrayImage, Vec<Vector2<f64>>)>,
{
    let mut previous = corrected.to_vec();
    let mut out = Vec::new();
    for (image, tracked) in frames.into_iter().take(opts.max_frames) {
        let Some(face) = box_from_shape(&predictor.mean_shape, &previous) else { break };
        let shape = run_cascade(
            predictor,
            image.view(),
            &face,
            &CascadeStart { shape: Some(&previous), held: &[] },
        );
        if shape_disagreement(&tracked, &shape) <= opts.agree_disagreement {
            break;
        }
        previous = shape.clone();
        out.push(shape);
    }
    out
}
