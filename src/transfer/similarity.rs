//! The least-squares similarity (or rigid) transform between two point sets: Umeyama's
//! closed form (Umeyama 1991, "Least-squares estimation of transformation parameters between
//! two point patterns", eq. 40–42), which is Kabsch's rotation plus a scale.

use super::TransferError;
use crate::math::{Matrix3, Point3, Vector3};

/// `y ≈ s·R·x + t`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Similarity {
    pub scale: f64,
    pub rotation: Matrix3,
    pub translation: Vector3,
}

impl Similarity {
    /// The identity transform.
    pub fn identity() -> Self {
        Self { scale: 1.0, rotation: Matrix3::identity(), translation: Vector3::zeros() }
    }

    /// The transformed point `s·R·p + t`.
    pub fn apply(&self, p: &Point3) -> Point3 {
        Point3::from(self.scale * (self.rotation * p.coords) + self.translation)
    }

    /// The transformed displacement `s·R·d` (translation does not act on differences).
    pub fn apply_vector(&self, d: &Vector3) -> Vector3 {
        self.scale * (self.rotation * d)
    }

    /// The inverse transform applied to a point: `Rᵀ(p − t)/s`.
    pub fn apply_inverse(&self, p: &Point3) -> Point3 {
        Point3::from(self.rotation.transpose() * (p.coords - self.translation) / self.scale)
    }
}

/// The similarity (`with_scale`) or rigid motion that best maps `from[i]` onto `to[i]` in
/// the least-squares sense, by Umeyama's SVD of the cross-covariance with the reflection
/// case fixed (the smallest singular direction flipped).
///
/// # Errors
/// [`TransferError::DegeneratePlacement`] when fewer than three points are given, the
/// lengths differ, or the points are collinear (the rotation about their line is then
/// undetermined).
pub fn estimate_similarity(
    from: &[Point3],
    to: &[Point3],
    with_scale: bool,
) -> Result<Similarity, TransferError> {
    let n = from.len();
    if n < 3 || to.len() != n {
        return Err(TransferError::DegeneratePlacement { points: n.min(to.len()) });
    }
    let nf = n as f64;
    let mu_x = from.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / nf;
    let mu_y = to.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / nf;
    let mut sigma = Matrix3::zeros();
    let mut var_x = 0.0;
    for (x, y) in from.iter().zip(to) {
        let dx = x.coords - mu_x;
        sigma += (y.coords - mu_y) * dx.transpose();
        var_x += dx.norm_squared();
    }
    sigma /= nf;
    var_x /= nf;
    let svd = sigma.svd(true, true);
    let (Some(u), Some(v_t)) = (svd.u, svd.v_t) else {
        return Err(TransferError::DegeneratePlacement { points: n });
    };
    let d = svd.singular_values;
    let top = d.max();
    // Rank < 2: collinear or coincident points on either side.
    if !top.is_finite() || top <= 0.0 || d.iter().filter(|&&s| s > 1e-10 * top).count() < 2 {
        return Err(TransferError::DegeneratePlacement { points: n });
    }
    let sign = (u * v_t).determinant().signum();
    let s_diag = Vector3::new(1.0, 1.0, sign);
    let rotation = u * Matrix3::from_diagonal(&s_diag) * v_t;
    let scale = if with_scale { d.dot(&s_diag) / var_x } else { 1.0 };
    let translation = mu_y - scale * (rotation * mu_x);
    Ok(Similarity { scale, rotation, translation })
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Unit};

    fn cloud() -> Vec<Point3> {
        (0..12)
            .map(|i| {
                let a = i as f64;
                Point3::new(a.sin() * 3.0, (1.7 * a).cos(), 0.3 * a - 1.0)
            })
            .collect()
    }

    #[test]
    fn recovers_a_known_similarity_and_rigid_motion() {
        let axis = Unit::new_normalize(Vector3::new(0.3, -1.0, 0.5));
        let rotation = *Rotation3::from_axis_angle(&axis, 0.8).matrix();
        let truth = Similarity { scale: 2.5, rotation, translation: Vector3::new(1.0, -2.0, 7.0) };
        let from = cloud();
        let to: Vec<Point3> = from.iter().map(|p| truth.apply(p)).collect();
        let est = estimate_similarity(&from, &to, true).unwrap();
        assert!((est.scale - 2.5).abs() < 1e-12);
        assert!((est.rotation - rotation).norm() < 1e-12);
        assert!((est.translation - truth.translation).norm() < 1e-11);
        let q = Point3::new(0.2, 0.4, -0.9);
        assert!((est.apply_inverse(&est.apply(&q)) - q).norm() < 1e-12);
        let rigid = Similarity { scale: 1.0, ..truth };
        let to: Vec<Point3> = from.iter().map(|p| rigid.apply(p)).collect();
        let est = estimate_similarity(&from, &to, false).unwrap();
        assert!((est.rotation - rotation).norm() < 1e-12 && est.scale == 1.0);
    }

    #[test]
    fn collinear_or_too_few_points_are_an_error() {
        let line: Vec<Point3> = (0..5).map(|i| Point3::new(i as f64, 0.0, 0.0)).collect();
        assert!(matches!(
            estimate_similarity(&line, &line, true),
            Err(TransferError::DegeneratePlacement { points: 5 })
        ));
        assert!(estimate_similarity(&line[..2], &line[..2], false).is_err());
    }
}
