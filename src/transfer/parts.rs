//! Disconnected parts of the target (teeth, tongue, eyes: connected parts of the mesh
//! that no control reaches): held still with the head, carried rigidly with the jaw (Kabsch
//! on the chin controls), or following the nearest moving skin vertex. Which parts go with
//! the jaw is decided in the head's own frame ([`JawZone`]), never along the world's axes.

use super::similarity::estimate_similarity;
use crate::math::{Point3, Vector3};

/// How parts that no control reaches move.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PartsMode {
    /// With the head's rigid pose only.
    Static,
    /// Parts below the mouth corners and near the mouth rigidly with the jaw, the rest with
    /// the head.
    #[default]
    Jaw,
    /// Each vertex with the displacement of its nearest interpolated skin vertex.
    NearestSurface,
}

/// Which part vertex moves how, decided once at setup.
#[derive(Clone, Debug, Default)]
pub struct PartsPlan {
    /// Vertices carried by the jaw's rigid motion.
    pub jaw: Vec<usize>,
    /// Control indices whose motion defines the jaw.
    pub jaw_controls: Vec<usize>,
    /// (vertex, skin vertex it follows).
    pub followers: Vec<(usize, usize)>,
}

/// Where the parts that move with the jaw lie, in the head's frame.
#[derive(Clone, Debug, PartialEq)]
pub struct JawZone {
    /// The head's up direction.
    pub up: Vector3,
    /// Height (along `up`) of the mouth corners: a jaw part's centroid lies below it.
    pub corner_height: f64,
    /// The mouth's middle, and how far from it a jaw part's centroid may lie.
    pub centre: Point3,
    pub reach: f64,
    /// Control indices whose motion defines the jaw (at least three).
    pub controls: Vec<usize>,
}

impl JawZone {
    fn holds(&self, centroid: &Point3) -> bool {
        centroid.coords.dot(&self.up) < self.corner_height
            && (centroid - self.centre).norm() <= self.reach
    }
}

/// Plans the motion of `part_vertices` (grouped by `part` id): in the jaw mode, parts whose
/// centroid lies in `jaw` follow its controls and the rest stay with the head (all of them
/// without a zone); `skin` lists the moving skin vertices to follow.
pub fn plan_parts(
    mode: PartsMode,
    points: &[Point3],
    part_vertices: &[usize],
    part: &[usize],
    jaw: Option<JawZone>,
    skin: &[usize],
) -> PartsPlan {
    match mode {
        PartsMode::Static => PartsPlan::default(),
        PartsMode::Jaw => {
            let Some(zone) = jaw.filter(|z| z.controls.len() >= 3) else {
                return PartsPlan::default();
            };
            let mut sums: std::collections::HashMap<usize, (Vector3, usize)> = Default::default();
            for &v in part_vertices {
                let e = sums.entry(part[v]).or_insert((Vector3::zeros(), 0));
                e.0 += points[v].coords;
                e.1 += 1;
            }
            let jaw = part_vertices
                .iter()
                .copied()
                .filter(|&v| {
                    let (sum, n) = sums[&part[v]];
                    zone.holds(&Point3::from(sum / n as f64))
                })
                .collect();
            PartsPlan { jaw, jaw_controls: zone.controls, followers: Vec::new() }
        }
        PartsMode::NearestSurface => {
            let followers = part_vertices
                .iter()
                .filter_map(|&v| {
                    skin.iter()
                        .copied()
                        .min_by(|&a, &b| {
                            (points[a] - points[v])
                                .norm_squared()
                                .total_cmp(&(points[b] - points[v]).norm_squared())
                        })
                        .map(|s| (v, s))
                })
                .collect();
            PartsPlan { followers, ..PartsPlan::default() }
        }
    }
}

impl PartsPlan {
    /// Adds the parts' displacements (in the head's pose-free frame) to `displacement`,
    /// given the controls' rest and current positions in that frame. Skin displacements
    /// must already be in `displacement` for followers.
    pub fn displace(
        &self,
        points: &[Point3],
        rest: &[Point3],
        current: &[Point3],
        displacement: &mut [Vector3],
    ) {
        if !self.jaw.is_empty() {
            let from: Vec<Point3> = self.jaw_controls.iter().map(|&c| rest[c]).collect();
            let to: Vec<Point3> = self.jaw_controls.iter().map(|&c| current[c]).collect();
            // Collinear chin controls leave the jaw parts where they are.
            if let Ok(jaw) = estimate_similarity(&from, &to, false) {
                for &v in &self.jaw {
                    displacement[v] = jaw.apply(&points[v]) - points[v];
                }
            }
        }
        for &(v, s) in &self.followers {
            displacement[v] = displacement[s];
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::{Rotation3, Vector3 as V};

    #[test]
    fn jaw_parts_turn_with_the_chin_and_followers_copy() {
        let points = vec![
            Point3::new(0.0, -1.0, 0.0), // control 0 (chin)
            Point3::new(1.0, -1.2, 0.0), // control 1
            Point3::new(0.0, -1.1, 1.0), // control 2
            Point3::new(0.2, -0.8, 0.3), // lower tooth (part 3)
            Point3::new(0.2, 0.5, 0.3),  // upper tooth (part 4)
        ];
        let part = vec![0, 0, 0, 3, 4];
        let zone = |reach: f64| JawZone {
            up: V::y(),
            corner_height: 0.0,
            centre: Point3::new(0.0, 0.0, 0.3),
            reach,
            controls: vec![0, 1, 2],
        };
        let plan = plan_parts(PartsMode::Jaw, &points, &[3, 4], &part, Some(zone(2.0)), &[]);
        assert_eq!(plan.jaw, vec![3]);
        // A loose piece below the mouth but far from it stays with the head.
        let far = plan_parts(PartsMode::Jaw, &points, &[3, 4], &part, Some(zone(0.5)), &[]);
        assert!(far.jaw.is_empty());
        let rot = Rotation3::from_axis_angle(&V::x_axis(), 0.2);
        let rest: Vec<Point3> = points[..3].to_vec();
        let current: Vec<Point3> = rest.iter().map(|p| rot * p).collect();
        let mut d = vec![V::zeros(); 5];
        plan.displace(&points, &rest, &current, &mut d);
        assert!((points[3] + d[3] - rot * points[3]).norm() < 1e-12);
        assert_eq!(d[4], V::zeros());

        let plan = plan_parts(PartsMode::NearestSurface, &points, &[3], &part, None, &[0, 1]);
        let mut d = vec![V::zeros(); 5];
        d[0] = V::new(0.0, 0.5, 0.0);
        plan.displace(&points, &rest, &rest, &mut d);
        assert_eq!(d[3], V::new(0.0, 0.5, 0.0));
        let one_control = JawZone { controls: vec![0], ..zone(2.0) };
        assert!(
            plan_parts(PartsMode::Jaw, &points, &[3], &part, Some(one_control), &[]).jaw.is_empty()
        );
    }
}
