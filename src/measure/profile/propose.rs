//! A full [`ProfileSetup`] proposed from one side frame (crop, reference line, nose length,
//! anchor), so the CLI runs without clicks. Start at [`propose_setup`].

use super::curve::{find_peaks, smooth};
use super::nose::nose_from_samples;
use super::registration::{MIN_REGISTRATION_ROWS, capture_anchor};
use super::setup::default_min_component_px;
use super::silhouette::full_frame_profile;
use super::{Facing, NoseLength, ProfileError, ProfileSetup, Rect, ReferenceLine, Threshold};
use crate::math::{Real, Vector2};
use image::GrayImage;

/// The nose tip is looked for in this share (numerator, denominator) of the silhouette's
/// rows from the top: the chin, lower in the frame, may stand out as far as the nose does.
const NOSE_ROWS: (usize, usize) = (3, 4);

/// The upper lip's bump must stand out by this share of the nose length L: well above edge
/// noise at any image scale, well below a lip's real relief (about a tenth of L).
const LIP_PROMINENCE: Real = 0.02;

/// The crop reaches this many L below the subnasale: the lips and the labiomental fold.
const CROP_BELOW_SUBNASALE: Real = 0.9;

/// The crop's rear edge lies this many L behind the subnasale, inside the face however far
/// the lips protrude or retract.
const CROP_BEHIND_SUBNASALE: Real = 0.5;

/// The crop's front edge lies this many L beyond the nose tip, in the background even for
/// lips protruding past the tip.
const CROP_BEYOND_TIP: Real = 0.25;

/// A crop must be more than this many px in each direction to hold a profile.
const MIN_CROP_PX: usize = 2;

/// The anchor starts this many nasion-to-tip heights above the nasion: forehead enough to
/// fix pitch, not so much that hair enters it.
const ANCHOR_ABOVE_NASION: Real = 0.8;

/// The anchor's rear edge lies this many L behind the nose ridge, inside the face.
const ANCHOR_BEHIND_NOSE: Real = 0.4;

/// Proposes a setup from one frame, so the CLI can run without clicks.
///
/// On the full frame's profile: the nose tip is the foremost point within the silhouette's
/// upper three quarters; the nasion the deepest hull concavity above it; below it, the first
/// bump standing out by 2 % of the nose length is the upper lip and the lowest point between
/// tip and lip the subnasale. Then, with L the nose length:
/// - crop rows from halfway between tip and subnasale down to subnasale + 0.9 L (lips and
///   labiomental fold), columns from 0.5 L behind the subnasale (inside the face) to 0.25 L
///   beyond the nose tip (background), clipped to the frame;
/// - reference line: vertical through the subnasale (the frontal plane seen with the camera
///   level; tilt it by hand when the camera is pitched);
/// - nose length: the two points found, fixed once;
/// - anchor: the profile from 0.8 nose heights above the nasion down to just under the tip,
///   so the line follows the head ([`ProfileSetup::anchor`]; set it to `None` to measure
///   from the line as drawn, as the published method did).
///
/// # Errors
/// Segmentation errors, [`ProfileError::NoseNotFound`] or [`ProfileError::NoUpperLip`] when
/// the profile lacks that structure.
pub fn propose_setup(frame: &GrayImage, facing: Facing) -> Result<ProfileSetup, ProfileError> {
    let min_component = default_min_component_px();
    let profile = full_frame_profile(frame, facing, Threshold::Otsu, true, min_component)?;
    let rows: Vec<usize> = (0..profile.len()).filter(|&r| profile[r].is_some()).collect();
    let (&first, &last) = (rows.first().ok_or(ProfileError::NoseNotFound)?, rows.last().unwrap());
    let limit = first + (NOSE_ROWS.0 * (last - first)) / NOSE_ROWS.1;
    let s: Vec<(usize, Real)> =
        rows.iter().filter(|&&r| r <= limit).map(|&r| (r, profile[r].unwrap().1)).collect();
    let nose = nose_from_samples(&s, &profile, limit + 1, Vector2::new(facing.sign(), 0.0))
        .ok_or(ProfileError::NoseNotFound)?;
    let len = nose.length_px();
    let tip_row = nose.tip.y.round() as usize;
    // Below the tip: forward position per row (rows without face sit far behind).
    let below: Vec<Real> =
        (tip_row..profile.len()).map(|r| profile[r].map_or(-1e9, |p| p.1)).collect();
    let smoothed = smooth(&below);
    let lip = find_peaks(&smoothed)
        .into_iter()
        .find(|p| p.prominence >= LIP_PROMINENCE * len)
        .ok_or(ProfileError::NoUpperLip(LIP_PROMINENCE * len))?;
    let sn_smooth =
        (0..lip.index).min_by(|&a, &b| smoothed[a].total_cmp(&smoothed[b])).unwrap_or(0);
    // Smoothing moves a sharp concavity's minimum by a row; the raw minimum near it is exact.
    let sn_off = (sn_smooth.saturating_sub(2)..(sn_smooth + 3).min(lip.index))
        .min_by(|&a, &b| below[a].total_cmp(&below[b]))
        .unwrap_or(sn_smooth);
    let sn_row = tip_row + sn_off;
    let (sn_pt, sn_u) = profile[sn_row].ok_or(ProfileError::NoUpperLip(LIP_PROMINENCE * len))?;
    let tip_u = profile[tip_row].map_or(sn_u + len, |p| p.1);
    let (w, h) = frame.dimensions();
    let top = tip_row + sn_off / 2;
    let bottom = ((sn_row as Real + CROP_BELOW_SUBNASALE * len).round() as usize).min(h as usize);
    let u_rear = sn_u - CROP_BEHIND_SUBNASALE * len;
    let u_front = tip_u + CROP_BEYOND_TIP * len;
    if bottom <= top + MIN_CROP_PX || u_front <= u_rear.max(0.0) + MIN_CROP_PX as Real {
        return Err(ProfileError::NoUpperLip(LIP_PROMINENCE * len));
    }
    // Forward-coordinate columns [u0, u1] and rows [r0, r1) as an image rectangle.
    let rect = |u0: Real, u1: Real, r0: usize, r1: usize| {
        let (u0, u1) = (u0.floor().max(0.0) as u32, u1.ceil().min(w as Real - 1.0) as u32);
        let x = match facing {
            Facing::Right => u0,
            Facing::Left => w - 1 - u1,
        };
        Rect::new(x, r0 as u32, u1 - u0 + 1, (r1 - r0) as u32)
    };
    let mut setup = ProfileSetup::new(
        rect(u_rear, u_front, top, bottom),
        ReferenceLine::vertical(sn_pt.x),
        facing,
    );
    setup.nose = NoseLength::Points { root: nose.root, tip: nose.tip };
    // The anchor: forehead above the nasion down to just under the nose tip, rigid parts.
    let root_row = nose.root.y.round() as usize;
    let root_u = profile[root_row].map_or(tip_u - len, |p| p.1);
    let a_top =
        root_row.saturating_sub((ANCHOR_ABOVE_NASION * (tip_row - root_row) as Real) as usize);
    let a_bottom = (tip_row + sn_off / 4 + 1).min(top);
    if a_bottom > a_top + MIN_REGISTRATION_ROWS {
        let region = rect(root_u.min(tip_u) - ANCHOR_BEHIND_NOSE * len, u_front, a_top, a_bottom);
        setup.anchor = Some(capture_anchor(frame, &setup, region)?);
    }
    Ok(setup)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measure::profile::measure_lip_profile;
    use crate::measure::profile::synthetic::{BACKGROUND, FACE, draw, face, face_edge, lip_apex};

    #[test]
    fn the_proposed_setup_frames_the_mouth_and_measures_the_lip() {
        let setup = propose_setup(&face(), Facing::Right).unwrap();
        let (row, x) = lip_apex();
        let c = setup.crop;
        assert!((c.y as Real) < row && row < (c.y + c.height) as Real, "{c:?}");
        assert!((c.x as Real) < 100.0 && x < (c.x + c.width) as Real, "{c:?}");
        // The line runs through the subnasale, the concavity between nose and lip.
        let sn = setup.reference_line.a.x;
        let deepest = (112..145).map(|y| face_edge(y as Real)).fold(Real::MAX, Real::min);
        assert!((sn - deepest).abs() < 0.5, "{sn} vs {deepest}");
        assert!(matches!(setup.nose, NoseLength::Points { .. }));
        assert!(setup.anchor.is_some());
        // Measured from the line as drawn, P is the lip's distance from the subnasale.
        let fixed = ProfileSetup { anchor: None, ..setup.clone() };
        let m = measure_lip_profile(&face(), &fixed).unwrap();
        assert!((m.p_px - (x - sn)).abs() < 0.05, "{} vs {}", m.p_px, x - sn);
        // Following the head, the frame the anchor was taken on barely moves.
        let m = measure_lip_profile(&face(), &setup).unwrap().motion.unwrap();
        assert!(m.translation.vector.norm() < 0.25 && m.rotation.angle().abs() < 2e-3, "{m:?}");
    }

    #[test]
    fn a_profile_without_a_nose_is_refused() {
        let flat = draw(|_| 100.0, Facing::Right, FACE, BACKGROUND);
        assert_eq!(propose_setup(&flat, Facing::Right), Err(ProfileError::NoseNotFound));
    }
}
