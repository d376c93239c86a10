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
//! [`propagate_realignment`] carries a correction forward: each corrected point is followed
//! into the next frame by its image patch (`lucas_kanade`) and that frame is re-aligned to the
//! followed points, until they agree with the tracker's again or a patch is lost.

use super::cascade::{CascadeStart, GrayImage, GrayView, run_cascade};
use super::lucas_kanade::{FlowOptions, Pyramid, follow_point, follow_point_checked};
use super::predictor_file::ShapePredictor;
use super::shape_prior::{HeldCarry, ShapePrior};
use super::similarity::box_from_shape;
use super::tracker::shape_scale;
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

/// When a propagation stops, and how its points are followed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PropagateOptions {
    /// Stop once the followed points are within this mean distance of the tracker's, in
    /// eye-corner distances (36–45)...
    pub agree_disagreement: f64,
    /// ...or after this many frames.
    pub max_frames: usize,
    /// Half the side of the patch a point is followed by, in eye-corner distances (at least
    /// 3 pixels).
    pub window_eyes: f64,
    /// The patch is lost when the point, followed into the next frame and back, lands farther
    /// than this from where it started (eye-corner distances; Kalal et al.'s forward–backward
    /// error).
    pub max_round_trip_eyes: f64,
    /// Halvings of each frame for the pyramid (Bouguet's L_m).
    pub pyramid_levels: usize,
}

impl Default for PropagateOptions {
    /// Agreement at the self-check's 0.02 eye distances (the flags' threshold); a patch of
    /// 0.3 eye distances a side (11×11 pixels on carphone's 31-pixel eye distance, 51×51 on
    /// the demo's 165), lost beyond a round trip of 0.03 eye distances (≈ 1 px on carphone);
    /// two halvings (the face's motion by the tracker is the first guess, so the pyramid only
    /// has to find the rest). Chosen on carphone and two demo seeds (`docs/tracking.md`).
    fn default() -> Self {
        Self {
            agree_disagreement: 0.02,
            max_frames: 100,
            window_eyes: 0.15,
            max_round_trip_eyes: 0.03,
            pyramid_levels: 2,
        }
    }
}

/// A frame after the corrected one, as [`propagate_realignment`] walks it.
#[derive(Clone, Debug)]
pub struct NextFrame {
    /// Its number in the clip (only reported back).
    pub frame: usize,
    pub image: GrayImage,
    /// The tracker's own points there (`None`: the tracker lost the face).
    pub tracked: Option<Vec<Vector2<f64>>>,
}

/// Why a propagation stopped.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PropagationEnd {
    /// On this frame the followed points agree with the tracker's again (left as it was).
    Agreed { frame: usize },
    /// This held point could not be followed into this frame (left as it was): its patch left
    /// the image, has no texture, or does not come back to itself.
    Lost { frame: usize, point: usize },
    /// This held point, followed, parts from the tracker's by more than the user's own
    /// correction (and the patch tolerance) on the corrected frame (left as it was): the patch
    /// slid, or the tracker's error there is another one; the user looks there.
    Parted { frame: usize, point: usize },
    /// The tracker has no face on this frame (left as it was).
    NoFace { frame: usize },
    /// `max_frames` frames were re-aligned.
    MaxFrames,
    /// The clip ended.
    ClipEnd,
}

/// The frames a propagation re-aligned, in order, and why it stopped.
#[derive(Clone, Debug, PartialEq)]
pub struct Propagation {
    pub shapes: Vec<Vec<Vector2<f64>>>,
    pub end: PropagationEnd,
}

/// The corrected frame a propagation starts from.
#[derive(Clone, Copy, Debug)]
pub struct CorrectedFrame<'a> {
    pub image: GrayView<'a>,
    /// The tracker's own points there.
    pub tracked: &'a [Vector2<f64>],
    /// The user's points (index, pixels).
    pub held: &'a [(usize, Vector2<f64>)],
}

/// Carries a correction through the frames after the corrected one. Each held point is
/// followed into the next frame by its image patch (pyramidal Lucas–Kanade from where it was
/// on the frame before, the face's motion by the tracker as the first guess,
/// [`follow_point_checked`]); the frame is then re-aligned from the tracker's points with the
/// followed points held and the others carried by `prior` ([`realign_shape`]). The walk
/// stops at the first frame where the followed points are within `agree_disagreement` of the
/// tracker's (the tracker is right again: the frame is left as it was), where a held point's
/// patch is lost or parts from the tracker's by more than the user's correction did, where
/// the tracker has no face, or after `max_frames`. `frames` is walked lazily.
///
/// Why the image and not the shape before: a cascade started from the previous frame's
/// result, with nothing held, barely moves from it and nothing pulls it back to the face, so
/// the chain drifts (13 px after 60 frames on carphone); a followed patch is where the user's
/// point is in each frame, and the tracker's own points keep the rest of the face where the
/// tracker saw it. `docs/tracking.md` has the figures.
pub fn propagate_realignment<I>(
    predictor: &ShapePredictor,
    prior: &ShapePrior,
    start: &CorrectedFrame<'_>,
    frames: I,
    opts: &PropagateOptions,
) -> Propagation
where
    I: IntoIterator<Item = NextFrame>,
{
    let corrected = Pyramid::new(start.image, opts.pyramid_levels);
    let mut previous = corrected.clone();
    let mut previous_tracked = start.tracked.to_vec();
    let n = start.tracked.len();
    let anchors: Vec<(usize, Vector2<f64>)> =
        start.held.iter().copied().filter(|(i, _)| *i < n).collect();
    let mut held = anchors.clone();
    let mut shapes = Vec::new();
    for next in frames {
        if shapes.len() == opts.max_frames {
            return Propagation { shapes, end: PropagationEnd::MaxFrames };
        }
        let frame = next.frame;
        let Some(tracked) = next.tracked.filter(|t| t.len() == previous_tracked.len()) else {
            return Propagation { shapes, end: PropagationEnd::NoFace { frame } };
        };
        let eye = shape_scale(&tracked);
        let flow = FlowOptions {
            half_window: ((opts.window_eyes * eye).round() as usize).max(3),
            ..FlowOptions::default()
        };
        let pyramid = Pyramid::new(next.image.view(), opts.pyramid_levels);
        let guess = median_motion(&previous_tracked, &tracked);
        let mut followed = Vec::with_capacity(held.len());
        let tolerance = opts.max_round_trip_eyes * eye;
        for (&(i, p), &(_, user)) in held.iter().zip(&anchors) {
            let chained = match follow_point_checked(&previous, &pyramid, p, guess, &flow) {
                Some(f) if f.round_trip <= tolerance => f.position,
                _ => return Propagation { shapes, end: PropagationEnd::Lost { frame, point: i } },
            };
            // Frame-to-frame following drifts (each step's error stays). Matthews, Ishikawa
            // & Baker's correction ("The Template Update Problem", PAMI 2004, strategy 3):
            // align the corrected frame's own patch, from where the chain put the point, and
            // take that when it lands near; the patch as the user saw it does not drift, and
            // where it no longer looks the same (the mouth opened) the chain is kept.
            let anchored = follow_point(&corrected, &pyramid, user, chained - user, &flow)
                .filter(|q| (q - chained).norm() <= tolerance);
            let position = anchored.unwrap_or(chained);
            // A correction is the user's word on the tracker's error of that size: a followed
            // point parting from the tracker's by more (the patch slid as the mouth opened, or
            // the tracker went wrong another way) is no longer it, so the walk stops there.
            let user_correction = (user - start.tracked[i]).norm();
            if (position - tracked[i]).norm() > user_correction + tolerance {
                return Propagation { shapes, end: PropagationEnd::Parted { frame, point: i } };
            }
            followed.push((i, position));
        }
        let apart = followed.iter().map(|&(i, p)| (p - tracked[i]).norm()).sum::<f64>()
            / followed.len().max(1) as f64;
        if apart <= opts.agree_disagreement * eye {
            return Propagation { shapes, end: PropagationEnd::Agreed { frame } };
        }
        let Some(shape) = realign_shape(predictor, prior, next.image.view(), &tracked, &followed)
        else {
            return Propagation { shapes, end: PropagationEnd::NoFace { frame } };
        };
        shapes.push(shape);
        previous = pyramid;
        previous_tracked = tracked;
        held = followed;
    }
    Propagation { shapes, end: PropagationEnd::ClipEnd }
}

/// The face's motion from `a` to `b`: the median of its points' moves, per coordinate. Not
/// the held point's own move: where the tracker is wrong about that point (the error being
/// corrected), its move is wrong too, most of all where the error starts or ends.
fn median_motion(a: &[Vector2<f64>], b: &[Vector2<f64>]) -> Vector2<f64> {
    let median = |mut v: Vec<f64>| {
        v.sort_by(f64::total_cmp);
        if v.is_empty() { 0.0 } else { v[v.len() / 2] }
    };
    let moves: Vec<Vector2<f64>> = a.iter().zip(b).map(|(p, q)| q - p).collect();
    Vector2::new(
        median(moves.iter().map(|m| m.x).collect()),
        median(moves.iter().map(|m| m.y).collect()),
    )
}
