//! Lip-order checks: the lip contours of the iBUG-68 scheme must stay in their anatomical
//! order along the mouth's vertical axis — outer upper lip (50–52) above inner upper lip
//! (61–63) above inner lower lip (67–65) above outer lower lip (58–56). A tracker that puts
//! a lower inner point on the teeth above the upper lip, or an inner point outside the lip,
//! breaks that order; real speech never does. Start at [`lip_order_flags`].

use super::flags::{FlagReason, FlagThresholds, face_sizes};
use super::track::Track;
use crate::math::Vector2;

/// (upper, lower) point pairs that must keep `upper` above `lower`, column by column:
/// outer upper over inner upper, inner upper over inner lower, inner lower over outer lower.
pub const ORDERED_PAIRS: [(usize, usize); 9] =
    [(50, 61), (51, 62), (52, 63), (61, 67), (62, 66), (63, 65), (67, 58), (66, 57), (65, 56)];

/// One reason per frame: the pair most out of order, when its overlap (how far `lower` sits
/// above `upper`, measured perpendicular to the corner-to-corner line 48→54) exceeds
/// `lip_order_face_fraction` of the face size. Sealed lips make the inner pairs coincide, and
/// trackers scatter them by a pixel either way: the tolerance absorbs that.
pub fn lip_order_flags(track: &Track, th: &FlagThresholds) -> Vec<(usize, FlagReason)> {
    let sizes = face_sizes(track);
    let mut out = Vec::new();
    for (f, size) in track.frames.iter().zip(sizes) {
        let Some(size) = size else { continue };
        let pos = |i: usize| f.points.get(i).filter(|p| p.visible).map(|p| p.pos());
        let (Some(left), Some(right)) = (pos(48), pos(54)) else { continue };
        let across = right - left;
        if across.norm() <= 1e-9 {
            continue;
        }
        // Image y points down: rotating the corner line by +90° gives "down the face".
        let down = Vector2::new(-across.y, across.x).normalize();
        let worst = ORDERED_PAIRS
            .iter()
            .filter_map(|&(upper, lower)| {
                let overlap = (pos(upper)? - pos(lower)?).dot(&down) / size;
                Some((upper, lower, overlap))
            })
            .max_by(|a, b| a.2.total_cmp(&b.2));
        if let Some((upper, lower, overlap)) = worst
            && overlap > th.lip_order_face_fraction
        {
            out.push((f.frame, FlagReason::LipOrder { upper, lower, face_fraction: overlap }));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::landmarks::flags::FlagThresholds;
    use crate::landmarks::{FrameLandmarks, LandmarkPoint, N_LANDMARKS};

    /// A frontal face: eyes 60 px apart, an open mouth whose columns are in order.
    fn open_mouth() -> FrameLandmarks {
        let mut pts = vec![LandmarkPoint::tracked(100.0, 100.0); N_LANDMARKS];
        pts[36] = LandmarkPoint::tracked(70.0, 60.0);
        pts[45] = LandmarkPoint::tracked(130.0, 60.0);
        pts[48] = LandmarkPoint::tracked(80.0, 130.0);
        pts[54] = LandmarkPoint::tracked(120.0, 130.0);
        for (col, x) in [(0, 92.0), (1, 100.0), (2, 108.0)] {
            pts[50 + col] = LandmarkPoint::tracked(x, 120.0);
            pts[61 + col] = LandmarkPoint::tracked(x, 125.0);
            pts[67 - col] = LandmarkPoint::tracked(x, 135.0);
            pts[58 - col] = LandmarkPoint::tracked(x, 142.0);
        }
        FrameLandmarks::new(0, pts)
    }

    #[test]
    fn a_lower_inner_point_above_the_upper_lip_is_flagged() {
        let th = FlagThresholds::default();
        let ok = Track::new(vec![open_mouth()]);
        assert!(lip_order_flags(&ok, &th).is_empty());
        let mut bad = open_mouth();
        bad.points[66].y = 121.0; // above 62 (125) by 4 px = 0.067 of the 60 px eye distance
        let flags = lip_order_flags(&Track::new(vec![bad]), &th);
        assert_eq!(flags.len(), 1);
        let FlagReason::LipOrder { upper, lower, face_fraction } = flags[0].1 else { panic!() };
        assert_eq!((upper, lower), (62, 66));
        assert!((face_fraction - 4.0 / 60.0).abs() < 1e-9);
    }

    #[test]
    fn sealed_lips_within_a_pixel_are_not_flagged() {
        let mut sealed = open_mouth();
        for col in 0..3 {
            sealed.points[61 + col].y = 130.0;
            sealed.points[67 - col].y = 129.5;
        }
        assert!(lip_order_flags(&Track::new(vec![sealed]), &FlagThresholds::default()).is_empty());
    }
}
