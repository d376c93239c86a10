//! Barycentric interpolation (Terissi et al. 2011, §5.2, eq. 4–5), in a frame that moves
//! with each control triangle.
//!
//! Eq. 5 as printed, `γ_k = Z⁻¹ v_k` with the three control points as the columns of `Z`,
//! reproduces `v_k = Z γ_k` (eq. 4) only while the head stays where it was: translating
//! everything by `t` gives `Z′γ_k = v_k + t·Σγ` and `Σγ ≠ 1` in general
//! ([`paper_coefficients`] keeps the printed form for the test that shows it). Here each
//! vertex is written in the triangle's own frame instead: `v = z₁ + a·e₁ + b·e₂ + c·ñ` with
//! `e₁ = z₂ − z₁`, `e₂ = z₃ − z₁` and `ñ = (e₁ × e₂)/√‖e₁ × e₂‖` (a normal that scales like
//! the edges), which rotations, translations and uniform scalings carry exactly.

use crate::math::{Matrix3, Point3, Vector3};

/// A vertex bound to one control triangle by its frame coordinates `(a, b, c)`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Binding {
    pub vertex: usize,
    pub triangle: usize,
    pub coords: Vector3,
}

fn frame(z: &[Point3; 3]) -> Option<Matrix3> {
    let (e1, e2) = (z[1] - z[0], z[2] - z[0]);
    let cross = e1.cross(&e2);
    let len = cross.norm();
    if len.is_nan() || len <= 0.0 {
        return None;
    }
    Some(Matrix3::from_columns(&[e1, e2, cross / len.sqrt()]))
}

/// The frame coordinates `(a, b, c)` of `v` in triangle `z`; `None` for a degenerate one.
pub fn frame_coordinates(z: &[Point3; 3], v: &Point3) -> Option<Vector3> {
    frame(z)?.try_inverse().map(|inv| inv * (v - z[0]))
}

/// The point with frame coordinates `coords` in triangle `z` (a degenerate one gives `z₁`).
pub fn frame_point(z: &[Point3; 3], coords: &Vector3) -> Point3 {
    frame(z).map_or(z[0], |f| z[0] + f * coords)
}

/// Eq. 5 as printed: `γ = Z⁻¹ v`, `Z` having the control points as columns.
pub fn paper_coefficients(z: &[Point3; 3], v: &Point3) -> Option<Vector3> {
    Matrix3::from_columns(&[z[0].coords, z[1].coords, z[2].coords])
        .try_inverse()
        .map(|i| i * v.coords)
}

/// Eq. 4: `v = γ₁z₁ + γ₂z₂ + γ₃z₃`.
pub fn paper_point(z: &[Point3; 3], gamma: &Vector3) -> Point3 {
    Point3::from(gamma.x * z[0].coords + gamma.y * z[1].coords + gamma.z * z[2].coords)
}

/// Distance from `v` to triangle `z` and whether its projection falls inside.
fn distance_to_triangle(z: &[Point3; 3], v: &Point3) -> (f64, bool) {
    if let Some(c) = frame_coordinates(z, v) {
        let (a, b) = (c.x, c.y);
        if a >= 0.0 && b >= 0.0 && a + b <= 1.0 {
            let n = (z[1] - z[0]).cross(&(z[2] - z[0])).normalize();
            return ((v - z[0]).dot(&n).abs(), true);
        }
    }
    let segment = |p: &Point3, q: &Point3| {
        let d = q - p;
        let t = ((v - p).dot(&d) / d.norm_squared().max(f64::MIN_POSITIVE)).clamp(0.0, 1.0);
        (v - (p + t * d)).norm()
    };
    let d = segment(&z[0], &z[1]).min(segment(&z[1], &z[2])).min(segment(&z[2], &z[0]));
    (d, false)
}

/// Binds each of `vertices` (indices into `points`) to a control triangle (corners are
/// indices into `controls`): the triangle over which it lies with the smallest depth, if
/// that depth is within `depth_gate`; otherwise the nearest triangle.
pub fn bind_vertices(
    points: &[Point3],
    vertices: &[usize],
    controls: &[Point3],
    triangles: &[[usize; 3]],
    depth_gate: f64,
) -> Vec<Binding> {
    let corners: Vec<[Point3; 3]> = triangles.iter().map(|t| t.map(|c| controls[c])).collect();
    vertices
        .iter()
        .filter_map(|&vertex| {
            let v = &points[vertex];
            let mut over: Option<(f64, usize)> = None;
            let mut nearest: Option<(f64, usize)> = None;
            for (i, z) in corners.iter().enumerate() {
                let (d, inside) = distance_to_triangle(z, v);
                if inside && d <= depth_gate && over.is_none_or(|(b, _)| d < b) {
                    over = Some((d, i));
                }
                if nearest.is_none_or(|(b, _)| d < b) {
                    nearest = Some((d, i));
                }
            }
            let (_, triangle) = over.or(nearest)?;
            let coords = frame_coordinates(&corners[triangle], v)?;
            Some(Binding { vertex, triangle, coords })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Unit};

    fn tri() -> [Point3; 3] {
        [Point3::new(1.0, 0.2, 3.0), Point3::new(2.0, 0.1, 3.3), Point3::new(1.2, 1.4, 2.8)]
    }

    #[test]
    fn moving_frame_is_exact_under_similarity_and_eq5_is_not() {
        let z = tri();
        let v = Point3::new(1.5, 0.6, 3.9);
        let c = frame_coordinates(&z, &v).unwrap();
        assert!((frame_point(&z, &c) - v).norm() < 1e-14);
        let r = Rotation3::from_axis_angle(&Unit::new_normalize(Vector3::new(1.0, 2.0, -0.5)), 1.1);
        let t = Vector3::new(10.0, -4.0, 2.5);
        let moved = z.map(|p| Point3::from(2.0 * (r * p.coords) + t));
        let expect = Point3::from(2.0 * (r * v.coords) + t);
        assert!((frame_point(&moved, &c) - expect).norm() < 1e-12 * expect.coords.norm());
        // Eq. 5 as printed reproduces the rest pose but not the translated one.
        let gamma = paper_coefficients(&z, &v).unwrap();
        assert!((paper_point(&z, &gamma) - v).norm() < 1e-12);
        let shifted = z.map(|p| p + t);
        let err = (paper_point(&shifted, &gamma) - (v + t)).norm();
        assert!(err > 0.1 * t.norm(), "eq. 5 error {err}");
    }

    #[test]
    fn binds_over_then_nearest() {
        let controls = vec![
            Point3::new(0.0, 0.0, 0.0),
            Point3::new(1.0, 0.0, 0.0),
            Point3::new(0.0, 1.0, 0.0),
            Point3::new(1.0, 1.0, 0.5),
        ];
        let triangles = [[0, 1, 2], [1, 3, 2]];
        let points = vec![
            Point3::new(0.2, 0.2, 0.05),
            Point3::new(3.0, 3.0, 0.0),
            Point3::new(0.2, 0.2, 5.0),
        ];
        let b = bind_vertices(&points, &[0, 1, 2], &controls, &triangles, 0.5);
        assert_eq!(b[0].triangle, 0);
        assert_eq!(b[1].triangle, 1);
        assert_eq!(b.len(), 3);
    }
}
