//! Labelling suggestions: which mesh vertex an iBUG landmark most likely is, found by seeing
//! the head through a frame's camera and picking the vertex that lands on the tracked point.
//!
//! The camera is a fitted frame's pose when there is one, else a scaled orthographic pose
//! estimated from the landmarks already mapped, so a few hand labels suggest all the rest.

use super::camera::{OrthoPose, estimate_orthographic_pose, refine_orthographic_pose};
use crate::landmarks::{FrameLandmarks, N_LANDMARKS};
use crate::math::{Point2, Point3, Real};
use crate::model::LandmarkMap;

/// Mapped and visible landmarks needed to estimate a pose (the affine camera has 8 unknowns).
pub const MIN_LABELS_FOR_POSE: usize = 4;

/// One suggested label.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LabelSuggestion {
    pub landmark: usize,
    pub vertex: usize,
    /// Distance in pixels between the vertex's projection and the tracked point: how far
    /// the suggestion is from exact (large values mean the pose or the head disagrees).
    pub distance_px: Real,
}

/// Why no suggestion could be made.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SuggestError {
    #[error(
        "label at least {MIN_LABELS_FOR_POSE} landmarks visible in this frame first \
         (or fit it), {0} so far"
    )]
    TooFewLabels(usize),
    #[error("the pose from the labels is degenerate: {0}")]
    Pose(String),
    #[error("landmark {0} is not tracked as visible in this frame")]
    NotVisible(usize),
    #[error("the head has no vertices")]
    NoVertices,
}

/// Estimates the frame's camera from the mapped landmarks (visible ones only) of `vertices`.
///
/// # Errors
/// Fewer than [`MIN_LABELS_FOR_POSE`] usable pairs; a degenerate (e.g. collinear) set.
pub fn pose_from_labels(
    vertices: &[Point3],
    map: &LandmarkMap,
    frame: &FrameLandmarks,
    image_height: Real,
) -> Result<OrthoPose, SuggestError> {
    let (image, model): (Vec<Point2>, Vec<Point3>) = map
        .pairs()
        .filter_map(|(l, v)| {
            let p = frame.points.get(l).filter(|p| p.visible)?;
            Some((Point2::new(p.x, p.y), *vertices.get(v)?))
        })
        .unzip();
    if image.len() < MIN_LABELS_FOR_POSE {
        return Err(SuggestError::TooFewLabels(image.len()));
    }
    let start = estimate_orthographic_pose(&image, &model, image_height)
        .map_err(|e| SuggestError::Pose(e.to_string()))?;
    Ok(refine_orthographic_pose(&start, &image, &model, None, image_height, 10))
}

/// The vertex whose projection lands on `target`: the nearest projection, and among those
/// within `tolerance_px` of the nearest, the one closest to the camera, so a lip point is
/// not given to the teeth or the back of the head that project to the same pixel.
pub fn vertex_at(
    vertices: &[Point3],
    pose: &OrthoPose,
    image_height: Real,
    target: Point2,
    tolerance_px: Real,
) -> Option<(usize, Real)> {
    let projected: Vec<(Real, Real)> = vertices
        .iter()
        .map(|v| {
            let d = (pose.project(v, image_height) - target).norm();
            // Camera space z grows towards the viewer (the model looks down +z).
            (d, (pose.r * v.coords).z)
        })
        .collect();
    let nearest = projected.iter().map(|p| p.0).filter(|d| d.is_finite()).reduce(Real::min)?;
    projected
        .iter()
        .enumerate()
        .filter(|(_, p)| p.0 <= nearest + tolerance_px)
        .max_by(|a, b| a.1.1.total_cmp(&b.1.1))
        .map(|(i, p)| (i, p.0))
}

/// Suggests a vertex for each landmark in `landmarks` that is visible in `frame`, seeing
/// `vertices` through `pose` (a fitted frame's; `None` estimates it from the labels already
/// in `map`). Landmarks not visible in the frame are skipped.
///
/// # Errors
/// As [`pose_from_labels`] when no pose is given; `NoVertices`.
pub fn suggest_labels(
    vertices: &[Point3],
    map: &LandmarkMap,
    frame: &FrameLandmarks,
    image_height: Real,
    pose: Option<OrthoPose>,
    landmarks: impl IntoIterator<Item = usize>,
) -> Result<Vec<LabelSuggestion>, SuggestError> {
    if vertices.is_empty() {
        return Err(SuggestError::NoVertices);
    }
    let pose = match pose {
        Some(p) => p,
        None => pose_from_labels(vertices, map, frame, image_height)?,
    };
    // Half a percent of the face's size in the image: below the landmarks' own noise, above
    // the spacing of lip vertices that overlap in projection.
    let tolerance = 0.005 * face_size_px(frame).max(100.0);
    Ok(landmarks
        .into_iter()
        .filter(|&l| l < N_LANDMARKS)
        .filter_map(|l| {
            let p = frame.points.get(l).filter(|p| p.visible)?;
            let (vertex, distance_px) =
                vertex_at(vertices, &pose, image_height, Point2::new(p.x, p.y), tolerance)?;
            Some(LabelSuggestion { landmark: l, vertex, distance_px })
        })
        .collect())
}

/// One landmark's suggestion, with the reason when there is none.
///
/// # Errors
/// As [`suggest_labels`]; `NotVisible` when the landmark is not tracked as visible.
pub fn suggest_label(
    vertices: &[Point3],
    map: &LandmarkMap,
    frame: &FrameLandmarks,
    image_height: Real,
    pose: Option<OrthoPose>,
    landmark: usize,
) -> Result<LabelSuggestion, SuggestError> {
    suggest_labels(vertices, map, frame, image_height, pose, [landmark])?
        .pop()
        .ok_or(SuggestError::NotVisible(landmark))
}

fn face_size_px(frame: &FrameLandmarks) -> Real {
    let pts: Vec<&crate::landmarks::LandmarkPoint> =
        frame.points.iter().filter(|p| p.visible).collect();
    let span = |f: fn(&crate::landmarks::LandmarkPoint) -> Real| {
        let (lo, hi) = pts
            .iter()
            .fold((Real::INFINITY, Real::NEG_INFINITY), |(lo, hi), p| (lo.min(f(p)), hi.max(f(p))));
        if hi >= lo { hi - lo } else { 0.0 }
    };
    span(|p| p.x).max(span(|p| p.y))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::camera::rotation_from_yaw_pitch_roll_deg;
    use crate::landmarks::LandmarkPoint;

    /// A bumpy grid "face" in front (z up to 1) and a back plane at z = -1 under it.
    fn head() -> Vec<Point3> {
        let mut v = Vec::new();
        for i in 0..21 {
            for j in 0..21 {
                let (x, y) = (i as f64 / 10.0 - 1.0, j as f64 / 10.0 - 1.0);
                v.push(Point3::new(x, y, 1.0 - 0.3 * (x * x + y * y)));
            }
        }
        for i in 0..21 {
            for j in 0..21 {
                v.push(Point3::new(i as f64 / 10.0 - 1.0, j as f64 / 10.0 - 1.0, -1.0));
            }
        }
        v
    }

    fn frame_seen_by(pose: &OrthoPose, vertices: &[Point3], truth: &[usize]) -> FrameLandmarks {
        let mut f = FrameLandmarks::new(0, vec![LandmarkPoint::missing(); N_LANDMARKS]);
        for (l, &v) in truth.iter().enumerate() {
            let p = pose.project(&vertices[v], 480.0);
            f.points[l] = LandmarkPoint::tracked(p.x, p.y);
        }
        f
    }

    #[test]
    fn five_labels_suggest_the_rest_and_prefer_the_front_surface() {
        let v = head();
        let pose = OrthoPose {
            r: rotation_from_yaw_pitch_roll_deg(20.0, -10.0, 5.0),
            s: 100.0,
            tx: 3.0,
            ty: 2.5,
        };
        // 68 landmarks on distinct front vertices.
        let truth: Vec<usize> = (0..N_LANDMARKS).map(|l| (l * 6) % 441).collect();
        let frame = frame_seen_by(&pose, &v, &truth);
        let mut map = LandmarkMap::default();
        for l in [0, 8, 16, 30, 48] {
            map.to_vertex.insert(l, truth[l]);
        }
        let s = suggest_labels(&v, &map, &frame, 480.0, None, 0..N_LANDMARKS).unwrap();
        assert_eq!(s.len(), N_LANDMARKS);
        for x in &s {
            assert_eq!(x.vertex, truth[x.landmark], "landmark {}", x.landmark);
            assert!(x.distance_px < 1e-6);
        }
        // A fitted pose given directly gives the same answer without any label.
        let one = suggest_label(&v, &LandmarkMap::default(), &frame, 480.0, Some(pose), 62);
        assert_eq!(one.unwrap().vertex, truth[62]);
    }

    #[test]
    fn too_few_labels_and_invisible_points_are_reported() {
        let v = head();
        let pose = OrthoPose { r: nalgebra::Matrix3::identity(), s: 100.0, tx: 2.0, ty: 2.0 };
        let truth: Vec<usize> = (0..N_LANDMARKS).collect();
        let mut frame = frame_seen_by(&pose, &v, &truth);
        let mut map = LandmarkMap::default();
        map.to_vertex.insert(0, 0);
        map.to_vertex.insert(1, 1);
        let e = suggest_label(&v, &map, &frame, 480.0, None, 5).unwrap_err();
        assert_eq!(e, SuggestError::TooFewLabels(2));
        frame.points[5].visible = false;
        let e = suggest_label(&v, &map, &frame, 480.0, Some(pose), 5).unwrap_err();
        assert_eq!(e, SuggestError::NotVisible(5));
        assert_eq!(
            suggest_label(&[], &map, &frame, 480.0, Some(pose), 6).unwrap_err(),
            SuggestError::NoVertices
        );
    }
}
