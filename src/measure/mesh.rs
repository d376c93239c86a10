//! W, H and protrusion P of a fitted mesh, taken exactly from its mapped landmark vertices in
//! model space (y up, face looking along +z, pose removed), with no re-tracking of a render.
//!
//! W and H use the same definitions as the video (see `mouth`): by default on the frontal
//! projection (x, y) of the vertices, which is what a frontal orthographic camera sees, so
//! the two are directly comparable. P is the distance along +z from a reference plane
//! parallel to the frontal plane (z = const) to the foremost upper-lip vertex, divided by the
//! 3D length |nasion(27) − nose tip(30)|. Shapes from elsewhere (a posed export) can be
//! brought into model space first with [`remove_rigid_pose`].

use super::{MeasureError, MouthMeasures, Trajectory, mouth};
use crate::landmarks::N_LANDMARKS;
use crate::landmarks::ibug::point::{
    INNER_LIP_LEFT, INNER_LIP_RIGHT, LEFT_ENDOCANTHION, NASION, NOSE_TIP, RIGHT_ENDOCANTHION,
    STOMION_LOWER, STOMION_UPPER, SUBNASALE,
};
use crate::math::{DVector, Matrix3, Point2, Point3, Vector3};
use crate::model::LandmarkMap;
use serde::{Deserialize, Serialize};

/// The plane, parallel to the frontal (x–y) plane, from which protrusion is measured.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum ReferencePlane {
    /// Through the mean z of the inner eye corners (39, 42). The default: no articulation and
    /// no blendshape of the lips moves the eye corners, so P changes only when the lip moves,
    /// and it is the same anchor as the W/H reference length.
    #[default]
    InnerEyeCorners,
    /// Through the subnasale (33): close to the lips, as a profile "Sn vertical" is, but an
    /// expression model may move it slightly with the upper lip.
    Subnasale,
    /// Through a given 0-based iBUG landmark's vertex.
    Landmark(usize),
    /// A fixed z in model units (e.g. a neutral pose's value kept for a whole clip).
    FixedZ(f64),
}

/// Which vertices count as the upper lip when looking for the foremost one.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum UpperLip {
    /// The mapped vertices of the upper-lip landmarks: outer 48..=54 and inner 60..=64
    /// (unmapped ones are skipped). The default, usable with any landmark map.
    #[default]
    MappedLandmarks,
    /// A caller-given vertex set (0-based vertex indices), e.g. the whole upper-lip region of
    /// a head, which finds the true foremost point between landmark vertices.
    Vertices(Vec<usize>),
    /// The whole upper lip of any head, found from its landmark map: the front-surface
    /// vertices whose frontal (x, y) lie inside the band outlined by the mapped upper-lip
    /// landmarks (see [`upper_lip_region`]). This is what a profile silhouette shows, so use
    /// it when the head's P is compared with P from a side view. Resolve it once per model
    /// with [`MeshMeasureOptions::with_region_resolved`] (the region of the neutral shape);
    /// left unresolved, each measured shape finds its own region (slower, and the region
    /// then moves with the lips).
    Region,
}

/// How W and H are measured between two vertices.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum MeshDistance {
    /// On the frontal projection (x, y), as a frontal orthographic video sees it (default).
    #[default]
    Frontal,
    /// Full 3D Euclidean distance.
    Euclidean,
}

/// Options of the mesh measures; the defaults are documented on each field's type.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize, Default)]
pub struct MeshMeasureOptions {
    #[serde(default)]
    pub reference: ReferencePlane,
    #[serde(default)]
    pub upper_lip: UpperLip,
    #[serde(default)]
    pub distance: MeshDistance,
}

/// Upper-lip landmarks used by [`UpperLip::MappedLandmarks`].
pub const UPPER_LIP_LANDMARKS: [usize; 12] = [48, 49, 50, 51, 52, 53, 54, 60, 61, 62, 63, 64];

/// The upper-lip band as a closed polygon of landmarks: the outer upper lip from the right
/// corner (48) over the Cupid's bow to the left corner (54), then the inner upper lip back
/// from 64 to 60.
pub const UPPER_LIP_BAND: [usize; 12] = [48, 49, 50, 51, 52, 53, 54, 64, 63, 62, 61, 60];

/// How far behind the band's rearmost landmark vertex (in |nasion − nose tip| lengths) a
/// vertex may lie and still count as lip surface: the vermilion curves back less than this
/// between its landmarks, while the back of a head, eyeballs behind the face or a mouth
/// interior deeper than this are left out (they could never be the foremost point anyway,
/// but a smaller set is cheaper per frame).
const REGION_DEPTH: f64 = 0.25;

/// Whether `p` lies inside the closed polygon `poly` (even–odd rule; points exactly on an
/// edge count as inside).
fn inside_polygon(p: Point2, poly: &[Point2]) -> bool {
    let mut inside = false;
    let n = poly.len();
    for i in 0..n {
        let (a, b) = (poly[i], poly[(i + n - 1) % n]);
        // On the edge a–b: collinear and between the ends.
        let cross = (b - a).perp(&(p - a));
        let dot = (p - a).dot(&(p - b));
        if cross.abs() <= 1e-12 * (b - a).norm_squared().max(1e-300) && dot <= 0.0 {
            return true;
        }
        if (a.y > p.y) != (b.y > p.y) {
            let x = a.x + (p.y - a.y) * (b.x - a.x) / (b.y - a.y);
            if p.x < x {
                inside = !inside;
            }
        }
    }
    inside
}

/// The whole upper lip of `shape` (flat, model space: y up, face along +z) through `map`:
/// the vertices whose frontal projection (x, y) falls inside the band outlined by the mapped
/// upper-lip landmarks ([`UPPER_LIP_BAND`]; unmapped ones are skipped, at least 3 needed),
/// no deeper than a quarter nose length behind the band's rearmost landmark vertex, plus the
/// mapped upper-lip landmark vertices themselves. Ascending vertex order.
///
/// Give it the model's mean (neutral) shape once and use the result per frame
/// ([`MeshMeasureOptions::with_region_resolved`]): the lip's vertices stay the lip's.
///
/// # Errors
/// `MissingLandmark` when fewer than 3 band landmarks, or nasion/nose tip, are mapped;
/// `VertexOutOfRange`, `NonFinite`, `BadShapeLength`.
pub fn upper_lip_region(shape: &DVector, map: &LandmarkMap) -> Result<Vec<usize>, MeasureError> {
    check_shape(shape)?;
    let mut poly = Vec::with_capacity(UPPER_LIP_BAND.len());
    let mut rear = f64::INFINITY;
    let mut own = Vec::new();
    for &l in &UPPER_LIP_BAND {
        let Some(v) = map.vertex(l) else { continue };
        let p = vertex_of(shape, v, l)?;
        poly.push(Point2::new(p.x, p.y));
        rear = rear.min(p.z);
        own.push(v);
    }
    if poly.len() < 3 {
        let missing = UPPER_LIP_BAND.iter().copied().find(|&l| map.vertex(l).is_none());
        return Err(MeasureError::MissingLandmark(missing.unwrap_or(UPPER_LIP_BAND[0])));
    }
    let length =
        (landmark_vertex(shape, map, NASION)? - landmark_vertex(shape, map, NOSE_TIP)?).norm();
    if !length.is_finite() || length <= 1e-12 {
        return Err(MeasureError::DegenerateReference(length));
    }
    let z_min = rear - REGION_DEPTH * length;
    let (lo, hi) = poly.iter().fold(
        (
            Point2::new(f64::INFINITY, f64::INFINITY),
            Point2::new(f64::NEG_INFINITY, f64::NEG_INFINITY),
        ),
        |(lo, hi), p| {
            (Point2::new(lo.x.min(p.x), lo.y.min(p.y)), Point2::new(hi.x.max(p.x), hi.y.max(p.y)))
        },
    );
    let mut region: Vec<usize> = (0..shape.len() / 3)
        .filter(|&v| {
            let (x, y, z) = (shape[3 * v], shape[3 * v + 1], shape[3 * v + 2]);
            let q = Point2::new(x, y);
            z >= z_min
                && (lo.x..=hi.x).contains(&x)
                && (lo.y..=hi.y).contains(&y)
                && inside_polygon(q, &poly)
        })
        .collect();
    region.extend(own);
    region.sort_unstable();
    region.dedup();
    Ok(region)
}

/// Vertex `v` of a flat `x0 y0 z0 x1 …` shape.
///
/// # Errors
/// `VertexOutOfRange` (reported with landmark `usize::MAX` when not a landmark),
/// `NonFinite`.
pub fn vertex(shape: &DVector, v: usize) -> Result<Point3, MeasureError> {
    vertex_of(shape, v, usize::MAX)
}

fn vertex_of(shape: &DVector, v: usize, landmark: usize) -> Result<Point3, MeasureError> {
    let n = shape.len() / 3;
    if v >= n {
        return Err(MeasureError::VertexOutOfRange { landmark, vertex: v, n_vertices: n });
    }
    let p = Point3::new(shape[3 * v], shape[3 * v + 1], shape[3 * v + 2]);
    if p.coords.iter().all(|c| c.is_finite()) { Ok(p) } else { Err(MeasureError::NonFinite) }
}

/// The model-space position of landmark `landmark` (0-based iBUG) through `map`.
///
/// # Errors
/// `MissingLandmark` when unmapped, `VertexOutOfRange`, `NonFinite`.
pub fn landmark_vertex(
    shape: &DVector,
    map: &LandmarkMap,
    landmark: usize,
) -> Result<Point3, MeasureError> {
    let v = map.vertex(landmark).ok_or(MeasureError::MissingLandmark(landmark))?;
    vertex_of(shape, v, landmark)
}

/// All 68 landmark positions of a shape, `None` where unmapped or invalid.
pub fn landmark_points_3d(shape: &DVector, map: &LandmarkMap) -> Vec<Option<Point3>> {
    (0..N_LANDMARKS).map(|i| landmark_vertex(shape, map, i).ok()).collect()
}

/// The frontal orthographic projection (x, y) of the 68 landmark vertices, in model units
/// with y up: what the facial indices and the 2D measures take for a head.
pub fn frontal_landmarks(shape: &DVector, map: &LandmarkMap) -> Vec<Option<Point2>> {
    landmark_points_3d(shape, map).into_iter().map(|p| p.map(|p| Point2::new(p.x, p.y))).collect()
}

fn check_shape(shape: &DVector) -> Result<(), MeasureError> {
    if shape.len().is_multiple_of(3) {
        Ok(())
    } else {
        Err(MeasureError::BadShapeLength(shape.len()))
    }
}

/// The z of the reference plane for `shape`.
///
/// # Errors
/// As [`landmark_vertex`] for the landmarks the plane needs; `NonFinite` for a NaN `FixedZ`.
pub fn reference_plane_z(
    shape: &DVector,
    map: &LandmarkMap,
    plane: &ReferencePlane,
) -> Result<f64, MeasureError> {
    let z = match plane {
        ReferencePlane::InnerEyeCorners => {
            let a = landmark_vertex(shape, map, RIGHT_ENDOCANTHION)?;
            let b = landmark_vertex(shape, map, LEFT_ENDOCANTHION)?;
            0.5 * (a.z + b.z)
        }
        ReferencePlane::Subnasale => landmark_vertex(shape, map, SUBNASALE)?.z,
        ReferencePlane::Landmark(i) => landmark_vertex(shape, map, *i)?.z,
        ReferencePlane::FixedZ(z) => *z,
    };
    if z.is_finite() { Ok(z) } else { Err(MeasureError::NonFinite) }
}

/// Protrusion P: (z of the foremost upper-lip vertex − reference-plane z) / |v27 − v30|.
/// Positive when the lip is in front of the plane.
///
/// # Errors
/// `MissingLandmark` for unmapped 27/30 or plane landmarks, `NoUpperLip` when no upper-lip
/// vertex is available, `DegenerateReference` when nasion and nose tip coincide,
/// `VertexOutOfRange`, `NonFinite`, `BadShapeLength`.
pub fn protrusion(
    shape: &DVector,
    map: &LandmarkMap,
    options: &MeshMeasureOptions,
) -> Result<f64, MeasureError> {
    check_shape(shape)?;
    let z_ref = reference_plane_z(shape, map, &options.reference)?;
    let foremost = match &options.upper_lip {
        UpperLip::MappedLandmarks => {
            let mut best: Option<f64> = None;
            for &l in &UPPER_LIP_LANDMARKS {
                let Some(v) = map.vertex(l) else { continue };
                let z = vertex_of(shape, v, l)?.z;
                best = Some(best.map_or(z, |b| b.max(z)));
            }
            best
        }
        UpperLip::Vertices(vs) => foremost_z(shape, vs)?,
        UpperLip::Region => foremost_z(shape, &upper_lip_region(shape, map)?)?,
    }
    .ok_or(MeasureError::NoUpperLip)?;
    let length =
        (landmark_vertex(shape, map, NASION)? - landmark_vertex(shape, map, NOSE_TIP)?).norm();
    if !length.is_finite() || length <= 1e-12 {
        return Err(MeasureError::DegenerateReference(length));
    }
    Ok((foremost - z_ref) / length)
}

/// The largest z among vertices `vs` of `shape` (`None` for an empty set).
fn foremost_z(shape: &DVector, vs: &[usize]) -> Result<Option<f64>, MeasureError> {
    let mut best: Option<f64> = None;
    for &v in vs {
        let z = vertex(shape, v)?.z;
        best = Some(best.map_or(z, |b| b.max(z)));
    }
    Ok(best)
}

impl MeshMeasureOptions {
    /// These options with [`UpperLip::Region`] replaced by the region of `neutral` (e.g. the
    /// model's mean shape), so every frame measures the same vertices; other choices are
    /// returned unchanged.
    ///
    /// # Errors
    /// As [`upper_lip_region`].
    pub fn with_region_resolved(
        &self,
        neutral: &DVector,
        map: &LandmarkMap,
    ) -> Result<MeshMeasureOptions, MeasureError> {
        let mut out = self.clone();
        if out.upper_lip == UpperLip::Region {
            out.upper_lip = UpperLip::Vertices(upper_lip_region(neutral, map)?);
        }
        Ok(out)
    }
}

/// W, H and P of one model-space shape (flat `x0 y0 z0 …`) through a landmark map.
///
/// W and H are exactly the 2D definitions applied to the landmark vertices (frontal
/// projection by default, or 3D distances with [`MeshDistance::Euclidean`]).
///
/// # Errors
/// Any error of W/H (missing or degenerate landmarks) or of [`protrusion`].
pub fn measure_shape(
    shape: &DVector,
    map: &LandmarkMap,
    options: &MeshMeasureOptions,
) -> Result<MouthMeasures, MeasureError> {
    check_shape(shape)?;
    let (w, h) = match options.distance {
        MeshDistance::Frontal => {
            // Only the points W and H use, with their own errors (an out-of-range vertex
            // must not read as merely "missing").
            let mut pts = vec![None; N_LANDMARKS];
            for i in [
                RIGHT_ENDOCANTHION,
                LEFT_ENDOCANTHION,
                NOSE_TIP,
                INNER_LIP_RIGHT,
                INNER_LIP_LEFT,
                STOMION_UPPER,
                STOMION_LOWER,
            ] {
                let p = landmark_vertex(shape, map, i)?;
                pts[i] = Some(Point2::new(p.x, p.y));
            }
            let m = mouth::measure_points(&pts)?;
            (m.w, m.h)
        }
        MeshDistance::Euclidean => {
            let v = |i| landmark_vertex(shape, map, i);
            let eye_mid = nalgebra::center(&v(RIGHT_ENDOCANTHION)?, &v(LEFT_ENDOCANTHION)?);
            let reference = (eye_mid - v(NOSE_TIP)?).norm();
            if reference.is_nan() || reference <= 1e-12 {
                return Err(MeasureError::DegenerateReference(reference));
            }
            let w = (v(INNER_LIP_RIGHT)? - v(INNER_LIP_LEFT)?).norm();
            let h = (v(STOMION_UPPER)? - v(STOMION_LOWER)?).norm();
            (w / reference, h / reference)
        }
    };
    let p = protrusion(shape, map, options)?;
    Ok(MouthMeasures { w, h, p: Some(p) })
}

/// W, H, P trajectories of a sequence of shapes (frame i = item i); `None` shapes (failed
/// fits) and shapes whose measure fails give `None` frames.
pub fn trajectory_from_shapes<'a, I>(
    shapes: I,
    map: &LandmarkMap,
    options: &MeshMeasureOptions,
) -> Trajectory
where
    I: IntoIterator<Item = Option<&'a DVector>>,
{
    let frames: Vec<Option<MouthMeasures>> =
        shapes.into_iter().map(|s| s.and_then(|s| measure_shape(s, map, options).ok())).collect();
    Trajectory::from_frames(&frames)
}

/// Rigidly aligns `shape` onto `reference` (both flat, same topology) using the listed
/// vertices, and returns the whole shape moved by that rotation and translation (no scale):
/// Kabsch's least-squares rotation (Kabsch 1976; SVD of the cross-covariance, with the
/// reflection case fixed by flipping the smallest singular direction).
///
/// Use it to bring a posed mesh back into model space before measuring P; choose vertices
/// that articulation does not move (eye corners, nose bridge, brows).
///
/// # Errors
/// `BadShapeLength` for mismatched or non-multiple-of-3 lengths, `VertexOutOfRange`,
/// `NonFinite`, and `DegenerateReference(rank)` when fewer than three non-collinear
/// vertices are given (the rotation is then undetermined).
pub fn remove_rigid_pose(
    shape: &DVector,
    reference: &DVector,
    vertices: &[usize],
) -> Result<DVector, MeasureError> {
    check_shape(shape)?;
    if shape.len() != reference.len() {
        return Err(MeasureError::BadShapeLength(shape.len()));
    }
    let src: Vec<Point3> = vertices.iter().map(|&v| vertex(shape, v)).collect::<Result<_, _>>()?;
    let dst: Vec<Point3> =
        vertices.iter().map(|&v| vertex(reference, v)).collect::<Result<_, _>>()?;
    if src.len() < 3 {
        return Err(MeasureError::DegenerateReference(src.len() as f64));
    }
    let n = src.len() as f64;
    let cs = src.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / n;
    let cd = dst.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / n;
    let mut cov = Matrix3::zeros();
    for (s, d) in src.iter().zip(&dst) {
        cov += (d.coords - cd) * (s.coords - cs).transpose();
    }
    let svd = cov.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err(MeasureError::NonFinite);
    };
    // Rank < 2 means collinear (or coincident) points: any rotation about the line fits.
    let sv = svd.singular_values;
    let scale = sv.max().max(1e-300);
    if sv.iter().filter(|&&s| s > 1e-10 * scale).count() < 2 {
        return Err(MeasureError::DegenerateReference(sv.min()));
    }
    let d = (u * v_t).determinant().signum();
    let rotation = u * Matrix3::from_diagonal(&Vector3::new(1.0, 1.0, d)) * v_t;
    let translation = cd - rotation * cs;
    let mut out = shape.clone();
    for k in 0..shape.len() / 3 {
        let p =
            rotation * Vector3::new(shape[3 * k], shape[3 * k + 1], shape[3 * k + 2]) + translation;
        out.fixed_rows_mut::<3>(3 * k).copy_from(&p);
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// A 68-vertex head where vertex i is landmark i, plus 2 extra lip vertices (68, 69).
    fn head() -> (DVector, LandmarkMap) {
        let mut v = vec![[0.0f64; 3]; 70];
        for (i, p) in v.iter_mut().enumerate() {
            // Spread the unused points on a curved surface so nothing is degenerate.
            let a = i as f64 * 0.37;
            *p = [40.0 * a.cos(), 40.0 * a.sin(), 5.0 + (i % 7) as f64];
        }
        v[27] = [0.0, 35.0, 12.0];
        v[30] = [0.0, 0.0, 30.0];
        v[33] = [0.0, -6.0, 22.0];
        v[39] = [-15.0, 30.0, 9.0];
        v[42] = [15.0, 30.0, 11.0];
        v[48] = [-25.0, -30.0, 12.0];
        v[51] = [0.0, -21.0, 24.0];
        v[54] = [25.0, -30.0, 12.0];
        v[60] = [-20.0, -30.0, 15.0];
        v[62] = [0.0, -27.0, 21.0];
        v[64] = [20.0, -30.0, 15.0];
        v[66] = [0.0, -33.0, 20.0];
        for (i, z) in [(49, 18.0), (50, 22.0), (52, 22.0), (53, 18.0), (61, 19.0), (63, 19.0)] {
            v[i][2] = z;
        }
        v[68] = [1.0, -22.0, 26.5];
        v[69] = [-1.0, -22.0, 25.0];
        let flat = DVector::from_iterator(210, v.iter().flatten().copied());
        let map = LandmarkMap { to_vertex: (0..68).map(|i| (i, i)).collect() };
        (flat, map)
    }

    #[test]
    fn hand_computed_w_h_p() {
        let (s, map) = head();
        let m = measure_shape(&s, &map, &MeshMeasureOptions::default()).unwrap();
        // Frontal reference: mid(39,42) = (0, 30) vs nose tip (0, 0): 30.
        assert!((m.w - 40.0 / 30.0).abs() < 1e-12);
        assert!((m.h - 6.0 / 30.0).abs() < 1e-12);
        // Plane z = (9 + 11)/2 = 10; foremost upper lip 51 at z 24; |v27 − v30| = √(35² + 18²).
        let len = (35.0f64 * 35.0 + 18.0 * 18.0).sqrt();
        assert!((m.p.unwrap() - 14.0 / len).abs() < 1e-12);

        let e = MeshMeasureOptions { distance: MeshDistance::Euclidean, ..Default::default() };
        let m = measure_shape(&s, &map, &e).unwrap();
        let reference = (900.0f64 + 400.0).sqrt(); // (0,30,10) − (0,0,30)
        assert!((m.w - 40.0 / reference).abs() < 1e-12);
        assert!((m.h - 37.0f64.sqrt() / reference).abs() < 1e-12);
    }

    #[test]
    fn plane_and_vertex_set_choices() {
        let (s, map) = head();
        let len = (35.0f64 * 35.0 + 18.0 * 18.0).sqrt();
        let sub = MeshMeasureOptions { reference: ReferencePlane::Subnasale, ..Default::default() };
        assert!((protrusion(&s, &map, &sub).unwrap() - 2.0 / len).abs() < 1e-12);
        let fixed =
            MeshMeasureOptions { reference: ReferencePlane::FixedZ(0.0), ..Default::default() };
        assert!((protrusion(&s, &map, &fixed).unwrap() - 24.0 / len).abs() < 1e-12);
        let set = MeshMeasureOptions {
            upper_lip: UpperLip::Vertices(vec![68, 69, 51]),
            ..Default::default()
        };
        assert!((protrusion(&s, &map, &set).unwrap() - 16.5 / len).abs() < 1e-12);
    }

    /// `head()` with its upper-lip band laid out as a real one: outer 48..54 along an arch,
    /// inner 60..64 along a flatter one below, vertex 68 inside the band (in front of every
    /// landmark), 69 below the band (further forward still, but lower lip), and vertex 0 in
    /// the band's (x, y) but far behind the face (the back of a head).
    fn head_with_band() -> (DVector, LandmarkMap) {
        let (mut s, map) = head();
        let mut set = |v: usize, p: [f64; 3]| s.fixed_rows_mut::<3>(3 * v).copy_from_slice(&p);
        for (k, l) in (48..=54).enumerate() {
            let x = -24.0 + 8.0 * k as f64;
            set(l, [x, -20.0 - 0.01 * x * x, 20.0 - 0.01 * x * x]);
        }
        for (k, l) in (60..=64).enumerate() {
            let x = -20.0 + 10.0 * k as f64;
            set(l, [x, -26.0 - 0.005 * x * x, 19.0 - 0.01 * x * x]);
        }
        set(68, [1.0, -23.0, 26.5]);
        set(69, [0.0, -29.0, 30.0]);
        set(0, [0.0, -23.0, -80.0]);
        (s, map)
    }

    #[test]
    fn region_is_the_band_between_outer_and_inner_upper_lip() {
        let (s, map) = head_with_band();
        let region = upper_lip_region(&s, &map).unwrap();
        assert!(region.contains(&68), "{region:?}");
        assert!(!region.contains(&69) && !region.contains(&0), "{region:?}");
        for l in UPPER_LIP_LANDMARKS {
            assert!(region.contains(&l));
        }
        let len = (35.0f64 * 35.0 + 18.0 * 18.0).sqrt();
        let opts = MeshMeasureOptions { upper_lip: UpperLip::Region, ..Default::default() };
        // Plane z 10; the foremost region vertex is 68 at z 26.5, ahead of every landmark.
        assert!((protrusion(&s, &map, &opts).unwrap() - 16.5 / len).abs() < 1e-12);
        let resolved = opts.with_region_resolved(&s, &map).unwrap();
        assert_eq!(resolved.upper_lip, UpperLip::Vertices(region));
        assert!((protrusion(&s, &map, &resolved).unwrap() - 16.5 / len).abs() < 1e-12);
        let landmarks = protrusion(&s, &map, &MeshMeasureOptions::default()).unwrap();
        assert!((landmarks - 10.0 / len).abs() < 1e-12, "{landmarks}");
        // Other choices pass through unchanged.
        let plain = MeshMeasureOptions::default();
        assert_eq!(plain.with_region_resolved(&s, &map).unwrap(), plain);
    }

    #[test]
    fn region_needs_a_band() {
        let (s, mut map) = head_with_band();
        for l in [48, 49, 50, 51, 52, 53, 54, 60, 61, 62] {
            map.to_vertex.remove(&l);
        }
        assert!(matches!(upper_lip_region(&s, &map), Err(MeasureError::MissingLandmark(_))));
        let opts = MeshMeasureOptions { upper_lip: UpperLip::Region, ..Default::default() };
        assert!(protrusion(&s, &map, &opts).is_err());
    }

    #[test]
    fn point_in_polygon_edges_and_holes() {
        let sq = [
            Point2::new(0.0, 0.0),
            Point2::new(2.0, 0.0),
            Point2::new(2.0, 2.0),
            Point2::new(0.0, 2.0),
        ];
        assert!(inside_polygon(Point2::new(1.0, 1.0), &sq));
        assert!(inside_polygon(Point2::new(2.0, 1.0), &sq));
        assert!(!inside_polygon(Point2::new(2.5, 1.0), &sq));
        assert!(!inside_polygon(Point2::new(1.0, -0.1), &sq));
    }

    #[test]
    fn degenerate_inputs_are_errors() {
        let (s, mut map) = head();
        let bad = DVector::zeros(7);
        assert_eq!(
            measure_shape(&bad, &map, &Default::default()),
            Err(MeasureError::BadShapeLength(7))
        );
        map.to_vertex.insert(62, 500);
        assert!(matches!(
            measure_shape(&s, &map, &Default::default()),
            Err(MeasureError::VertexOutOfRange { landmark: 62, vertex: 500, .. })
        ));
        map.to_vertex.remove(&62);
        assert_eq!(
            measure_shape(&s, &map, &Default::default()),
            Err(MeasureError::MissingLandmark(62))
        );
        let only =
            MeshMeasureOptions { upper_lip: UpperLip::Vertices(vec![]), ..Default::default() };
        assert_eq!(protrusion(&s, &map, &only), Err(MeasureError::NoUpperLip));
        let line = [27usize, 30, 27];
        assert!(matches!(
            remove_rigid_pose(&s, &s, &line),
            Err(MeasureError::DegenerateReference(_))
        ));
    }

    #[test]
    fn trajectory_skips_failed_frames() {
        let (s, map) = head();
        let t = trajectory_from_shapes([Some(&s), None, Some(&s)], &map, &Default::default());
        assert_eq!(t.w.len(), 3);
        assert!(t.p[0].is_some() && t.p[1].is_none());
    }

    fn rigid(shape: &DVector, r: &nalgebra::Rotation3<f64>, t: Vector3) -> DVector {
        let mut out = shape.clone();
        for k in 0..shape.len() / 3 {
            let p = r * Vector3::new(shape[3 * k], shape[3 * k + 1], shape[3 * k + 2]) + t;
            out.fixed_rows_mut::<3>(3 * k).copy_from(&p);
        }
        out
    }

    proptest! {
        #[test]
        fn measures_invariant_to_rigid_motion_after_pose_removal(
            axis in prop::array::uniform3(-1.0f64..1.0),
            angle in -3.1f64..3.1,
            t in prop::array::uniform3(-500.0f64..500.0),
        ) {
            let (s, map) = head();
            let axis = Vector3::from(axis);
            prop_assume!(axis.norm() > 1e-3);
            let r = nalgebra::Rotation3::from_axis_angle(&nalgebra::Unit::new_normalize(axis), angle);
            let moved = rigid(&s, &r, Vector3::from(t));
            // Rigid anchors: eye corners, nose bridge and tip, brows.
            let anchors: Vec<usize> = (17..=30).chain(36..=47).collect();
            let back = remove_rigid_pose(&moved, &s, &anchors).unwrap();
            let opts = MeshMeasureOptions::default();
            let a = measure_shape(&s, &map, &opts).unwrap();
            let b = measure_shape(&back, &map, &opts).unwrap();
            prop_assert!((a.w - b.w).abs() < 1e-9);
            prop_assert!((a.h - b.h).abs() < 1e-9);
            prop_assert!((a.p.unwrap() - b.p.unwrap()).abs() < 1e-9);
            // 3D distances need no pose removal at all.
            let e = MeshMeasureOptions { distance: MeshDistance::Euclidean, ..Default::default() };
            let a = measure_shape(&s, &map, &e).unwrap();
            let c = measure_shape(&moved, &map, &e).unwrap();
            prop_assert!((a.w - c.w).abs() < 1e-9 && (a.h - c.h).abs() < 1e-9);
        }
    }
}
