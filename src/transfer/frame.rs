//! The head's own frame: the axes every geometric decision of the transfer is taken in, so
//! that a head standing y-up, z-up or facing −z, anywhere in space, is treated the same.
//!
//! The axes come from the head's landmarks ([`face_axes`]: up from the mouth and chin to the
//! eyes and brows, forward towards the nose); a map without those groups falls back to the
//! points' principal axes, which fix extents but not directions.

use crate::math::{Matrix3, Point3, Vector3};
use crate::model::LandmarkMap;
use crate::model::map_check::face_axes;
use std::collections::BTreeMap;

/// Axes of a head, as rows of a rotation (x to the subject's left, up, forward).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeadFrame {
    pub axes: Matrix3,
    /// Whether the axes are the face's (landmarks) rather than principal axes, whose signs
    /// and order mean nothing anatomically.
    pub anatomical: bool,
}

impl HeadFrame {
    /// The face's axes from the landmarks `map` puts on `points`; `None` without points
    /// above and below the nose or without a nose point.
    pub fn from_landmarks(map: &LandmarkMap, points: &[Point3]) -> Option<Self> {
        let labelled: BTreeMap<usize, Point3> =
            map.pairs().filter_map(|(l, v)| Some((l, *points.get(v)?))).collect();
        face_axes(&labelled).map(|axes| Self { axes, anatomical: true })
    }

    /// The face's axes when the landmarks give them, else the principal axes of `fallback`.
    pub fn of_head(map: &LandmarkMap, points: &[Point3], fallback: &[Point3]) -> Self {
        Self::from_landmarks(map, points).unwrap_or_else(|| Self::principal(fallback))
    }

    /// The principal axes of `points` (eigenvectors of their covariance), largest first.
    pub fn principal(points: &[Point3]) -> Self {
        let n = points.len().max(1) as f64;
        let mean = points.iter().fold(Vector3::zeros(), |a, p| a + p.coords) / n;
        let cov = points.iter().fold(Matrix3::zeros(), |a, p| {
            let d = p.coords - mean;
            a + d * d.transpose()
        }) / n;
        let eigen = cov.symmetric_eigen();
        let mut order = [0usize, 1, 2];
        order.sort_by(|&a, &b| eigen.eigenvalues[b].total_cmp(&eigen.eigenvalues[a]));
        let rows = order.map(|k| eigen.eigenvectors.column(k).transpose());
        Self { axes: Matrix3::from_rows(&rows), anatomical: false }
    }

    /// `p` in the head's axes.
    pub fn local(&self, p: &Point3) -> Vector3 {
        self.axes * p.coords
    }

    /// The head's up direction (in the head's space).
    pub fn up(&self) -> Vector3 {
        self.axes.row(1).transpose()
    }

    /// The direction to the subject's left (in the head's space).
    pub fn left(&self) -> Vector3 {
        self.axes.row(0).transpose()
    }

    /// The diagonal of the bounding box of `points` along these axes: a size that turns and
    /// moves with the head (0 when empty).
    pub fn extent_diagonal(&self, points: &[Point3]) -> f64 {
        let local: Vec<Point3> = points.iter().map(|p| Point3::from(self.local(p))).collect();
        super::surface::bounding_diagonal(&local)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Rotation3;

    /// A face-like set: eyes and brows up, mouth and chin down, the nose forward.
    fn face() -> (LandmarkMap, Vec<Point3>) {
        let points = vec![
            Point3::new(-3.0, 2.0, 0.0),  // 36
            Point3::new(3.0, 2.0, 0.0),   // 45
            Point3::new(0.0, 0.0, 2.0),   // 30
            Point3::new(-2.0, -3.0, 0.5), // 48
            Point3::new(2.0, -3.0, 0.5),  // 54
            Point3::new(0.0, -6.0, 0.0),  // 8
        ];
        let map = LandmarkMap { to_vertex: [36, 45, 30, 48, 54, 8].into_iter().zip(0..).collect() };
        (map, points)
    }

    #[test]
    fn axes_turn_with_the_head_and_extents_do_not_change() {
        let (map, points) = face();
        let frame = HeadFrame::from_landmarks(&map, &points).unwrap();
        assert!(frame.anatomical);
        assert!((frame.up() - Vector3::y()).norm() < 0.1, "{}", frame.up());
        assert!(frame.left().x > 0.99, "x is the subject's left: {}", frame.left());
        let r = Rotation3::from_euler_angles(1.2, -0.4, 2.5);
        let moved: Vec<Point3> =
            points.iter().map(|p| r * p + Vector3::new(5.0, -2.0, 9.0)).collect();
        let turned = HeadFrame::from_landmarks(&map, &moved).unwrap();
        assert!((turned.up() - r * frame.up()).norm() < 1e-12);
        assert!((turned.extent_diagonal(&moved) - frame.extent_diagonal(&points)).abs() < 1e-12);
        let p = HeadFrame::principal(&points);
        let q = HeadFrame::principal(&moved);
        assert!(!p.anatomical);
        assert!((p.extent_diagonal(&points) - q.extent_diagonal(&moved)).abs() < 1e-9);
        assert!(HeadFrame::from_landmarks(&LandmarkMap::default(), &points).is_none());
    }
}
