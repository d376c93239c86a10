//! Re-aligning a frame from the points a user corrected: the cascade is run again from the
//! tracker's shape of the frame, in the box of that shape, with the corrected points *held*,
//! and the other points carried with them by the predictor's own shape prior
//! (`shape_prior`).
//!
//! Holding alone cannot move the others: the trees read the same pixels that made the
//! tracker's mistake and put the uncorrected points back where the tracker had them. The
//! only new information is at the held points, so it is spread to the rest by how the
//! predictor's training residuals go together: before the first stage, the user's
//! correction (held − current) moves every point by its conditional mean; after each stage,
//! what that stage's trees moved the held points away from the user's positions is taken
//! back at every point the same way, so the next stage reads its pixels around a face that
//! agrees with the user's fix. `docs/tracking.md` gives the reasons and the figures.
//!
//! [`propagate_realignment`] carries a correction forward: each next frame is re-run from
//! the re-aligned frame before it, until the result agrees with what the tracker had there.

use super::cascade::{CascadeStart, GrayImage, GrayView, run_cascade};
use super::predictor_file::ShapePredictor;
use super::shape_prior::{HeldCarry, ShapePrior};
use super::similarity::box_from_shape;
use super::tracker::shape_disagreement;
use nalgebra::Vector2;

/// The shape of a frame re-aligned to the `held` points (pixel positions, by point index):
/// the cascade run from `current` (the tracker's shape of the frame: the held points'
/// corrections are their moves away from it), in the box of `current` with the held points
/// moved, the held points put where given and the others carried with them by `prior`
/// ([`HeldCarry`]). The held points come back exactly as given; indices past the shape are
/// ignored. `None` when `current` is not a shape of the predictor's size or has no extent.
pub fn realign_shape(
    predictor: &ShapePredictor,
    prior: &ShapePrior,
    image: GrayView<'_>,
    current: &[Vector2<f64>],
    held: &[(usize, Vector2<f64>)],
) -> Option<Vec<Vector2<f64>>> {
    if current.len() != predictor.num_parts() {
        return None;
    }
    let n = current.len();
    let mut held: Vec<(usize, Vector2<f64>)> =
        held.iter().copied().filter(|(i, _)| *i < n).collect();
    // A point given twice is held where it was given last.
    held.reverse();
    let mut seen = vec![false; n];
    held.retain(|(i, _)| !std::mem::replace(&mut seen[*i], true));
    held.reverse();
    let mut moved = current.to_vec();
    for &(i, p) in &held {
        moved[i] = p;
    }
    let face = box_from_shape(&predictor.mean_shape, &moved)?;
    let indices: Vec<usize> = held.iter().map(|h| h.0).collect();
    let carry = HeldCarry::new(prior, &indices);
    let start = CascadeStart { shape: Some(current), held: &held, carry: carry.as_ref() };
    let mut out = run_cascade(predictor, image, &face, &start);
    // The box round trip (pixels → normalised f32 → pixels) moves a held point by ~1e-5 px;
    // give the user's values back exactly.
    for &(i, p) in &held {
        out[i] = p;
    }
    Some(out)
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
            &CascadeStart { shape: Some(&previous), held: &[], carry: None },
        );
        if shape_disagreement(&tracked, &shape) <= opts.agree_disagreement {
            break;
        }
        previous = shape.clone();
        out.push(shape);
    }
    out
}
