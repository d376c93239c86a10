//! W and H from 68-point 2D landmarks (video, or a mesh's projected landmark vertices),
//! normalised by the reference length |mid(p39, p42) − p30|, and per-sequence min–max.
//!
//! W = |p60 − p64| (inner lip corners), H = |p62 − p66| (inner lip midpoints), both divided
//! by the distance from the midpoint of the inner eye corners to the nose tip, a length that
//! articulation does not change (`docs/design.md`, "Measures"). Being ratios of distances, both are invariant
//! to image scale, translation and in-plane rotation, so head size and camera zoom drop out.

use super::{MeasureError, MouthMeasures, Series, Trajectory};
use crate::landmarks::ibug::point::{
    INNER_LIP_LEFT, INNER_LIP_RIGHT, LEFT_ENDOCANTHION, NOSE_TIP, RIGHT_ENDOCANTHION,
    STOMION_LOWER, STOMION_UPPER,
};
use crate::landmarks::{FrameLandmarks, Track};
use crate::math::Point2;

/// Smallest reference length accepted, relative to nothing: lengths at or below this (in the
/// landmarks' own units) mean coincident points, and the ratio would explode.
const MIN_REFERENCE_LENGTH: f64 = 1e-9;

fn get(points: &[Option<Point2>], i: usize) -> Result<Point2, MeasureError> {
    let p = points.get(i).copied().flatten().ok_or(MeasureError::MissingLandmark(i))?;
    if p.x.is_finite() && p.y.is_finite() { Ok(p) } else { Err(MeasureError::NonFinite) }
}

/// The reference length |mid(p39, p42) − p30| in the points' units (pixels for video).
///
/// `points` holds the 68 iBUG points (0-based), `None` where a point is not available.
///
/// # Errors
/// `MissingLandmark` when 30, 39 or 42 is absent, `NonFinite` for NaN coordinates.
///
/// ```
/// use lipmap::math::Point2;
/// let mut pts = vec![None; 68];
/// pts[39] = Some(Point2::new(-1.0, 0.0));
/// pts[42] = Some(Point2::new(1.0, 0.0));
/// pts[30] = Some(Point2::new(0.0, 4.0));
/// assert_eq!(lipmap::measure::reference_length(&pts).unwrap(), 4.0);
/// ```
pub fn reference_length(points: &[Option<Point2>]) -> Result<f64, MeasureError> {
    let a = get(points, RIGHT_ENDOCANTHION)?;
    let b = get(points, LEFT_ENDOCANTHION)?;
    let tip = get(points, NOSE_TIP)?;
    Ok((nalgebra::center(&a, &b) - tip).norm())
}

/// Normalised W and H from 68 iBUG points (`None` = unavailable); `p` is always `None`.
///
/// # Errors
/// `MissingLandmark` when one of 30, 39, 42, 60, 62, 64, 66 is absent; `NonFinite`;
/// `DegenerateReference` when the reference length is (near) zero.
///
/// ```
/// use lipmap::math::Point2;
/// let mut pts = vec![None; 68];
/// for (i, x, y) in [(39, -1.0, 0.0), (42, 1.0, 0.0), (30, 0.0, 2.0),
///                   (60, -1.0, 5.0), (64, 1.0, 5.0), (62, 0.0, 4.5), (66, 0.0, 5.5)] {
///     pts[i] = Some(Point2::new(x, y));
/// }
/// let m = lipmap::measure::measure_points(&pts).unwrap();
/// assert_eq!((m.w, m.h), (1.0, 0.5));
/// ```
pub fn measure_points(points: &[Option<Point2>]) -> Result<MouthMeasures, MeasureError> {
    let reference = reference_length(points)?;
    if !reference.is_finite() || reference <= MIN_REFERENCE_LENGTH {
        return Err(MeasureError::DegenerateReference(reference));
    }
    let w = (get(points, INNER_LIP_RIGHT)? - get(points, INNER_LIP_LEFT)?).norm();
    let h = (get(points, STOMION_UPPER)? - get(points, STOMION_LOWER)?).norm();
    Ok(MouthMeasures { w: w / reference, h: h / reference, p: None })
}

/// The frame's visible points as the `Option` slice the measures take.
pub fn visible_points(frame: &FrameLandmarks) -> Vec<Option<Point2>> {
    frame.points.iter().map(|p| p.visible.then(|| p.pos())).collect()
}

/// Normalised W and H of one tracked frame, using visible points only.
///
/// # Errors
/// As [`measure_points`]; an occluded point counts as missing.
pub fn measure_frame(frame: &FrameLandmarks) -> Result<MouthMeasures, MeasureError> {
    measure_points(&visible_points(frame))
}

/// W and H trajectories of a track, indexed by frame number; untracked frames and frames
/// whose measure fails are `None`. `n_frames` pads (or truncates) to a clip's length when
/// given; otherwise the length is last frame + 1. `p` stays empty.
pub fn trajectory_from_track(track: &Track, n_frames: Option<usize>) -> Trajectory {
    let len = n_frames.unwrap_or_else(|| track.frames.last().map_or(0, |f| f.frame + 1));
    let mut frames = vec![None; len];
    for f in &track.frames {
        if f.frame < len {
            frames[f.frame] = measure_frame(f).ok();
        }
    }
    Trajectory::from_frames(&frames)
}

/// Min–max normalisation of one sequence to [0, 1]: `(x − min) / (max − min)` over its
/// present values; `None` entries stay `None`. The published method applies it to the video
/// and to the head separately, so the comparison is of trajectory shapes, not amplitudes.
///
/// Returns `None` when fewer than two values are present or the range is zero (a constant
/// sequence has no shape to compare).
///
/// ```
/// let s = lipmap::measure::min_max_normalise(&[Some(2.0), None, Some(4.0), Some(3.0)]).unwrap();
/// assert_eq!(s, vec![Some(0.0), None, Some(1.0), Some(0.5)]);
/// ```
pub fn min_max_normalise(series: &[Option<f64>]) -> Option<Series> {
    let present = series.iter().flatten().copied().filter(|v| v.is_finite());
    let (lo, hi, n) = present.fold((f64::INFINITY, f64::NEG_INFINITY, 0usize), |(lo, hi, n), v| {
        (lo.min(v), hi.max(v), n + 1)
    });
    let range = hi - lo;
    if n < 2 || !range.is_finite() || range <= 0.0 {
        return None;
    }
    Some(series.iter().map(|v| v.filter(|v| v.is_finite()).map(|v| (v - lo) / range)).collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::landmarks::{LandmarkPoint, N_LANDMARKS};
    use proptest::prelude::*;

    /// A plausible frontal face: eyes at y = 0, nose tip 40 px lower, mouth 30 px below that.
    fn face() -> Vec<Option<Point2>> {
        let mut pts: Vec<Option<Point2>> =
            (0..N_LANDMARKS).map(|i| Some(Point2::new(i as f64, 100.0 + i as f64))).collect();
        pts[39] = Some(Point2::new(90.0, 100.0));
        pts[42] = Some(Point2::new(130.0, 100.0));
        pts[30] = Some(Point2::new(110.0, 140.0));
        pts[60] = Some(Point2::new(90.0, 170.0));
        pts[64] = Some(Point2::new(130.0, 172.0));
        pts[62] = Some(Point2::new(110.0, 165.0));
        pts[66] = Some(Point2::new(111.0, 177.0));
        pts
    }

    #[test]
    fn known_face_gives_hand_computed_ratios() {
        let m = measure_points(&face()).unwrap();
        // W = sqrt(40² + 2²) / 40, H = sqrt(1 + 12²) / 40.
        assert!((m.w - (1604.0f64).sqrt() / 40.0).abs() < 1e-12);
        assert!((m.h - (145.0f64).sqrt() / 40.0).abs() < 1e-12);
        assert_eq!(m.p, None);
    }

    #[test]
    fn missing_or_degenerate_points_are_errors_not_panics() {
        let mut pts = face();
        pts[62] = None;
        assert_eq!(measure_points(&pts), Err(MeasureError::MissingLandmark(62)));
        let mut pts = face();
        pts[30] = Some(Point2::new(110.0, 100.0));
        assert!(matches!(measure_points(&pts), Err(MeasureError::DegenerateReference(_))));
        let mut pts = face();
        pts[60] = Some(Point2::new(f64::NAN, 1.0));
        assert_eq!(measure_points(&pts), Err(MeasureError::NonFinite));
        assert_eq!(measure_points(&[]), Err(MeasureError::MissingLandmark(39)));
    }

    #[test]
    fn occluded_point_is_missing_in_a_frame() {
        let pts: Vec<LandmarkPoint> =
            face().iter().map(|p| LandmarkPoint::tracked(p.unwrap().x, p.unwrap().y)).collect();
        let mut frame = FrameLandmarks::new(3, pts);
        assert!(measure_frame(&frame).is_ok());
        frame.points[66].visible = false;
        assert_eq!(measure_frame(&frame), Err(MeasureError::MissingLandmark(66)));
    }

    #[test]
    fn track_trajectory_places_frames_by_number() {
        let pts: Vec<LandmarkPoint> =
            face().iter().map(|p| LandmarkPoint::tracked(p.unwrap().x, p.unwrap().y)).collect();
        let track = Track::new(vec![
            FrameLandmarks::new(0, pts.clone()),
            FrameLandmarks::new(2, pts.clone()),
        ]);
        let t = trajectory_from_track(&track, None);
        assert_eq!(t.w.len(), 3);
        assert!(t.w[0].is_some() && t.w[1].is_none() && t.w[2].is_some());
        assert!(t.p.is_empty());
        assert_eq!(trajectory_from_track(&track, Some(5)).h.len(), 5);
    }

    #[test]
    fn min_max_rejects_constant_and_short_series() {
        assert_eq!(min_max_normalise(&[Some(1.0), Some(1.0)]), None);
        assert_eq!(min_max_normalise(&[Some(1.0), None]), None);
        let t =
            Trajectory { w: vec![Some(1.0), Some(3.0)], h: vec![Some(2.0), Some(2.0)], p: vec![] };
        let n = t.min_max_normalised();
        assert_eq!(n.w, vec![Some(0.0), Some(1.0)]);
        assert_eq!(n.h, vec![None, None]);
    }

    fn transform(
        pts: &[Option<Point2>],
        s: f64,
        angle: f64,
        tx: f64,
        ty: f64,
    ) -> Vec<Option<Point2>> {
        let (sin, cos) = angle.sin_cos();
        pts.iter()
            .map(|p| {
                p.map(|p| {
                    Point2::new(s * (cos * p.x - sin * p.y) + tx, s * (sin * p.x + cos * p.y) + ty)
                })
            })
            .collect()
    }

    proptest! {
        #[test]
        fn normalised_w_h_invariant_to_similarity(
            s in 0.05f64..20.0,
            angle in -3.1f64..3.1,
            tx in -1e3f64..1e3,
            ty in -1e3f64..1e3,
            jitter in prop::collection::vec(-5.0f64..5.0, 14),
        ) {
            let mut pts = face();
            for (k, &i) in [39usize, 42, 30, 60, 64, 62, 66].iter().enumerate() {
                let p = pts[i].unwrap();
                pts[i] = Some(Point2::new(p.x + jitter[2 * k], p.y + jitter[2 * k + 1]));
            }
            let a = measure_points(&pts).unwrap();
            let b = measure_points(&transform(&pts, s, angle, tx, ty)).unwrap();
            prop_assert!((a.w - b.w).abs() < 1e-9 * a.w.max(1.0));
            prop_assert!((a.h - b.h).abs() < 1e-9 * a.h.max(1.0));
        }
    }
}
