//! Head motion in the side view: the rigid upper-face profile (forehead, nasion, nose ridge)
//! of the frame the reference line was drawn on is the [`Anchor`]; each frame's profile is
//! registered to it by point-to-line ICP, so the line stays fixed to the head. Start at
//! [`capture_anchor`] and [`register_to_anchor`].

use super::silhouette::segment;
use super::{Anchor, ProfileError, ProfileSetup, Rect, Rigid2};
use crate::math::{Point2, Real, Vector2};
use image::GrayImage;

/// Row σ of the Gaussian that smooths registration profiles, and its reach.
const PROFILE_SIGMA_ROWS: Real = 2.5;
const PROFILE_RADIUS_ROWS: usize = 7;

/// The forward edge of `region` in `image`, one point per row (image px), leaving out rows
/// whose face reaches the region's front edge (clipped, not an edge).
///
/// The x values are smoothed along each run of consecutive rows by a Gaussian of
/// [`PROFILE_SIGMA_ROWS`], and each run loses [`PROFILE_RADIUS_ROWS`] rows at both ends
/// (where the kernel would be cut). On hard-edged frames a slanted edge is a staircase whose
/// steps sit on whole pixels; registering staircases locks onto whole-pixel shifts, while
/// their smoothed ramps carry the sub-pixel position.
pub(super) fn region_profile(
    image: &GrayImage,
    setup: &ProfileSetup,
    region: Rect,
) -> Result<Vec<Point2>, ProfileError> {
    let sil = segment(
        image,
        region,
        setup.facing,
        setup.threshold,
        setup.denoise,
        setup.min_component_px,
    )?;
    let raw: Vec<Option<Point2>> = sil
        .forward_edges()
        .into_iter()
        .enumerate()
        .map(|(r, e)| e.filter(|e| !e.1).map(|(u, _)| sil.to_image(u, r as Real)))
        .collect();
    let kernel: Vec<Real> = (0..=PROFILE_RADIUS_ROWS)
        .map(|d| (-0.5 * (d as Real / PROFILE_SIGMA_ROWS).powi(2)).exp())
        .collect();
    let norm = kernel[0] + 2.0 * kernel[1..].iter().sum::<Real>();
    let k = PROFILE_RADIUS_ROWS;
    Ok((k..raw.len().saturating_sub(k))
        .filter_map(|r| {
            let p = raw[r]?;
            let mut x = kernel[0] * p.x;
            for d in 1..=k {
                x += kernel[d] * (raw[r - d]?.x + raw[r + d]?.x);
            }
            Some(Point2::new(x / norm, p.y))
        })
        .collect())
}

/// Records the upper-face profile inside `region` of `image` (the frame the reference line
/// is drawn on) as the anchor that later frames are registered to.
///
/// # Errors
/// Segmentation errors, or [`ProfileError::Registration`] when fewer than
/// [`MIN_REGISTRATION_ROWS`] rows hold an edge.
pub fn capture_anchor(
    image: &GrayImage,
    setup: &ProfileSetup,
    region: Rect,
) -> Result<Anchor, ProfileError> {
    let profile = region_profile(image, setup, region)?;
    if profile.len() < MIN_REGISTRATION_ROWS {
        return Err(ProfileError::Registration("too few profile rows in the anchor region"));
    }
    Ok(Anchor { region, profile })
}

/// Cap on ICP steps; each costs one pass over the rows.
const MAX_ICP_STEPS: usize = 50;

/// Widest two-state oscillation (px at the profile's farthest point) that ICP may end in and
/// still count as registered, at its middle: a tenth of this moves P by under 1/1000 of a
/// typical nose length.
const MAX_OSCILLATION_PX: Real = 0.25;

/// Fewest profile rows a registration uses (three parameters, and noise to average).
pub const MIN_REGISTRATION_ROWS: usize = 12;

/// ICP's first steps pair points up to [`COARSE_GATE_PX`] apart, so a head that moved a few
/// px is caught; later steps only [`FINE_GATE_PX`], so the nose ridge's far rows (which pair
/// with the wrong segment while the motion is still rough) stop pulling.
const COARSE_STEPS: usize = 3;
const COARSE_GATE_PX: Real = 4.0;
const FINE_GATE_PX: Real = 2.0;

/// A step moving the profile's farthest point less than this (px) has converged: a
/// thousandth of the sub-pixel precision the edges carry.
const CONVERGED_STEP_PX: Real = 1e-4;

/// After [`MAX_ICP_STEPS`], a last step under this (px) is taken as converged: pairs
/// switching segments by a hair keep ICP from reaching [`CONVERGED_STEP_PX`] while moving P
/// by far less than its precision.
const SETTLED_STEP_PX: Real = 1e-2;

/// The normal matrix's smallest eigenvalue must reach this share of its largest, or one
/// direction of motion (sliding along a straight profile) is not fixed by the data.
const MIN_EIGENVALUE_RATIO: Real = 1e-6;

/// Segments looked at either side of a point's row: the motion after the coarse steps is
/// a few px at most.
const SEARCH_ROWS: usize = 4;

/// Consecutive profile points more than this many rows apart leave a gap, not a segment.
const MAX_SEGMENT_ROWS: Real = 1.5;

/// The closest point to `p` on the polyline `line` (consecutive points one row apart),
/// searched among segments starting within [`SEARCH_ROWS`] rows of `p`; with the segment's
/// unit normal.
/// Points beyond either end of the polyline have none: they would pull sideways.
fn closest_on_profile(line: &[Point2], p: Point2) -> Option<(Point2, Vector2)> {
    let y0 = line.first()?.y;
    let k = ((p.y - y0).round() as isize).clamp(0, line.len() as isize - 1) as usize;
    let mut best: Option<(Real, Point2, Vector2)> = None;
    for i in k.saturating_sub(SEARCH_ROWS)..(k + SEARCH_ROWS).min(line.len().saturating_sub(1)) {
        let (a, b) = (line[i], line[i + 1]);
        let d = b - a;
        let len2 = d.norm_squared();
        if len2.is_nan() || len2 <= 1e-12 || d.y.abs() > MAX_SEGMENT_ROWS {
            continue; // a gap in the rows, not a segment
        }
        let t = ((p - a).dot(&d) / len2).clamp(0.0, 1.0);
        if (i == 0 && t == 0.0) || (i + 2 == line.len() && t == 1.0) {
            continue;
        }
        let q = a + d * t;
        let dist = (p - q).norm();
        if best.is_none_or(|b| dist < b.0) {
            let n = Vector2::new(d.y, -d.x) / len2.sqrt();
            best = Some((dist, q, n));
        }
    }
    best.map(|(_, q, n)| (q, n))
}

/// The rigid motion taking this frame's upper-face profile onto the anchor's: point-to-line
/// ICP (Chen & Medioni 1992) over the profile rows, each step a linearised least-squares fit
/// of a small rotation (about the points' centroid) and a translation, pairs farther than
/// [`COARSE_GATE_PX`] ([`FINE_GATE_PX`] after [`COARSE_STEPS`] steps) left out.
///
/// # Errors
/// Segmentation errors; [`ProfileError::Registration`] with too few rows or paired points,
/// a profile without enough shape to fix all three parameters, or no convergence.
pub fn register_to_anchor(
    image: &GrayImage,
    setup: &ProfileSetup,
    anchor: &Anchor,
) -> Result<Rigid2, ProfileError> {
    let points = region_profile(image, setup, anchor.region)?;
    if points.len() < MIN_REGISTRATION_ROWS || anchor.profile.len() < MIN_REGISTRATION_ROWS {
        return Err(ProfileError::Registration("too few profile rows"));
    }
    let mut motion = Rigid2::identity();
    let mut previous = motion;
    let mut last_step = Real::INFINITY;
    for iteration in 0..MAX_ICP_STEPS {
        let gate = if iteration < COARSE_STEPS { COARSE_GATE_PX } else { FINE_GATE_PX };
        let moved: Vec<Point2> = points.iter().map(|p| motion * p).collect();
        let pairs: Vec<(Point2, Point2, Vector2)> = moved
            .iter()
            .filter_map(|&p| {
                let (q, n) = closest_on_profile(&anchor.profile, p)?;
                ((p - q).norm() <= gate).then_some((p, q, n))
            })
            .collect();
        if pairs.len() < MIN_REGISTRATION_ROWS {
            return Err(ProfileError::Registration("too few paired profile points"));
        }
        let c = pairs.iter().fold(Vector2::zeros(), |acc, (p, _, _)| acc + p.coords)
            / pairs.len() as Real;
        let mut ata = nalgebra::Matrix3::<Real>::zeros();
        let mut atb = nalgebra::Vector3::<Real>::zeros();
        for (p, q, n) in &pairs {
            let r = p.coords - c;
            let row = nalgebra::Vector3::new(n.dot(&Vector2::new(-r.y, r.x)), n.x, n.y);
            ata += row * row.transpose();
            atb -= row * n.dot(&(p - q));
        }
        // A straight profile leaves sliding along it free: refuse rather than guess.
        let eig = ata.symmetric_eigenvalues();
        let floor = MIN_EIGENVALUE_RATIO * eig.max().max(1e-12);
        if eig.min().is_nan() || eig.min() <= floor {
            return Err(ProfileError::Registration("the profile is too straight"));
        }
        let delta = ata.cholesky().ok_or(ProfileError::Registration("singular"))?.solve(&atb);
        let rot = nalgebra::Rotation2::new(delta[0]);
        let step = Rigid2::new(c - rot * c + Vector2::new(delta[1], delta[2]), delta[0]);
        previous = motion;
        motion = step * motion;
        // Movement of the profile's farthest point, px.
        let reach = pairs.iter().map(|(p, _, _)| (p.coords - c).norm()).fold(0.0, Real::max);
        last_step = delta[0].abs() * reach + delta[1].hypot(delta[2]);
        if last_step < CONVERGED_STEP_PX {
            return Ok(motion);
        }
    }
    // Pairs may keep switching segments by a hair: a last step this small is converged.
    if last_step < SETTLED_STEP_PX {
        return Ok(motion);
    }
    // Or a few rows' pairs flip between two segments and the motion jumps between two
    // states a fraction of a pixel apart: the middle of the two is as good as the data fixes
    // it. Anything wider is a failure.
    if last_step < MAX_OSCILLATION_PX {
        let angle = 0.5 * (motion.rotation.angle() + previous.rotation.angle());
        let t = 0.5 * (motion.translation.vector + previous.translation.vector);
        return Ok(Rigid2::new(t, angle));
    }
    Err(ProfileError::Registration("no convergence"))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measure::profile::Facing;
    use crate::measure::profile::synthetic::{
        BACKGROUND, FACE, draw, face, face_edge, mouth_setup,
    };

    /// The upper face: forehead, nasion and nose ridge down to just under the tip.
    fn anchor_region() -> Rect {
        Rect::new(70, 30, 80, 90)
    }

    #[test]
    fn the_same_frame_registers_to_the_identity() {
        let setup = mouth_setup();
        let anchor = capture_anchor(&face(), &setup, anchor_region()).unwrap();
        assert!(anchor.profile.len() >= MIN_REGISTRATION_ROWS);
        let m = register_to_anchor(&face(), &setup, &anchor).unwrap();
        assert!(m.translation.vector.norm() < 1e-3 && m.rotation.angle().abs() < 1e-5, "{m:?}");
    }

    #[test]
    fn a_moved_head_is_registered_back() {
        let setup = mouth_setup();
        let anchor = capture_anchor(&face(), &setup, anchor_region()).unwrap();
        // The head moved 1.6 px forward and 2.4 px down.
        let moved = draw(|y| face_edge(y - 2.4) + 1.6, Facing::Right, FACE, BACKGROUND);
        let m = register_to_anchor(&moved, &setup, &anchor).unwrap();
        let t = m.translation.vector;
        assert!((t.x + 1.6).abs() < 0.1 && (t.y + 2.4).abs() < 0.2, "{m:?}");
        assert!(m.rotation.angle().abs() < 2e-3, "{m:?}");
    }

    #[test]
    fn a_straight_profile_cannot_be_registered() {
        let setup = mouth_setup();
        let straight = draw(|_| 100.0, Facing::Right, FACE, BACKGROUND);
        let anchor = capture_anchor(&straight, &setup, anchor_region()).unwrap();
        assert!(matches!(
            register_to_anchor(&straight, &setup, &anchor),
            Err(ProfileError::Registration(_))
        ));
        let tiny = Rect::new(70, 30, 80, 2 * PROFILE_RADIUS_ROWS as u32 + 5);
        assert!(matches!(
            capture_anchor(&face(), &setup, tiny),
            Err(ProfileError::Registration(_))
        ));
    }
}
