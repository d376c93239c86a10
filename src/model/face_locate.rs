//! Where the face is on a mesh, from its geometry alone: a head, a bust, a face mask or a
//! whole figure, standing y-up, z-up or facing −z, with or without named parts. Used to
//! frame the labelling view on the face before any landmark is labelled.
//!
//! Start with [`locate_face`]. Three steps, each on the surface only (helper and joint
//! geometry left out by the caller's `eligible`):
//!
//! 1. **The midline.** Faces and bodies are mirror-symmetric about their midsagittal plane.
//!    Each principal axis and each world axis is tried as the plane's normal and refined by
//!    mirror ICP (reflect the points, pair each with the nearest original point, re-fit the
//!    plane to the pairs: the iterative reflection matching of Combès et al. 2008, reduced
//!    to a plane); the plane whose reflection lands closest to the surface wins.
//! 2. **Head or figure.** Seen along the plane's normal, a head, bust or mask is about as
//!    deep as tall; a standing or lying figure is several times longer than deep. For a
//!    figure the head is the end whose midline is occupied (the crown; between the feet
//!    the midline is empty), about 1/7.5 of its length (the canon of adult proportions).
//! 3. **The profile.** The mesh is cut by the midline plane; seen from each direction in
//!    the plane (every 5°, both ways up), the cut's front-most points form a profile, and
//!    an adult soft-tissue profile (forehead, nose, lips, chin: [`PROFILE_MM`], proportions
//!    after Farkas 1994) is slid along it at a range of scales. The best match gives the
//!    face's forward and up directions, its nose tip and its size in the mesh's units.
//!
//! It fails on faces turned far from their body's midline (a figure posed looking over its
//! shoulder), on very asymmetric scans (a face cut off on one side), and on profiles the
//! template does not resemble (a beak, a muzzle): docs/labelling.md.

use crate::math::{Matrix3, Point3, Real, Vector3};

/// The face found on a mesh.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceLocation {
    /// Rows: the subject's left, up, forward (as `map_check::face_axes`), so that the
    /// matrix turns the mesh to face the viewer upright.
    pub axes: Matrix3,
    pub nose_tip: Point3,
    /// Mesh units per millimetre of an adult face.
    pub scale: Real,
    /// The profile match's mean residual (mm of the template); small is a good match.
    pub residual_mm: Real,
}

impl FaceLocation {
    /// The middle of the face (behind and a little below the nose tip).
    pub fn centre(&self) -> Point3 {
        let (up, fwd) = (self.axes.row(1).transpose(), self.axes.row(2).transpose());
        self.nose_tip + self.scale * (-15.0 * up - 35.0 * fwd)
    }

    /// A radius around [`FaceLocation::centre`] that holds the face, brows to chin and ear
    /// to ear, in mesh units.
    pub fn radius(&self) -> Real {
        105.0 * self.scale
    }
}

/// An adult's midline soft-tissue profile, nose tip at the origin: (up, forward) in mm,
/// from the forehead to under the chin. Proportions after Farkas (1994): nasion 48 mm above
/// the tip and 21 mm behind it, subnasale 19 mm behind, the lips 2–4 mm behind the line from
/// nose tip to chin (Ricketts' E-line), menton 82 mm below the tip.
pub const PROFILE_MM: [(Real, Real); 20] = [
    (95.0, -24.0),
    (75.0, -18.0),
    (58.0, -16.0),
    (48.0, -21.0),
    (35.0, -15.0),
    (20.0, -8.0),
    (8.0, -3.0),
    (0.0, 0.0),
    (-6.0, -4.0),
    (-13.0, -14.0),
    (-17.0, -19.0),
    (-24.0, -16.0),
    (-30.0, -13.0),
    (-36.0, -16.0),
    (-42.0, -14.0),
    (-52.0, -22.0),
    (-64.0, -18.0),
    (-76.0, -24.0),
    (-82.0, -33.0),
    (-85.0, -45.0),
];

/// A figure is a mesh this many times longer than deep (seen along its midline's normal):
/// a standing adult is about six times, a face mask less than three.
const FIGURE_ELONGATION: Real = 4.0;
/// Adult figures are about this many heads tall.
const HEADS_PER_FIGURE: Real = 7.5;
/// An adult head, crown to chin, mm.
const HEAD_HEIGHT_MM: Real = 230.0;
/// Points used for the midline plane (a deterministic subsample of the surface).
const PLANE_SAMPLE: usize = 6000;
/// A profile residual above this (mm) counts as a miss: the template's features differ
/// from a real face's by a few mm; a whole feature missing costs this much, no more.
const RESIDUAL_CAP_MM: Real = 12.0;
/// A best match worse than this (mean, mm) is no face: faces match to 2.5–3.5 mm
/// (MakeHuman, the SFM mean, the demo head); the best wrong placement found on the demo
/// head, seen from under its chin, was 7 mm.
const MAX_RESIDUAL_MM: Real = 5.0;

/// Finds the face on the mesh `vertices`/`triangles`, using only the `eligible` vertices
/// (all when `None`) and the triangles all of whose corners are eligible. `None` when the
/// mesh has too few points, no symmetry plane, or nothing that looks like a face profile.
pub fn locate_face(
    vertices: &[Point3],
    triangles: &[[u32; 3]],
    eligible: Option<&[bool]>,
) -> Option<FaceLocation> {
    let ok = |v: u32| eligible.is_none_or(|e| e.get(v as usize) == Some(&true));
    let tris: Vec<[u32; 3]> = triangles
        .iter()
        .filter(|t| t.iter().all(|&v| ok(v) && (v as usize) < vertices.len()))
        .copied()
        .collect();
    let mut used = vec![false; vertices.len()];
    if tris.is_empty() {
        (0..vertices.len()).filter(|&v| ok(v as u32)).for_each(|v| used[v] = true);
    } else {
        tris.iter().flatten().for_each(|&v| used[v as usize] = true);
    }
    let points: Vec<Point3> = (0..vertices.len())
        .filter(|&v| used[v] && vertices[v].coords.iter().all(|x| x.is_finite()))
        .map(|v| vertices[v])
        .collect();
    if points.len() < 20 {
        return None;
    }
    let sample: Vec<Point3> =
        points.iter().step_by(points.len().div_ceil(PLANE_SAMPLE)).copied().collect();
    let plane = symmetry_plane(&sample)?;
    let body = Body::of(&points, &plane);
    let cut = midline_cut(vertices, &tris, &points, &plane, body.bin);
    let found = match_profile(&cut, &plane, &body);
    // A long thin mask can pass for a figure: it is tried as a head too, and the better
    // match wins.
    let as_head = body.up.is_some().then(|| Body::head(&points, &plane)).and_then(|head| {
        match_profile(&midline_cut(vertices, &tris, &points, &plane, head.bin), &plane, &head)
    });
    [found, as_head].into_iter().flatten().min_by(|a, b| a.residual_mm.total_cmp(&b.residual_mm))
}

/// A plane `n·x = d`, `n` unit length.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Plane {
    n: Vector3,
    d: Real,
}

impl Plane {
    fn distance(&self, p: &Point3) -> Real {
        self.n.dot(&p.coords) - self.d
    }

    fn reflect(&self, p: &Point3) -> Point3 {
        p - 2.0 * self.distance(p) * self.n
    }
}

/// Nearest-point queries over a uniform grid of cells (no index crate needed for a few
/// thousand points).
struct PointGrid<'a> {
    points: &'a [Point3],
    lo: Vector3,
    cell: Real,
    dims: [usize; 3],
    cells: Vec<Vec<u32>>,
}

impl<'a> PointGrid<'a> {
    fn new(points: &'a [Point3], cell: Real) -> Self {
        let lo = points.iter().fold(Vector3::repeat(Real::INFINITY), |a, p| a.inf(&p.coords));
        let hi = points.iter().fold(Vector3::repeat(Real::NEG_INFINITY), |a, p| a.sup(&p.coords));
        let dims = [0, 1, 2].map(|k| (((hi[k] - lo[k]) / cell).floor() as usize + 1).min(256));
        let mut cells = vec![Vec::new(); dims[0] * dims[1] * dims[2]];
        let mut grid = Self { points, lo, cell, dims, cells: Vec::new() };
        for (i, p) in points.iter().enumerate() {
            cells[grid.index(grid.cell_of(p))].push(i as u32);
        }
        grid.cells = cells;
        grid
    }

    fn cell_of(&self, p: &Point3) -> [i64; 3] {
        [0, 1, 2].map(|k| ((p[k] - self.lo[k]) / self.cell).floor() as i64)
    }

    fn index(&self, c: [i64; 3]) -> usize {
        let c = [0, 1, 2].map(|k| c[k].clamp(0, self.dims[k] as i64 - 1) as usize);
        (c[2] * self.dims[1] + c[1]) * self.dims[0] + c[0]
    }

    /// The nearest point within two cells of `p` and its distance.
    fn nearest(&self, p: &Point3) -> Option<(usize, Real)> {
        let c = self.cell_of(p);
        let mut best: Option<(usize, Real)> = None;
        for dz in -2..=2 {
            for dy in -2..=2 {
                for dx in -2..=2 {
                    let q = [c[0] + dx, c[1] + dy, c[2] + dz];
                    if (0..3).any(|k| q[k] < 0 || q[k] >= self.dims[k] as i64) {
                        continue;
                    }
                    for &i in &self.cells[self.index(q)] {
                        let d = (self.points[i as usize] - p).norm();
                        if best.is_none_or(|b| d < b.1) {
                            best = Some((i as usize, d));
                        }
                    }
                }
            }
        }
        best
    }
}

fn centroid(points: &[Point3]) -> Vector3 {
    points.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / points.len().max(1) as Real
}

/// Unit eigenvectors of the points' covariance, largest variance first.
fn principal_axes(points: &[Point3]) -> [Vector3; 3] {
    let c = centroid(points);
    let cov = points.iter().fold(Matrix3::zeros(), |a, p| {
        let d = p.coords - c;
        a + d * d.transpose()
    });
    let eigen = cov.symmetric_eigen();
    let mut order = [0usize, 1, 2];
    order.sort_by(|&a, &b| eigen.eigenvalues[b].total_cmp(&eigen.eigenvalues[a]));
    order.map(|k| eigen.eigenvectors.column(k).into_owned())
}

/// The mirror-symmetry plane of `points`: each principal and world axis as the normal of a
/// plane through the centroid, refined by mirror ICP; the best by how close the reflected
/// points land to the originals. `None` when nothing is anywhere near symmetric.
fn symmetry_plane(points: &[Point3]) -> Option<Plane> {
    let c = centroid(points);
    let diag = {
        let lo = points.iter().fold(Vector3::repeat(Real::INFINITY), |a, p| a.inf(&p.coords));
        let hi = points.iter().fold(Vector3::repeat(Real::NEG_INFINITY), |a, p| a.sup(&p.coords));
        (hi - lo).norm()
    };
    if !(diag.is_finite() && diag > 0.0) {
        return None;
    }
    let grid = PointGrid::new(points, diag / 60.0);
    let far = 2.0 * grid.cell;
    let score = |plane: &Plane| -> Real {
        points
            .iter()
            .map(|p| grid.nearest(&plane.reflect(p)).map_or(far, |(_, d)| d.min(far)))
            .sum::<Real>()
            / points.len() as Real
    };
    let axes = principal_axes(points);
    let candidates = axes.into_iter().chain([Vector3::x(), Vector3::y(), Vector3::z()]);
    let best = candidates
        .map(|n| refine_plane(points, &grid, Plane { n, d: n.dot(&c) }))
        .map(|p| (score(&p), p))
        .min_by(|a, b| a.0.total_cmp(&b.0))?;
    // A symmetric surface reflects onto itself to within a few of its cells.
    (best.0 < 0.5 * far).then_some(best.1)
}

/// Mirror ICP: reflect, pair each point with the original nearest its reflection, and take
/// the plane that bisects the pairs (normal along their differences, through their
/// midpoints). Pairs far off (the worst third) and points on the plane itself are left out.
fn refine_plane(points: &[Point3], grid: &PointGrid, mut plane: Plane) -> Plane {
    for _ in 0..8 {
        let pairs: Vec<(Point3, Point3, Real)> = points
            .iter()
            .filter_map(|p| {
                let (q, d) = grid.nearest(&plane.reflect(p))?;
                Some((*p, points[q], d))
            })
            .collect();
        if pairs.len() < 10 {
            return plane;
        }
        let mut ds: Vec<Real> = pairs.iter().map(|x| x.2).collect();
        ds.sort_by(Real::total_cmp);
        let cut = ds[ds.len() * 2 / 3];
        let mut sum = Vector3::zeros();
        for (p, q, d) in &pairs {
            let v = p - q;
            if *d <= cut && v.norm() > grid.cell {
                sum += if v.dot(&plane.n) >= 0.0 { v } else { -v };
            }
        }
        let Some(n) = sum.try_normalize(1e-12) else { return plane };
        let mut mids: Vec<Real> = pairs
            .iter()
            .filter(|x| x.2 <= cut)
            .map(|(p, q, _)| n.dot(&((p.coords + q.coords) / 2.0)))
            .collect();
        mids.sort_by(Real::total_cmp);
        plane = Plane { n, d: mids[mids.len() / 2] };
    }
    plane
}

/// What the mesh is, seen along the midline plane's normal: a head (or bust, or mask), or a
/// figure whose head is at one end.
#[derive(Clone, Copy, Debug)]
struct Body {
    /// The up direction, when the mesh is a figure.
    up: Option<Vector3>,
    /// Where along `up` the head's segment starts (figures only).
    head_from: Real,
    /// Scales (mesh units per mm) to try.
    scale_lo: Real,
    scale_hi: Real,
    /// Profile bin width, mesh units.
    bin: Real,
}

impl Body {
    /// A head, bust or mask `extent` long in the midline plane: crown to chin, forehead to
    /// chin, or crown to chest.
    fn head_of_extent(extent: Real) -> Self {
        Self {
            up: None,
            head_from: Real::NEG_INFINITY,
            scale_lo: 0.5 * extent / HEAD_HEIGHT_MM,
            scale_hi: 1.5 * extent / HEAD_HEIGHT_MM,
            bin: extent / 400.0,
        }
    }

    /// The mesh taken as a head whatever its proportions.
    fn head(points: &[Point3], plane: &Plane) -> Self {
        let (_, lo, hi, _) = Self::spans(points, plane);
        Self::head_of_extent(hi - lo)
    }

    /// The longer in-plane principal axis of the points seen along the plane's normal, the
    /// points' 1st and 99th percentiles along it, and their extent along the other.
    fn spans(points: &[Point3], plane: &Plane) -> (Vector3, Real, Real, Real) {
        let in_plane: Vec<Point3> =
            points.iter().map(|p| p - plane.distance(p) * plane.n).collect();
        let axes = principal_axes(&in_plane);
        // The two principal axes in the plane (the third is along the normal).
        let inplane: Vec<Vector3> =
            axes.into_iter().filter(|a| a.dot(&plane.n).abs() < 0.5).collect();
        let inplane = if inplane.len() < 2 { vec![axes[0], axes[1]] } else { inplane };
        let range = |a: &Vector3| -> (Real, Real) {
            let mut x: Vec<Real> = in_plane.iter().map(|p| a.dot(&p.coords)).collect();
            x.sort_by(Real::total_cmp);
            (x[x.len() / 100], x[x.len() - 1 - x.len() / 100])
        };
        let (lo, hi) = range(&inplane[0]);
        let (lo2, hi2) = range(&inplane[1]);
        (inplane[0], lo, hi, hi2 - lo2)
    }

    fn of(points: &[Point3], plane: &Plane) -> Self {
        let (a, lo1, hi1, e2) = Self::spans(points, plane);
        let e1 = hi1 - lo1;
        if e1 < FIGURE_ELONGATION * e2 {
            return Self::head_of_extent(e1);
        }
        let head = e1 / HEADS_PER_FIGURE;
        let top_of = |sign: Real| if sign > 0.0 { hi1 } else { -lo1 };
        // The crown is on the midline; between a figure's feet the midline is empty.
        let occupied = |sign: Real| {
            let seg: Vec<&Point3> =
                points.iter().filter(|p| sign * a.dot(&p.coords) >= top_of(sign) - head).collect();
            let near = seg.iter().filter(|p| plane.distance(p).abs() < 0.1 * head).count();
            near as Real / seg.len().max(1) as Real
        };
        let sign = if occupied(1.0) >= occupied(-1.0) { 1.0 } else { -1.0 };
        Self {
            up: Some(sign * a),
            head_from: top_of(sign) - 1.6 * head,
            scale_lo: 0.7 * head / HEAD_HEIGHT_MM,
            scale_hi: 1.4 * head / HEAD_HEIGHT_MM,
            bin: head / 80.0,
        }
    }
}

/// Points of the mesh's cut by the midline plane, every `step` along each cut segment; the
/// points near the plane when there are no triangles.
fn midline_cut(
    vertices: &[Point3],
    tris: &[[u32; 3]],
    points: &[Point3],
    plane: &Plane,
    step: Real,
) -> Vec<Point3> {
    if tris.is_empty() {
        return points.iter().filter(|p| plane.distance(p).abs() < 2.0 * step).copied().collect();
    }
    let mut cut = Vec::new();
    for t in tris {
        let p = t.map(|v| vertices[v as usize]);
        let s = p.map(|q| plane.distance(&q));
        let mut ends = Vec::with_capacity(2);
        for (i, j) in [(0, 1), (1, 2), (2, 0)] {
            if (s[i] < 0.0) != (s[j] < 0.0) {
                let t = s[i] / (s[i] - s[j]);
                ends.push(p[i] + t * (p[j] - p[i]));
            }
        }
        if let [a, b] = ends[..] {
            let n = ((b - a).norm() / step).ceil().clamp(1.0, 64.0) as usize;
            cut.extend((0..=n).map(|k| a + (b - a) * (k as Real / n as Real)));
        }
    }
    cut
}

/// The best placement of [`PROFILE_MM`] on the cut's profile seen from any direction in
/// the plane (restricted to about level with the figure's up, for a figure).
fn match_profile(cut: &[Point3], plane: &Plane, body: &Body) -> Option<FaceLocation> {
    if cut.len() < 10 {
        return None;
    }
    let n = plane.n;
    // An in-plane basis.
    let helper = if n.x.abs() < 0.9 { Vector3::x() } else { Vector3::y() };
    let b1 = n.cross(&helper).normalize();
    let b2 = n.cross(&b1);
    let cut: Vec<&Point3> = match body.up {
        Some(up) => cut.iter().filter(|p| up.dot(&p.coords) >= body.head_from).collect(),
        None => cut.iter().collect(),
    };
    let scales: Vec<Real> = {
        let k = ((body.scale_hi / body.scale_lo).ln() / 1.08f64.ln()).ceil().max(1.0) as usize;
        (0..=k).map(|i| body.scale_lo * 1.08f64.powi(i as i32)).collect()
    };
    // The best match seen from the in-plane direction `angle_deg` (from b1 towards b2),
    // up turned one way or the other.
    let seen_from = |angle_deg: Real, flip: bool| -> Option<FaceLocation> {
        let a = angle_deg.to_radians();
        let fwd = a.cos() * b1 + a.sin() * b2;
        let up = if flip { -n.cross(&fwd) } else { n.cross(&fwd) };
        if body.up.is_some_and(|u| u.dot(&up) < 40f64.to_radians().cos()) {
            return None;
        }
        let profile = Profile::of(&cut, &up, &fwd, body.bin);
        let (residual_mm, tip_up, tip_fwd, scale) = scales
            .iter()
            .filter_map(|&scale| profile.best_fit(scale).map(|(r, u, f)| (r, u, f, scale)))
            .min_by(|a, b| a.0.total_cmp(&b.0))?;
        let x = up.cross(&fwd);
        Some(FaceLocation {
            axes: Matrix3::from_rows(&[x.transpose(), up.transpose(), fwd.transpose()]),
            nose_tip: Point3::from(plane.d * n + tip_up * up + tip_fwd * fwd),
            scale,
            residual_mm,
        })
    };
    let better =
        |a: FaceLocation, b: FaceLocation| if b.residual_mm < a.residual_mm { b } else { a };
    let coarse = (0..72)
        .flat_map(|k| [(5.0 * k as Real, false), (5.0 * k as Real, true)])
        .filter_map(|(a, flip)| seen_from(a, flip).map(|f| (a, flip, f)))
        .reduce(|a, b| if b.2.residual_mm < a.2.residual_mm { b } else { a })?;
    // Finer around the best direction.
    let (a0, flip0, found) = coarse;
    let fine = (-4..=4).filter_map(|k| seen_from(a0 + k as Real, flip0)).fold(found, better);
    (fine.residual_mm <= MAX_RESIDUAL_MM).then_some(fine)
}

/// A cut's front-most extent along `fwd`, binned along `up`.
struct Profile {
    bin: Real,
    /// `up` coordinate of bin 0's lower edge.
    origin: Real,
    front: Vec<Real>,
}

impl Profile {
    fn of(cut: &[&Point3], up: &Vector3, fwd: &Vector3, bin: Real) -> Self {
        let ups: Vec<Real> = cut.iter().map(|p| up.dot(&p.coords)).collect();
        let origin = ups.iter().copied().fold(Real::INFINITY, Real::min);
        let top = ups.iter().copied().fold(Real::NEG_INFINITY, Real::max);
        let len = (((top - origin) / bin).floor() as usize + 1).min(100_000);
        let mut front = vec![Real::NEG_INFINITY; len];
        for (p, u) in cut.iter().zip(&ups) {
            let k = (((u - origin) / bin).floor() as usize).min(len - 1);
            front[k] = front[k].max(fwd.dot(&p.coords));
        }
        Self { bin, origin, front }
    }

    /// The front at `up` coordinate `u` (−∞ where the cut has no point).
    fn at(&self, u: Real) -> Real {
        let k = ((u - self.origin) / self.bin).floor();
        if k < 0.0 || k >= self.front.len() as Real {
            return Real::NEG_INFINITY;
        }
        self.front[k as usize]
    }

    /// The template at `scale` placed with its nose tip on each local maximum of the
    /// profile: the lowest mean residual (mm, each capped) and where the tip is (up, fwd).
    fn best_fit(&self, scale: Real) -> Option<(Real, Real, Real)> {
        let half = ((8.0 * scale / self.bin).round() as usize).max(1);
        let mut best: Option<(Real, Real, Real)> = None;
        for k in 0..self.front.len() {
            let z = self.front[k];
            if !z.is_finite() {
                continue;
            }
            let window = k.saturating_sub(half)..(k + half + 1).min(self.front.len());
            if self.front[window].iter().any(|&w| w > z) {
                continue;
            }
            let u0 = self.origin + (k as Real + 0.5) * self.bin;
            let residual = PROFILE_MM
                .iter()
                .map(|&(y, dz)| {
                    let f = self.at(u0 + scale * y);
                    if f.is_finite() {
                        ((f - (z + scale * dz)).abs() / scale).min(RESIDUAL_CAP_MM)
                    } else {
                        RESIDUAL_CAP_MM
                    }
                })
                .sum::<Real>()
                / PROFILE_MM.len() as Real;
            if best.is_none_or(|b| residual < b.0) {
                best = Some((residual, u0, z));
            }
        }
        best
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::demo::head::build_head;

    fn rotated(vertices: &[Point3], r: &Matrix3, t: Vector3) -> Vec<Point3> {
        vertices.iter().map(|p| Point3::from(r * p.coords + t)).collect()
    }

    #[test]
    fn finds_the_demo_face_in_any_orientation() {
        let head = build_head();
        let tris = head.mesh.triangles();
        let tip = head.mesh.vertices[head.landmarks.vertex(30).unwrap()];
        let turns = [
            Matrix3::identity(),
            // z-up: the face looks along −y.
            *nalgebra::Rotation3::from_axis_angle(&Vector3::x_axis(), std::f64::consts::FRAC_PI_2)
                .matrix(),
            // Facing −z.
            *nalgebra::Rotation3::from_axis_angle(&Vector3::y_axis(), std::f64::consts::PI)
                .matrix(),
            *nalgebra::Rotation3::from_euler_angles(0.4, -0.7, 0.2).matrix(),
        ];
        for r in turns {
            let v = rotated(&head.mesh.vertices, &r, Vector3::new(30.0, -500.0, 7.0));
            let face = locate_face(&v, &tris, None).expect("a face");
            let want_tip = r * tip.coords + Vector3::new(30.0, -500.0, 7.0);
            assert!((face.nose_tip.coords - want_tip).norm() < 8.0, "{face:?}");
            // Forward is the model's +z, up its +y, turned.
            assert!((face.axes.row(2).transpose()).dot(&(r * Vector3::z())) > 0.95, "{face:?}");
            assert!((face.axes.row(1).transpose()).dot(&(r * Vector3::y())) > 0.95, "{face:?}");
            assert!((0.7..1.4).contains(&face.scale), "{face:?}");
        }
    }
}
