//! Camera estimation: the linear affine camera from 2D–3D pairs (Hartley–Zisserman Gold
//! Standard normalisation), its scaled orthographic form, and a Gauss–Newton pose refinement.
//!
//! Conventions (as eos): model space is right-handed, y up; image pixels have y down and height
//! `H`. A scaled orthographic pose projects `u = s·(r1·X + tx)`, `v = H − s·(r2·X + ty)`, with
//! `R = Ry(yaw)·Rx(pitch)·Rz(roll)` and `r1`, `r2` its first two rows.

use crate::math::{Matrix3, Point2, Point3, Real, Vector3};
use nalgebra::{Matrix4, Matrix6, Rotation3, SVD, Vector4, Vector6};
use serde::{Deserialize, Serialize};

/// A scaled orthographic camera (eos's `ScaledOrthoProjectionParameters`).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct OrthoPose {
    /// Rotation from model space to camera space (rows r1, r2, r3).
    pub r: Matrix3,
    /// Pixels per model unit.
    pub s: Real,
    /// Translation in model units (applied before scaling).
    pub tx: Real,
    pub ty: Real,
}

impl OrthoPose {
    /// Projects a model-space point to image pixels (y down) in an image `image_height` tall.
    pub fn project(&self, x: &Point3, image_height: Real) -> Point2 {
        let c = self.r * x.coords;
        Point2::new(self.s * (c.x + self.tx), image_height - self.s * (c.y + self.ty))
    }

    /// eos's 3×4 affine camera matrix (`get_3x4_affine_camera_matrix`): image y down, so the
    /// second row is negated and offset by the image height. Returns rows 1 and 2 (row 3 is
    /// `[0 0 0 1]`).
    pub fn affine_matrix(&self, image_height: Real) -> [[Real; 4]; 2] {
        let (r, s) = (&self.r, self.s);
        [
            [s * r[(0, 0)], s * r[(0, 1)], s * r[(0, 2)], s * self.tx],
            [-s * r[(1, 0)], -s * r[(1, 1)], -s * r[(1, 2)], image_height - s * self.ty],
        ]
    }

    /// (yaw, pitch, roll) in degrees for `R = Ry(yaw)·Rx(pitch)·Rz(roll)`.
    pub fn yaw_pitch_roll_deg(&self) -> (Real, Real, Real) {
        yaw_pitch_roll_deg(&self.r)
    }

    /// Whether every field is finite and the scale positive.
    pub fn is_valid(&self) -> bool {
        self.r.iter().all(|v| v.is_finite())
            && self.s.is_finite()
            && self.s > 0.0
            && self.tx.is_finite()
            && self.ty.is_finite()
    }
}

/// `R = Ry(yaw)·Rx(pitch)·Rz(roll)`, angles in degrees.
pub fn rotation_from_yaw_pitch_roll_deg(yaw: Real, pitch: Real, roll: Real) -> Matrix3 {
    let ry = Rotation3::from_axis_angle(&Vector3::y_axis(), yaw.to_radians());
    let rx = Rotation3::from_axis_angle(&Vector3::x_axis(), pitch.to_radians());
    let rz = Rotation3::from_axis_angle(&Vector3::z_axis(), roll.to_radians());
    (ry * rx * rz).into_inner()
}

/// Inverse of [`rotation_from_yaw_pitch_roll_deg`]. With `R = Ry·Rx·Rz`, row 2 of R is
/// `[cp·sr, cp·cr, −sp]` and column 3 is `[sy·cp, −sp, cy·cp]`, which gives the angles directly.
pub fn yaw_pitch_roll_deg(r: &Matrix3) -> (Real, Real, Real) {
    let pitch = (-r[(1, 2)]).clamp(-1.0, 1.0).asin();
    let yaw = r[(0, 2)].atan2(r[(2, 2)]);
    let roll = r[(1, 0)].atan2(r[(1, 1)]);
    (yaw.to_degrees(), pitch.to_degrees(), roll.to_degrees())
}

/// Why a camera could not be estimated.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum CameraError {
    #[error("too few points for a camera ({0}, need at least 4)")]
    TooFewPoints(usize),
    #[error("non-finite point coordinates")]
    NonFinite,
    #[error("points are degenerate (collinear or coincident)")]
    Degenerate,
}

/// Similarity normalisation (Hartley–Zisserman §4.4.4): centroid to the origin and RMS
/// distance from it to `target`. Returns (centroid, scale) or None when all points coincide.
fn normalisation<const D: usize>(
    points: impl Iterator<Item = nalgebra::SVector<Real, D>> + Clone,
    target: Real,
) -> Option<(nalgebra::SVector<Real, D>, Real)> {
    let mut n = 0usize;
    let mut c = nalgebra::SVector::<Real, D>::zeros();
    for p in points.clone() {
        c += p;
        n += 1;
    }
    if n == 0 {
        return None;
    }
    c /= n as Real;
    let ms = points.map(|p| (p - c).norm_squared()).sum::<Real>() / n as Real;
    let rms = ms.sqrt();
    if !rms.is_finite() || rms <= 1e-12 * (1.0 + c.norm()) {
        return None;
    }
    Some((c, target / rms))
}

/// The linear affine camera `[u ṽ]ᵀ = P·[X 1]ᵀ` (ṽ = H − v) from L ≥ 4 pairs, least squares
/// over the 2L×8 system with Gold Standard normalisation (Hartley–Zisserman Alg. 7.2).
/// Normalising changes the conditioning, not the least-squares solution, so the answer equals
/// eos's unnormalised one. Returns the 2×4 matrix rows.
pub fn estimate_affine_camera(
    image_points: &[Point2],
    model_points: &[Point3],
    image_height: Real,
) -> Result<[Vector4<Real>; 2], CameraError> {
    let n = image_points.len().min(model_points.len());
    if n < 4 {
        return Err(CameraError::TooFewPoints(n));
    }
    let finite = image_points[..n].iter().all(|p| p.x.is_finite() && p.y.is_finite())
        && model_points[..n].iter().all(|p| p.coords.iter().all(|v| v.is_finite()));
    if !finite {
        return Err(CameraError::NonFinite);
    }
    let img = |p: &Point2| nalgebra::Vector2::new(p.x, image_height - p.y);
    let (c2, k2) = normalisation(image_points[..n].iter().map(img), std::f64::consts::SQRT_2)
        .ok_or(CameraError::Degenerate)?;
    let (c3, k3) = normalisation(model_points[..n].iter().map(|p| p.coords), 3f64.sqrt())
        .ok_or(CameraError::Degenerate)?;
    // The 2L×8 system is block diagonal: both image rows share the design matrix [X' 1], so
    // its normal equations are one 4×4 matrix with two right-hand sides.
    let mut ata = Matrix4::<Real>::zeros();
    let mut atb_u = Vector4::<Real>::zeros();
    let mut atb_v = Vector4::<Real>::zeros();
    for (p2, p3) in image_points[..n].iter().zip(&model_points[..n]) {
        let x = (p3.coords - c3) * k3;
        let row = Vector4::new(x.x, x.y, x.z, 1.0);
        let y = (img(p2) - c2) * k2;
        ata += row * row.transpose();
        atb_u += row * y.x;
        atb_v += row * y.y;
    }
    // Collinear or coplanar model points make the 4×4 matrix singular; after normalisation
    // its entries are O(n), so the determinant is compared with n⁴.
    let det = ata.determinant();
    if det.is_nan() || det <= 1e-10 * (n as Real).powi(4) {
        return Err(CameraError::Degenerate);
    }
    let chol = ata.cholesky().ok_or(CameraError::Degenerate)?;
    let pu = chol.solve(&atb_u);
    let pv = chol.solve(&atb_v);
    // Denormalise: y = k2 (ỹ − c2) = P' [k3 (X − c3); 1]  ⇒  ỹ = P'·T3·X/k2 + c2.
    let denorm = |p: Vector4<Real>, c: Real| {
        let lin = Vector3::new(p[0], p[1], p[2]) * (k3 / k2);
        let t = (p[3] - Vector3::new(p[0], p[1], p[2]).dot(&(c3 * k3))) / k2 + c;
        Vector4::new(lin.x, lin.y, lin.z, t)
    };
    let rows = [denorm(pu, c2.x), denorm(pv, c2.y)];
    if rows.iter().any(|r| r.iter().any(|v| !v.is_finite())) {
        return Err(CameraError::NonFinite);
    }
    Ok(rows)
}

/// Scaled orthographic pose from an affine camera (eos's
/// `estimate_orthographic_projection_linear`): `s = (|r1|+|r2|)/2`, `R` the rotation nearest
/// to `[r̂1; r̂2; r̂1×r̂2]` by SVD (a reflection is fixed by flipping the weakest direction),
/// translation the fourth column over `s`.
pub fn orthographic_from_affine(rows: &[Vector4<Real>; 2]) -> Result<OrthoPose, CameraError> {
    let r1 = Vector3::new(rows[0][0], rows[0][1], rows[0][2]);
    let r2 = Vector3::new(rows[1][0], rows[1][1], rows[1][2]);
    let (n1, n2) = (r1.norm(), r2.norm());
    if !(n1.is_finite() && n2.is_finite()) || n1 <= 1e-12 || n2 <= 1e-12 {
        return Err(CameraError::Degenerate);
    }
    let s = 0.5 * (n1 + n2);
    let (a, b) = (r1 / n1, r2 / n2);
    let m = Matrix3::from_rows(&[a.transpose(), b.transpose(), a.cross(&b).transpose()]);
    let svd = SVD::new(m, true, true);
    let (Some(mut u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err(CameraError::Degenerate);
    };
    let mut r = u * v_t;
    if r.determinant() < 0.0 {
        // Singular values come sorted descending: flip the weakest direction.
        let mut c = u.column_mut(2);
        c *= -1.0;
        r = u * v_t;
    }
    let pose = OrthoPose { r, s, tx: rows[0][3] / s, ty: rows[1][3] / s };
    if pose.is_valid() { Ok(pose) } else { Err(CameraError::NonFinite) }
}

/// Linear affine camera followed by its scaled orthographic form: eos's camera step.
pub fn estimate_orthographic_pose(
    image_points: &[Point2],
    model_points: &[Point3],
    image_height: Real,
) -> Result<OrthoPose, CameraError> {
    orthographic_from_affine(&estimate_affine_camera(image_points, model_points, image_height)?)
}

/// Weighted squared reprojection error Σ wᵢ·|proj(Xᵢ) − xᵢ|².
pub fn reprojection_sse(
    pose: &OrthoPose,
    image_points: &[Point2],
    model_points: &[Point3],
    weights: Option<&[Real]>,
    image_height: Real,
) -> Real {
    image_points
        .iter()
        .zip(model_points)
        .enumerate()
        .map(|(i, (x, m))| {
            let w = weights.map_or(1.0, |w| w[i]);
            w * (pose.project(m, image_height) - x).norm_squared()
        })
        .sum()
}

/// One model point's reprojection residual under a pose, in (u, ṽ) with ṽ = H − v:
/// `r_u = s·(c_x + t_x) − u`, `r_v = s·(c_y + t_y) − ṽ` for the camera-space point `c = R·X`.
/// Every pose solver (the pose refinement, the joint step, the shape fit's gradient) reads
/// its residuals from here, so they agree on the convention.
#[derive(Clone, Copy, Debug)]
pub(crate) struct PoseResidual {
    /// The camera-space point `R·X`.
    pub c: Vector3,
    pub u: Real,
    pub v: Real,
}

impl PoseResidual {
    /// The residual of model point `x` against image point `observed` (pixels, y down).
    #[inline]
    pub fn new(pose: &OrthoPose, x: &Vector3, observed: &Point2, image_height: Real) -> Self {
        let c = pose.r * x;
        Self {
            c,
            u: pose.s * (c.x + pose.tx) - observed.x,
            v: pose.s * (c.y + pose.ty) - (image_height - observed.y),
        }
    }

    /// `(∂r_u, ∂r_v)` with respect to `(ω, s, t_x, t_y)`, ω the left rotation increment
    /// `R ← exp(ω)·R`: `dc = ω × c = (ω_y c_z − ω_z c_y, ω_z c_x − ω_x c_z, ω_x c_y − ω_y c_x)`.
    /// The solvers use it summed, in [`PoseSums::normal_equations`] and the joint solver's
    /// coupling rows; tests check both against it.
    #[cfg(test)]
    pub fn jacobian(&self, pose: &OrthoPose) -> (Vector6<Real>, Vector6<Real>) {
        let (c, s) = (&self.c, pose.s);
        (
            Vector6::new(0.0, s * c.z, -s * c.y, c.x + pose.tx, s, 0.0),
            Vector6::new(-s * c.z, 0.0, s * c.x, c.y + pose.ty, 0.0, s),
        )
    }
}

/// Weighted sums over points of their camera points `c = R·X` and residuals, from which a
/// pose's Gauss–Newton normal equations follow without forming each point's Jacobian: every
/// entry of `PoseResidual::jacobian` is affine in c, so `Σ w·(j_u j_uᵀ + j_v j_vᵀ)` and
/// `Σ w·(j_u r_u + j_v r_v)` are combinations of these moments.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct PoseSums {
    /// Σw
    w: Real,
    /// Σw·c
    c: Vector3,
    /// Σw·c_a·c_b for xx, yy, zz, xz, yz (xy cancels out of the normal equations).
    cc: [Real; 5],
    /// Σw·r_u, Σw·r_v
    r: [Real; 2],
    /// Σw·c_a·r_u and Σw·c_a·r_v for a = x, y, z.
    cr: [[Real; 2]; 3],
}

impl PoseSums {
    /// Adds one point's residual with weight `w`.
    #[inline]
    pub fn add(&mut self, res: &PoseResidual, w: Real) {
        let c = res.c;
        let (wu, wv) = (w * res.u, w * res.v);
        self.w += w;
        self.c += c * w;
        let wc = c * w;
        self.cc[0] += wc.x * c.x;
        self.cc[1] += wc.y * c.y;
        self.cc[2] += wc.z * c.z;
        self.cc[3] += wc.x * c.z;
        self.cc[4] += wc.y * c.z;
        self.r[0] += wu;
        self.r[1] += wv;
        for a in 0..3 {
            self.cr[a][0] += c[a] * wu;
            self.cr[a][1] += c[a] * wv;
        }
    }

    /// `(JᵀWJ, JᵀWr)` over (ω, s, t_x, t_y) at `pose`, with J the rows of
    /// `PoseResidual::jacobian`: `j_u = (0, s·c_z, −s·c_y, c_x + t_x, s, 0)`,
    /// `j_v = (−s·c_z, 0, s·c_x, c_y + t_y, 0, s)`.
    pub fn normal_equations(&self, pose: &OrthoPose) -> (Matrix6<Real>, Vector6<Real>) {
        let (s, tx, ty) = (pose.s, pose.tx, pose.ty);
        let s2 = s * s;
        let (n, m) = (self.w, self.c);
        let [xx, yy, zz, xz, yz] = self.cc;
        let mut h = Matrix6::<Real>::zeros();
        let mut set = |i: usize, j: usize, v: Real| {
            h[(i, j)] = v;
            h[(j, i)] = v;
        };
        set(0, 0, s2 * zz);
        set(0, 2, -s2 * xz);
        set(0, 3, -s * (yz + ty * m.z));
        set(0, 5, -s2 * m.z);
        set(1, 1, s2 * zz);
        set(1, 2, -s2 * yz);
        set(1, 3, s * (xz + tx * m.z));
        set(1, 4, s2 * m.z);
        set(2, 2, s2 * (xx + yy));
        set(2, 3, s * (ty * m.x - tx * m.y));
        set(2, 4, -s2 * m.y);
        set(2, 5, s2 * m.x);
        set(3, 3, xx + yy + 2.0 * (tx * m.x + ty * m.y) + (tx * tx + ty * ty) * n);
        set(3, 4, s * (m.x + tx * n));
        set(3, 5, s * (m.y + ty * n));
        set(4, 4, s2 * n);
        set(5, 5, s2 * n);
        let [cx, cy, cz] = self.cr;
        let g = Vector6::new(
            -s * cz[1],
            s * cz[0],
            s * (cx[1] - cy[0]),
            cx[0] + cy[1] + tx * self.r[0] + ty * self.r[1],
            s * self.r[0],
            s * self.r[1],
        );
        (h, g)
    }
}

/// Refines a scaled orthographic pose by Gauss–Newton on the (weighted) reprojection error,
/// the quantity the linear affine step only approximates: its 8 parameters ignore that r1 and
/// r2 must be orthogonal and equally long, so its rotation absorbs noise a true pose cannot.
/// Parameters: a rotation increment ω (R ← exp(ω)·R), s, tx, ty. Steps that do not lower the
/// error are rejected (halved), so the result is never worse than the start.
pub fn refine_orthographic_pose(
    start: &OrthoPose,
    image_points: &[Point2],
    model_points: &[Point3],
    weights: Option<&[Real]>,
    image_height: Real,
    iterations: usize,
) -> OrthoPose {
    let mut pose = *start;
    let mut err = reprojection_sse(&pose, image_points, model_points, weights, image_height);
    if !err.is_finite() {
        return pose;
    }
    for _ in 0..iterations {
        let mut sums = PoseSums::default();
        for (i, (x, m)) in image_points.iter().zip(model_points).enumerate() {
            let w = weights.map_or(1.0, |w| w[i]);
            if w > 0.0 {
                sums.add(&PoseResidual::new(&pose, &m.coords, x, image_height), w);
            }
        }
        let (jtj, jtr) = sums.normal_equations(&pose);
        let Some(chol) = jtj.cholesky() else { break };
        let delta = -chol.solve(&jtr);
        if !delta.iter().all(|v| v.is_finite()) {
            break;
        }
        let mut step = 1.0;
        let mut improved = false;
        for _ in 0..4 {
            let d = delta * step;
            let rot = Rotation3::new(Vector3::new(d[0], d[1], d[2]));
            let cand = OrthoPose {
                r: rot.into_inner() * pose.r,
                s: pose.s + d[3],
                tx: pose.tx + d[4],
                ty: pose.ty + d[5],
            };
            if cand.is_valid() {
                let e = reprojection_sse(&cand, image_points, model_points, weights, image_height);
                if e <= err {
                    let small = err - e <= 1e-12 * (1.0 + err);
                    pose = cand;
                    err = e;
                    improved = !small;
                    break;
                }
            }
            step *= 0.5;
        }
        if !improved {
            break;
        }
    }
    // Re-orthonormalise against accumulated rounding.
    let svd = SVD::new(pose.r, true, true);
    if let (Some(u), Some(v_t)) = (svd.u, svd.v_t) {
        let r = u * v_t;
        if r.determinant() > 0.0 {
            pose.r = r;
        }
    }
    pose
}

/// Angle in degrees of the rotation taking `a` to `b`.
pub fn rotation_angle_between_deg(a: &Matrix3, b: &Matrix3) -> Real {
    let c = ((a.transpose() * b).trace() - 1.0) / 2.0;
    c.clamp(-1.0, 1.0).acos().to_degrees()
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    fn face_like_points() -> Vec<Point3> {
        // A non-planar cloud roughly the size of a face (mm).
        let mut v = Vec::new();
        for i in 0..7 {
            for j in 0..7 {
                let x = -60.0 + 20.0 * i as Real;
                let y = -60.0 + 20.0 * j as Real;
                let z = 40.0 - 0.004 * (x * x + 2.0 * y * y) + 3.0 * ((i * j) % 3) as Real;
                v.push(Point3::new(x, y, z));
            }
        }
        v
    }

    #[test]
    fn ypr_round_trips() {
        let r = rotation_from_yaw_pitch_roll_deg(20.0, -8.0, 5.0);
        let (y, p, ro) = yaw_pitch_roll_deg(&r);
        assert!((y - 20.0).abs() < 1e-10 && (p + 8.0).abs() < 1e-10 && (ro - 5.0).abs() < 1e-10);
    }

    #[test]
    fn too_few_and_collinear_points_are_errors() {
        let p2 = vec![Point2::new(1.0, 2.0); 3];
        let p3 = vec![Point3::new(0.0, 0.0, 0.0); 3];
        assert_eq!(estimate_orthographic_pose(&p2, &p3, 100.0), Err(CameraError::TooFewPoints(3)));
        let p3: Vec<Point3> =
            (0..6).map(|i| Point3::new(i as Real, 2.0 * i as Real, 0.0)).collect();
        let p2: Vec<Point2> = (0..6).map(|i| Point2::new(i as Real, i as Real)).collect();
        assert_eq!(estimate_orthographic_pose(&p2, &p3, 100.0), Err(CameraError::Degenerate));
        let mut p2b = p2.clone();
        p2b[0].x = Real::NAN;
        assert_eq!(estimate_orthographic_pose(&p2b, &p3, 100.0), Err(CameraError::NonFinite));
    }

    proptest! {
        #[test]
        fn random_pose_is_recovered(yaw in -40.0..40.0f64, pitch in -25.0..25.0f64,
                                    roll in -30.0..30.0f64, s in 0.5..4.0f64,
                                    tx in 100.0..300.0f64, ty in 50.0..200.0f64) {
            let pose = OrthoPose { r: rotation_from_yaw_pitch_roll_deg(yaw, pitch, roll), s, tx, ty };
            let x3 = face_like_points();
            let x2: Vec<Point2> = x3.iter().map(|p| pose.project(p, 720.0)).collect();
            let est = estimate_orthographic_pose(&x2, &x3, 720.0).unwrap();
            let est = refine_orthographic_pose(&est, &x2, &x3, None, 720.0, 5);
            // acos near 1 limits the angle's precision to ~1e-6°, so compare entries too.
            prop_assert!(rotation_angle_between_deg(&est.r, &pose.r) < 1e-4);
            prop_assert!((est.r - pose.r).amax() < 1e-9);
            prop_assert!((est.s / s - 1.0).abs() < 1e-9);
            prop_assert!((est.tx - tx).abs() < 1e-6 && (est.ty - ty).abs() < 1e-6);
            let (y, p, r) = est.yaw_pitch_roll_deg();
            prop_assert!((y - yaw).abs() < 1e-6 && (p - pitch).abs() < 1e-6 && (r - roll).abs() < 1e-6);
            prop_assert!((est.r.determinant() - 1.0).abs() < 1e-9);
        }
    }

    #[test]
    fn pose_sums_give_the_normal_equations_of_the_jacobian() {
        let pose = OrthoPose {
            r: rotation_from_yaw_pitch_roll_deg(25.0, -10.0, 7.0),
            s: 1.7,
            tx: 120.0,
            ty: -40.0,
        };
        let (mut h, mut g) = (Matrix6::<Real>::zeros(), Vector6::<Real>::zeros());
        let mut sums = PoseSums::default();
        for (i, p) in face_like_points().iter().enumerate() {
            let observed = Point2::new(300.0 + 3.0 * i as Real, 200.0 - (i % 7) as Real * 9.0);
            let res = PoseResidual::new(&pose, &p.coords, &observed, 720.0);
            let w = 0.5 + (i % 3) as Real;
            let (ju, jv) = res.jacobian(&pose);
            h += (ju * ju.transpose() + jv * jv.transpose()) * w;
            g += (ju * res.u + jv * res.v) * w;
            sums.add(&res, w);
        }
        let (h2, g2) = sums.normal_equations(&pose);
        assert!((h2 - h).amax() <= 1e-9 * h.amax(), "{h2} vs {h}");
        assert!((g2 - g).amax() <= 1e-9 * g.amax(), "{g2} vs {g}");
    }

    #[test]
    fn refinement_does_not_increase_error_under_noise() {
        let pose = OrthoPose {
            r: rotation_from_yaw_pitch_roll_deg(15.0, 5.0, -3.0),
            s: 2.0,
            tx: 300.0,
            ty: 180.0,
        };
        let x3 = face_like_points();
        let x2: Vec<Point2> = x3
            .iter()
            .enumerate()
            .map(|(i, p)| {
                pose.project(p, 720.0)
                    + nalgebra::Vector2::new(
                        ((i * 7) % 5) as Real - 2.0,
                        ((i * 3) % 5) as Real - 2.0,
                    )
            })
            .collect();
        let lin = estimate_orthographic_pose(&x2, &x3, 720.0).unwrap();
        let refined = refine_orthographic_pose(&lin, &x2, &x3, None, 720.0, 10);
        let e0 = reprojection_sse(&lin, &x2, &x3, None, 720.0);
        let e1 = reprojection_sse(&refined, &x2, &x3, None, 720.0);
        assert!(e1 <= e0);
    }
}
