//! The nose length P is divided by: nose tip (foremost point above the mouth) and root
//! (nasion, deepest concavity above the tip) on the full frame's profile. Start at
//! [`find_nose_on_profile`] or [`resolve_nose_length`].

use super::curve::{APEX_SOFT, refine_maximum};
use super::silhouette::full_frame_profile;
use super::{NoseLength, ProfileError, ProfileSetup};
use crate::math::{Point2, Real, Vector2};
use image::GrayImage;
use serde::{Deserialize, Serialize};

/// The nose root and tip found on the full frame's profile.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct NosePoints {
    pub root: Point2,
    pub tip: Point2,
}

impl NosePoints {
    pub fn length_px(&self) -> Real {
        (self.tip - self.root).norm()
    }
}

/// The nasion's concavity must lie at least this deep (px) under the profile's hull; a
/// shallower dip is edge noise on a straight forehead-to-nose line.
const MIN_NASION_DEPTH_PX: Real = 1.0;

/// Upper hull of the points `(i, y[i])`: the least concave function at or above the curve,
/// evaluated at every index; the gap under it is the depth of each concavity.
fn upper_hull(y: &[(usize, Real)]) -> Vec<Real> {
    let mut hull: Vec<(Real, Real)> = Vec::new();
    for &(i, v) in y {
        let p = (i as Real, v);
        while hull.len() >= 2 {
            let (a, b) = (hull[hull.len() - 2], hull[hull.len() - 1]);
            // Drop b when it lies on or below the chord a–p.
            if (b.0 - a.0) * (p.1 - a.1) - (b.1 - a.1) * (p.0 - a.0) >= 0.0 {
                hull.pop();
            } else {
                break;
            }
        }
        hull.push(p);
    }
    y.iter()
        .map(|&(i, _)| {
            let x = i as Real;
            let k = hull.partition_point(|h| h.0 < x).min(hull.len() - 1);
            if k == 0 || hull[k].0 == x {
                hull[k].1
            } else {
                let (a, b) = (hull[k - 1], hull[k]);
                a.1 + (b.1 - a.1) * (x - a.0) / (b.0 - a.0)
            }
        })
        .collect()
}

/// Finds the nose tip and root on the full frame's profile: the tip is the foremost profile
/// point above the crop's top row, the root (nasion) the point above
/// the tip lying deepest under the profile's forward convex hull (the concavity between
/// forehead and nose). Forward is along the reference line's normal.
///
/// # Errors
/// [`ProfileError::NoseNotFound`] when the tip is not above the crop (the foremost point sits
/// on the crop's top row) or no concavity lies above it; segmentation errors as for frames.
pub fn find_nose_on_profile(
    image: &GrayImage,
    setup: &ProfileSetup,
) -> Result<NosePoints, ProfileError> {
    let normal =
        setup.reference_line.forward_normal(setup.facing).ok_or(ProfileError::BadReferenceLine)?;
    let profile = full_frame_profile(
        image,
        setup.facing,
        setup.threshold,
        setup.denoise,
        setup.min_component_px,
    )?;
    let top = (setup.crop.y as usize).min(profile.len());
    let s: Vec<(usize, Real)> = profile[..top]
        .iter()
        .enumerate()
        .filter_map(|(r, p)| p.map(|(q, _)| (r, (q - setup.reference_line.a).dot(&normal))))
        .collect();
    nose_from_samples(&s, &profile, top, normal).ok_or(ProfileError::NoseNotFound)
}

/// Tip = foremost of the samples `(row, distance along normal)` (not on the last row
/// `top − 1`), refined by a parabola as the lip is; root = deepest under the hull of the
/// samples above the tip.
pub(super) fn nose_from_samples(
    s: &[(usize, Real)],
    profile: &[Option<(Point2, Real)>],
    top: usize,
    normal: Vector2,
) -> Option<NosePoints> {
    let k = (0..s.len()).max_by(|&a, &b| s[a].1.total_cmp(&s[b].1))?;
    if s[k].0 + 1 >= top || k < 2 {
        return None;
    }
    let values: Vec<Real> = s.iter().map(|p| p.1).collect();
    let (t, v) = refine_maximum(&values, k, APEX_SOFT);
    // Move the tip's sample point by the refinement: along the rows and along the normal.
    let tip = profile[s[k].0]?.0 + Vector2::new(0.0, t - k as Real) + normal * (v - s[k].1);
    let above = &s[..=k];
    let hull = upper_hull(above);
    let (j, depth) = above
        .iter()
        .zip(&hull)
        .enumerate()
        .map(|(j, (p, h))| (j, h - p.1))
        .max_by(|a, b| a.1.total_cmp(&b.1))?;
    (depth >= MIN_NASION_DEPTH_PX).then_some(())?;
    let root = profile[above[j].0]?.0;
    Some(NosePoints { root, tip })
}

/// Resolves the setup's nose length (px) from `frame` when it must be found on the profile.
///
/// # Errors
/// As [`find_nose_on_profile`], and [`ProfileError::BadNoseLength`] for a non-positive length.
pub fn resolve_nose_length(
    setup: &ProfileSetup,
    frame: &GrayImage,
) -> Result<Option<Real>, ProfileError> {
    let len = match setup.nose {
        NoseLength::Unset => return Ok(None),
        NoseLength::Px(l) => l,
        NoseLength::Points { root, tip } => (tip - root).norm(),
        NoseLength::FromProfile => find_nose_on_profile(frame, setup)?.length_px(),
    };
    if len.is_finite() && len > 0.0 { Ok(Some(len)) } else { Err(ProfileError::BadNoseLength) }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measure::profile::synthetic::{face, face_edge, mouth_setup};

    #[test]
    fn the_hull_lies_on_or_above_the_curve_and_touches_its_peaks() {
        let y: Vec<(usize, Real)> =
            [0.0, 3.0, 1.0, 2.0, 4.0, 0.0].into_iter().enumerate().collect();
        let expected = [0.0, 3.0, 3.0 + 1.0 / 3.0, 3.0 + 2.0 / 3.0, 4.0, 0.0];
        let hull = upper_hull(&y);
        assert!(hull.iter().zip(expected).all(|(h, e)| (h - e).abs() < 1e-12), "{hull:?}");
    }

    #[test]
    fn nose_tip_and_root_on_the_full_frame_profile() {
        let nose = find_nose_on_profile(&face(), &mouth_setup()).unwrap();
        let tip_x = face_edge(110.0);
        assert!((nose.tip.y - 110.0).abs() < 0.5 && (nose.tip.x - tip_x).abs() < 0.1, "{nose:?}");
        // The nasion: the deepest point under the hull from the forehead to the tip, a few
        // rows below the dip's centre (the hull slopes up toward the tip).
        assert!((68.0..80.0).contains(&nose.root.y), "{nose:?}");
        assert!(nose.length_px() > 30.0 && nose.length_px() < 50.0);
    }

    #[test]
    fn nose_lengths_resolve_or_fail() {
        let mut setup = mouth_setup();
        assert_eq!(resolve_nose_length(&setup, &face()), Ok(None));
        setup.nose = NoseLength::Px(40.0);
        assert_eq!(resolve_nose_length(&setup, &face()), Ok(Some(40.0)));
        setup.nose = NoseLength::Points { root: Point2::new(0.0, 0.0), tip: Point2::new(3.0, 4.0) };
        assert_eq!(resolve_nose_length(&setup, &face()), Ok(Some(5.0)));
        setup.nose = NoseLength::Px(0.0);
        assert_eq!(resolve_nose_length(&setup, &face()), Err(ProfileError::BadNoseLength));
        setup.nose = NoseLength::FromProfile;
        let found = find_nose_on_profile(&face(), &setup).unwrap().length_px();
        assert_eq!(resolve_nose_length(&setup, &face()), Ok(Some(found)));
        // A crop starting above the nose tip leaves no tip above it.
        setup.crop.y = 90;
        assert_eq!(find_nose_on_profile(&face(), &setup), Err(ProfileError::NoseNotFound));
    }
}
