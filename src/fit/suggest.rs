//! Labelling suggestions: which mesh vertex an iBUG landmark most likely is, found by seeing
//! the head through a frame's camera and picking the vertex that lands on the tracked point.
//!
//! The camera is a fitted frame's pose when there is one, else a scaled orthographic pose
//! estimated from the landmarks already mapped, so a few hand labels suggest all the rest.

use super::camera::{OrthoPose, estimate_orthographic_pose, refine_orthographic_pose};
use crate::landmarks::{FrameLandmarks, N_LANDMARKS};
use crate::math::{Point2, Point3, Real, Vector2};
use crate::model::LandmarkMap;

/// Mapped and visible landmarks needed to estimate a pose (the affine camera has 8 unknowns).
pub const MIN_LABELS_FOR_POSE: usize = 4;

/// The head as suggestions see it: its vertices (as posed), the triangles that hide what
/// lies behind the surface, and which vertices may be labelled at all (`None`: all).
#[derive(Clone, Copy, Debug)]
pub struct SuggestHead<'a> {
    pub vertices: &'a [Point3],
    pub triangles: &'a [[u32; 3]],
    pub eligible: Option<&'a [bool]>,
}

impl<'a> SuggestHead<'a> {
    /// Every vertex eligible, nothing hidden.
    pub fn points(vertices: &'a [Point3]) -> Self {
        Self { vertices, triangles: &[], eligible: None }
    }
}

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
    // A fit's pose would do too, but it needs a map of at least as many landmarks: the
    // step that can be taken is labelling.
    #[error(
        "label at least {MIN_LABELS_FOR_POSE} landmarks visible in this frame by hand first, \
         {0} so far"
    )]
    TooFewLabels(usize),
    #[error("the pose from the labels is degenerate: {0}")]
    Pose(String),
    #[error("the head has no vertices")]
    NoVertices,
    #[error("the head has no faces to draw (a bare point set)")]
    NoSurface,
}

/// The triangles whose corners are all `kept` (when given): the head's surface for drawing
/// (its labelable vertices) or what hides a vertex from suggestions (see
/// [`crate::io::obj::occluding_vertices`]). A figure's helper shells (hair, clothing proxies)
/// sit in front of the skin; they must hide nothing.
pub fn surface_triangles(triangles: &[[u32; 3]], kept: Option<&[bool]>) -> Vec<[u32; 3]> {
    let ok = |v: u32| kept.is_none_or(|e| e.get(v as usize) == Some(&true));
    triangles.iter().copied().filter(|t| t.iter().all(|&v| ok(v))).collect()
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

/// Every vertex seen through `pose`: image position and depth (camera-space z, growing
/// towards the viewer: the model looks down +z).
fn project_all(vertices: &[Point3], pose: &OrthoPose, image_height: Real) -> Vec<(Point2, Real)> {
    vertices.iter().map(|v| (pose.project(v, image_height), (pose.r * v.coords).z)).collect()
}

/// Which vertices inside the image box `region` (min, max corners, px) the camera sees: a
/// vertex is hidden when a triangle not touching it covers its image position in front of
/// it. Exact per vertex (no depth-buffer resolution to blur silhouettes, where the jaw's
/// landmarks are), with triangles binned on a grid over the region. Vertices outside the
/// region are reported hidden. Without triangles every vertex in the region is visible.
pub fn visible_in_region(
    projected: &[(Point2, Real)],
    triangles: &[[u32; 3]],
    region: (Point2, Point2),
    depth_tolerance: Real,
) -> Vec<bool> {
    const CELL_PX: Real = 2.0;
    let (lo, hi) = region;
    let inside = |p: &Point2| p.x >= lo.x && p.x <= hi.x && p.y >= lo.y && p.y <= hi.y;
    let nx = (((hi.x - lo.x) / CELL_PX).ceil() as usize).clamp(1, 4096);
    let ny = (((hi.y - lo.y) / CELL_PX).ceil() as usize).clamp(1, 4096);
    let cell = |x: Real, y: Real| {
        let cx = (((x - lo.x) / CELL_PX).floor().max(0.0) as usize).min(nx - 1);
        let cy = (((y - lo.y) / CELL_PX).floor().max(0.0) as usize).min(ny - 1);
        (cx, cy)
    };
    let mut bins: Vec<Vec<u32>> = vec![Vec::new(); nx * ny];
    for (t, tri) in triangles.iter().enumerate() {
        let Some(p) = tri.iter().map(|&i| projected.get(i as usize)).collect::<Option<Vec<_>>>()
        else {
            continue;
        };
        let (x0, x1) = (
            p.iter().map(|q| q.0.x).fold(Real::INFINITY, Real::min),
            p.iter().map(|q| q.0.x).fold(Real::NEG_INFINITY, Real::max),
        );
        let (y0, y1) = (
            p.iter().map(|q| q.0.y).fold(Real::INFINITY, Real::min),
            p.iter().map(|q| q.0.y).fold(Real::NEG_INFINITY, Real::max),
        );
        if !(x0.is_finite() && y0.is_finite() && x1.is_finite() && y1.is_finite())
            || x1 < lo.x
            || x0 > hi.x
            || y1 < lo.y
            || y0 > hi.y
        {
            continue;
        }
        let ((a, b), (c, d)) = (cell(x0, y0), cell(x1, y1));
        for cy in b..=d {
            for cx in a..=c {
                bins[cy * nx + cx].push(t as u32);
            }
        }
    }
    projected
        .iter()
        .enumerate()
        .map(|(v, (p, z))| {
            if !inside(p) {
                return false;
            }
            let (cx, cy) = cell(p.x, p.y);
            !bins[cy * nx + cx].iter().any(|&t| {
                let tri = triangles[t as usize];
                if tri.contains(&(v as u32)) {
                    return false;
                }
                let [a, b, c] = tri.map(|i| projected[i as usize]);
                let det = (b.0.y - c.0.y) * (a.0.x - c.0.x) + (c.0.x - b.0.x) * (a.0.y - c.0.y);
                if det.abs() < 1e-12 {
                    return false;
                }
                let l1 = ((b.0.y - c.0.y) * (p.x - c.0.x) + (c.0.x - b.0.x) * (p.y - c.0.y)) / det;
                let l2 = ((c.0.y - a.0.y) * (p.x - c.0.x) + (a.0.x - c.0.x) * (p.y - c.0.y)) / det;
                let l3 = 1.0 - l1 - l2;
                // Edges count: a point behind the seam of two front triangles is hidden too.
                let covers = l1 >= -1e-9 && l2 >= -1e-9 && l3 >= -1e-9;
                covers && l1 * a.1 + l2 * b.1 + l3 * c.1 > z + depth_tolerance
            })
        })
        .collect()
}

/// The visible vertex whose projection lands on `target`: the nearest projection, and among
/// those within `tolerance_px` of the nearest, the one closest to the camera.
fn vertex_at(
    projected: &[(Point2, Real)],
    visible: &[bool],
    target: Point2,
    tolerance_px: Real,
) -> Option<(usize, Real)> {
    let dist: Vec<Option<Real>> = projected
        .iter()
        .zip(visible)
        .map(|((p, _), &vis)| vis.then(|| (p - target).norm()).filter(|d| d.is_finite()))
        .collect();
    let nearest = dist.iter().flatten().copied().reduce(Real::min)?;
    dist.iter()
        .enumerate()
        .filter_map(|(i, d)| d.filter(|&d| d <= nearest + tolerance_px).map(|d| (i, d)))
        .max_by(|a, b| projected[a.0].1.total_cmp(&projected[b.0].1))
}

/// The head seen through a frame's camera: every vertex's image position and depth, which
/// vertices are visible (and eligible), and the face's size in the image (px, at least 100).
pub(super) struct SeenHead {
    pub projected: Vec<(Point2, Real)>,
    pub visible: Vec<bool>,
    pub face_px: Real,
}

/// Sees `head` through `pose`: only the face's surroundings matter, and a tenth of a model
/// unit's worth of pixels in depth separates a surface from what lies behind it.
pub(super) fn see_head(
    head: &SuggestHead,
    frame: &FrameLandmarks,
    pose: &OrthoPose,
    image_height: Real,
) -> SeenHead {
    let face_px = face_size_px(frame).max(100.0);
    let projected = project_all(head.vertices, pose, image_height);
    let (lo, hi) = landmark_box(frame);
    let margin = 0.25 * face_px;
    let region = (lo - Vector2::repeat(margin), hi + Vector2::repeat(margin));
    let mut visible =
        visible_in_region(&projected, head.triangles, region, 0.1 / pose.s.max(1e-12));
    if let Some(eligible) = head.eligible {
        for (v, e) in visible.iter_mut().zip(eligible.iter().chain(std::iter::repeat(&false))) {
            *v &= *e;
        }
    }
    SeenHead { projected, visible, face_px }
}

/// Suggests a vertex for each landmark in `landmarks` that is visible in `frame`, seeing
/// `vertices` (with their `triangles`, which hide what lies behind the surface: teeth,
/// tongue, helper and joint geometry inside a figure) through `pose` (a fitted frame's;
/// `None` estimates it from the labels already in `map`). Landmarks not visible in the frame
/// are skipped.
///
/// # Errors
/// As [`pose_from_labels`] when no pose is given; `NoVertices`.
pub fn suggest_labels(
    head: &SuggestHead,
    map: &LandmarkMap,
    frame: &FrameLandmarks,
    image_height: Real,
    pose: Option<OrthoPose>,
    landmarks: impl IntoIterator<Item = usize>,
) -> Result<Vec<LabelSuggestion>, SuggestError> {
    let vertices = head.vertices;
    if vertices.is_empty() {
        return Err(SuggestError::NoVertices);
    }
    let pose = match pose {
        Some(p) => p,
        None => pose_from_labels(vertices, map, frame, image_height)?,
    };
    let seen = see_head(head, frame, &pose, image_height);
    // Half a percent of the face's size in the image: below the landmarks' own noise, above
    // the spacing of lip vertices that overlap in projection.
    let tolerance = 0.005 * seen.face_px;
    let (projected, visible) = (&seen.projected, &seen.visible);
    Ok(landmarks
        .into_iter()
        .filter(|&l| l < N_LANDMARKS)
        .filter_map(|l| {
            let p = frame.points.get(l).filter(|p| p.visible)?;
            let (vertex, distance_px) =
                vertex_at(projected, visible, Point2::new(p.x, p.y), tolerance)?;
            Some(LabelSuggestion { landmark: l, vertex, distance_px })
        })
        .collect())
}

/// The box (min, max corners, px) of the frame's visible points.
fn landmark_box(frame: &FrameLandmarks) -> (Point2, Point2) {
    frame.points.iter().filter(|p| p.visible).fold(
        (
            Point2::new(Real::INFINITY, Real::INFINITY),
            Point2::new(Real::NEG_INFINITY, Real::NEG_INFINITY),
        ),
        |(lo, hi), p| {
            (Point2::new(lo.x.min(p.x), lo.y.min(p.y)), Point2::new(hi.x.max(p.x), hi.y.max(p.y)))
        },
    )
}

pub(super) fn face_size_px(frame: &FrameLandmarks) -> Real {
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

    /// One landmark's suggestion (`None` when it is not tracked as visible).
    fn suggest_label(
        head: &SuggestHead,
        map: &LandmarkMap,
        frame: &FrameLandmarks,
        image_height: Real,
        pose: Option<OrthoPose>,
        landmark: usize,
    ) -> Result<Option<LabelSuggestion>, SuggestError> {
        Ok(suggest_labels(head, map, frame, image_height, pose, [landmark])?.pop())
    }

    /// Two triangles per grid square of a 21 × 21 vertex grid starting at vertex `first`.
    fn grid_triangles(first: u32) -> Vec<[u32; 3]> {
        let at = |i: u32, j: u32| first + i * 21 + j;
        (0..20)
            .flat_map(|i| (0..20).map(move |j| (i, j)))
            .flat_map(|(i, j)| {
                [
                    [at(i, j), at(i + 1, j), at(i + 1, j + 1)],
                    [at(i, j), at(i + 1, j + 1), at(i, j + 1)],
                ]
            })
            .collect()
    }

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
        let s = suggest_labels(&SuggestHead::points(&v), &map, &frame, 480.0, None, 0..N_LANDMARKS)
            .unwrap();
        assert_eq!(s.len(), N_LANDMARKS);
        for x in &s {
            assert_eq!(x.vertex, truth[x.landmark], "landmark {}", x.landmark);
            assert!(x.distance_px < 1e-6);
        }
        // A fitted pose given directly gives the same answer without any label.
        let one = suggest_label(
            &SuggestHead::points(&v),
            &LandmarkMap::default(),
            &frame,
            480.0,
            Some(pose),
            62,
        );
        assert_eq!(one.unwrap().unwrap().vertex, truth[62]);
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
        let e = suggest_label(&SuggestHead::points(&v), &map, &frame, 480.0, None, 5).unwrap_err();
        assert_eq!(e, SuggestError::TooFewLabels(2));
        frame.points[5].visible = false;
        let none = suggest_label(&SuggestHead::points(&v), &map, &frame, 480.0, Some(pose), 5);
        assert_eq!(none, Ok(None), "a landmark not tracked as visible gets no suggestion");
        assert_eq!(
            suggest_label(&SuggestHead::points(&[]), &map, &frame, 480.0, Some(pose), 6)
                .unwrap_err(),
            SuggestError::NoVertices
        );
    }

    #[test]
    fn geometry_behind_the_surface_is_never_suggested() {
        // A "joint" vertex inside the head, under the surface, lands exactly on the tracked
        // point; the nearest surface vertices are 5 px away.
        let mut v = head();
        let joint = v.len();
        v.push(Point3::new(0.05, 0.05, 0.0));
        let tris: Vec<[u32; 3]> =
            grid_triangles(0).into_iter().chain(grid_triangles(441)).collect();
        let pose = OrthoPose { r: nalgebra::Matrix3::identity(), s: 100.0, tx: 2.0, ty: 2.0 };
        let mut frame = FrameLandmarks::new(0, vec![LandmarkPoint::missing(); N_LANDMARKS]);
        let p = pose.project(&v[joint], 480.0);
        frame.points[62] = LandmarkPoint::tracked(p.x, p.y);
        let map = LandmarkMap::default();
        let blind = suggest_label(&SuggestHead::points(&v), &map, &frame, 480.0, Some(pose), 62)
            .unwrap()
            .unwrap();
        assert_eq!(blind.vertex, joint, "without faces nothing hides it");
        let head = SuggestHead { vertices: &v, triangles: &tris, eligible: None };
        let seen = suggest_label(&head, &map, &frame, 480.0, Some(pose), 62).unwrap().unwrap();
        assert!(seen.vertex < 441, "a front-surface vertex: {seen:?}");
        assert!((seen.distance_px - 5.0 * 2f64.sqrt()).abs() < 1e-6, "{seen:?}");
        // A vertex that may not be labelled (a helper shell) is skipped like a hidden one.
        let mut eligible = vec![true; v.len()];
        eligible[seen.vertex] = false;
        let head = SuggestHead { eligible: Some(&eligible), ..head };
        let other = suggest_label(&head, &map, &frame, 480.0, Some(pose), 62).unwrap().unwrap();
        assert!(other.vertex != seen.vertex && other.vertex < 441, "{other:?}");
    }
}
