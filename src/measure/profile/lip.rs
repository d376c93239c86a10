//! The upper lip's foremost point and its protrusion P (px) in one side frame: the first
//! prominent bump from the top of the silhouette's forward-edge profile, refined to
//! sub-pixel. Start at [`measure_lip_profile`].

#[cfg(doc)]
use super::ReferenceLine;
use super::curve::{APEX_HARD, APEX_SOFT, find_peaks, median_of_three, refine_maximum, smooth};
use super::registration::register_to_anchor;
use super::silhouette::{ANTIALIASED_MIN_SHARE, segment};
use super::{ProfileError, ProfileSetup, Rigid2};
use crate::math::{Point2, Real, Vector2};
use image::GrayImage;

/// A raw sample farther than this (px) from the despiked curve is a speck on the edge, not
/// the lip: a real edge moves well under a pixel between neighbouring rows near the apex.
const MAX_SPECK_OFFSET_PX: Real = 1.0;

/// Smallest rate (distance per image px along x) at which the distance from the reference
/// line grows: sin 30°, the same bound as [`ReferenceLine::forward_normal`]'s, after head
/// motion has turned the line.
const MIN_SLOPE: Real = 0.5;

/// One frame's profile measurement, with what the TUI may draw.
#[derive(Clone, Debug, PartialEq)]
pub struct LipProfile {
    /// The silhouette's forward edge per crop row (image px), `None` where the row has no face.
    pub edge: Vec<Option<Point2>>,
    /// The upper lip's foremost point (image px).
    pub upper_lip_px: Point2,
    /// Signed distance of `upper_lip_px` from the reference line, forward positive (px).
    pub p_px: Real,
    /// The subnasale and stomion concavities bracketing the upper lip, when inside the crop.
    pub subnasale_px: Option<Point2>,
    pub stomion_px: Option<Point2>,
    /// The gray threshold used.
    pub threshold: u8,
    /// This frame → anchor frame, when the setup follows head motion.
    pub motion: Option<Rigid2>,
}

/// Measures the upper lip's protrusion in one frame.
///
/// The rule for the upper lip: along the crop's rows (top to bottom) the profile's forward
/// distance `s(row)` from the reference line, smoothed, has interior peaks; the upper lip is
/// the first peak (from the top) whose prominence is at least `setup.min_prominence_px`. The
/// curve above it falls to the subnasale concavity (or climbs out of the crop into the nose
/// underside), the curve below it falls to the stomion before the lower lip. Its value is
/// refined to sub-pixel by a parabola through the raw samples around it.
///
/// # Errors
/// [`ProfileError`] when the crop is outside the frame, uniform, holds no face, the line is
/// degenerate, no lip bump stands out, or the lip touches the crop's front edge.
pub fn measure_lip_profile(
    image: &GrayImage,
    setup: &ProfileSetup,
) -> Result<LipProfile, ProfileError> {
    let line = &setup.reference_line;
    let normal = line.forward_normal(setup.facing).ok_or(ProfileError::BadReferenceLine)?;
    let motion = match &setup.anchor {
        Some(anchor) => Some(register_to_anchor(image, setup, anchor)?),
        None => None,
    };
    let to_reference = motion.unwrap_or_else(Rigid2::identity);
    let sil = segment(
        image,
        setup.crop,
        setup.facing,
        setup.threshold,
        setup.denoise,
        setup.min_component_px,
    )?;
    let edges = sil.forward_edges();
    let edge: Vec<Option<Point2>> =
        edges.iter().enumerate().map(|(r, e)| e.map(|(u, _)| sil.to_image(u, r as Real))).collect();
    // Distances are taken in the anchor frame: the line is fixed to the head.
    let dist = |p: Point2| (to_reference * p - line.a).dot(&normal);
    // Rows without face act as deep concavities: the distance of the crop's rear edge.
    let floor = (0..sil.height)
        .map(|r| dist(sil.to_image(-0.5, r as Real)))
        .fold(Real::INFINITY, Real::min);
    let s: Vec<Real> = edge.iter().map(|p| p.map_or(floor, dist)).collect();
    if s.len() < 3 {
        return Err(ProfileError::NoUpperLip(setup.min_prominence_px));
    }
    // Structure from a despiked, smoothed copy; the value from the raw samples, except rows
    // more than 1 px off the despiked curve (specks), which take the despiked value.
    let despiked = median_of_three(&s);
    let s: Vec<Real> = s
        .iter()
        .zip(&despiked)
        .map(|(&v, &d)| if (v - d).abs() > MAX_SPECK_OFFSET_PX { d } else { v })
        .collect();
    let smoothed = smooth(&despiked);
    let peaks = find_peaks(&smoothed);
    let lip = peaks
        .iter()
        .find(|p| p.prominence >= setup.min_prominence_px)
        .copied()
        .ok_or(ProfileError::NoUpperLip(setup.min_prominence_px))?;
    // Hard-edged frames need the wider window (see APEX_HARD).
    let window =
        if sil.antialiased_share() >= ANTIALIASED_MIN_SHARE { APEX_SOFT } else { APEX_HARD };
    let (row, p_px) = refine_maximum(&s, lip.index, window);
    let near = row.round() as usize;
    if (near.saturating_sub(1)..=(near + 1).min(sil.height - 1))
        .any(|r| edges[r].is_some_and(|e| e.1))
    {
        return Err(ProfileError::LipAtCropEdge);
    }
    // The image point on the refined row whose distance is the refined maximum: distance is
    // linear in x, with slope n·R·e_x.
    let y = sil.region.y as Real + row;
    let at_zero = dist(Point2::new(0.0, y));
    let slope = normal.dot(&(to_reference.rotation * Vector2::x()));
    if slope.abs() < MIN_SLOPE {
        return Err(ProfileError::BadReferenceLine);
    }
    let x = (p_px - at_zero) / slope;
    let concavity = |range: std::ops::Range<usize>| {
        let r = range.clone().min_by(|&a, &b| smoothed[a].total_cmp(&smoothed[b]))?;
        // A concavity at the crop edge is only where the curve left the crop.
        (r > 0 && r + 1 < sil.height).then_some(())?;
        edge[r]
    };
    let subnasale_px = concavity(0..lip.index);
    let next = peaks.iter().find(|p| p.index > lip.index).map_or(sil.height, |p| p.index);
    let stomion_px = concavity(lip.index + 1..next);
    Ok(LipProfile {
        edge,
        upper_lip_px: Point2::new(x, y),
        p_px,
        subnasale_px,
        stomion_px,
        threshold: sil.threshold,
        motion,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measure::profile::synthetic::{
        BACKGROUND, FACE, draw, face, face_edge, lip_apex, mouth_setup,
    };
    use crate::measure::profile::{Facing, Rect, ReferenceLine};

    #[test]
    fn the_upper_lip_apex_and_p_are_recovered() {
        let (row, x) = lip_apex();
        let m = measure_lip_profile(&face(), &mouth_setup()).unwrap();
        assert!((m.upper_lip_px.y - row).abs() < 0.5, "{:?} vs {row}", m.upper_lip_px);
        assert!((m.p_px - (x - 100.0)).abs() < 0.05, "{} vs {}", m.p_px, x - 100.0);
        assert!((m.upper_lip_px.x - x).abs() < 0.05);
        // The concavities bracket the lip: subnasale above it, stomion below.
        let (sn, st) = (m.subnasale_px.unwrap(), m.stomion_px.unwrap());
        assert!(sn.y < row && row < st.y && st.y < 170.0, "{sn:?} {st:?}");
        assert_eq!(m.motion, None);
    }

    #[test]
    fn p_follows_a_sub_pixel_shift_and_the_facing() {
        let base = measure_lip_profile(&face(), &mouth_setup()).unwrap().p_px;
        let shifted = draw(|y| face_edge(y) + 0.3, Facing::Right, FACE, BACKGROUND);
        let p = measure_lip_profile(&shifted, &mouth_setup()).unwrap().p_px;
        assert!((p - base - 0.3).abs() < 0.02, "{p} vs {base}");
        let left = draw(face_edge, Facing::Left, FACE, BACKGROUND);
        let w = left.width();
        let setup = crate::measure::profile::ProfileSetup::new(
            Rect::new(w - 160, 125, 100, 70),
            ReferenceLine::vertical(w as Real - 1.0 - 100.0),
            Facing::Left,
        );
        let p = measure_lip_profile(&left, &setup).unwrap().p_px;
        assert!((p - base).abs() < 1e-9, "{p} vs {base}");
    }

    #[test]
    fn no_bump_and_a_lip_at_the_crop_edge_are_errors() {
        let flat = draw(|_| 100.0, Facing::Right, FACE, BACKGROUND);
        assert!(matches!(
            measure_lip_profile(&flat, &mouth_setup()),
            Err(ProfileError::NoUpperLip(_))
        ));
        let mut narrow = mouth_setup();
        narrow.crop.width = 51; // front edge at x = 110, behind the lip's apex
        assert_eq!(measure_lip_profile(&face(), &narrow), Err(ProfileError::LipAtCropEdge));
        let mut flat_line = mouth_setup();
        flat_line.reference_line = ReferenceLine::through(Point2::new(100.0, 150.0), 80.0);
        assert_eq!(measure_lip_profile(&face(), &flat_line), Err(ProfileError::BadReferenceLine));
    }
}
