//! Applying a set-up transfer to one frame. The head's rigid pose is factored out first
//! (Kabsch on the stable controls), the pose-free control displacements are interpolated,
//! and the pose is put back, so a rigid motion of the controls moves every vertex
//! rigidly whatever the interpolation (a displacement field alone cannot rotate).
//!
//! Controls move by the source's displacement from its reference, except the inner lips'
//! vertical gap, which is the source's own (scaled): a relative displacement would keep the
//! target's rest gap as an offset, so a head modelled with parted lips would never close
//! them (docs/transfer.md).

use super::TransferError;
use super::barycentric::frame_point;
use super::setup::{Interpolator, Transfer};
use super::similarity::{Similarity, estimate_similarity};
use crate::math::{DVector, Point3, Vector3};

impl Transfer {
    /// The target's vertices (flat `x0 y0 z0 …`, all vertices) for one source shape (flat,
    /// the source model's layout). The source's own rigid motion (Kabsch on its stable
    /// controls) is carried over as the conjugate motion in target space; the rest of its
    /// motion moves the controls by `s·R·(x − x_ref)`, and each inner-lip pair then opens
    /// (along the head's up direction) to `s` times the source's gap, never below zero.
    ///
    /// # Errors
    /// `ShapeLength` or `NonFinite` for a bad shape.
    pub fn apply(&self, shape: &DVector) -> Result<DVector, TransferError> {
        let expected = 3 * self.reference.len();
        if shape.len() != expected {
            return Err(TransferError::ShapeLength { len: shape.len(), expected });
        }
        if shape.iter().any(|x| !x.is_finite()) {
            return Err(TransferError::NonFinite);
        }
        let at = |v: usize| Point3::new(shape[3 * v], shape[3 * v + 1], shape[3 * v + 2]);
        let stable_src: Vec<usize> = self.stable.iter().map(|&c| self.source_controls[c]).collect();
        let from: Vec<Point3> = stable_src.iter().map(|&v| self.reference[v]).collect();
        let to: Vec<Point3> = stable_src.iter().map(|&v| at(v)).collect();
        let pose =
            estimate_similarity(&from, &to, false).unwrap_or_else(|_| Similarity::identity());
        let t = &self.placement.similarity;
        // The source pose seen in target space: p ↦ T(P(T⁻¹(p))).
        let rotation = t.rotation * pose.rotation * t.rotation.transpose();
        let translation =
            t.translation + t.scale * (t.rotation * pose.translation) - rotation * t.translation;
        let target_pose = Similarity { scale: 1.0, rotation, translation };
        let free: Vec<Point3> =
            self.source_controls.iter().map(|&sv| pose.apply_inverse(&at(sv))).collect();
        let mut moved: Vec<Point3> = self
            .source_controls
            .iter()
            .zip(&self.target_controls)
            .zip(&free)
            .map(|((&sv, &tv), x)| self.rest[tv] + t.apply_vector(&(x - self.reference[sv])))
            .collect();
        let up_source = self.source_up;
        let up = t.rotation * up_source;
        for &(upper, lower) in &self.lip_pairs {
            let wanted = (t.scale * (free[upper] - free[lower]).dot(&up_source)).max(0.0);
            let correction = 0.5 * (wanted - (moved[upper] - moved[lower]).dot(&up)) * up;
            moved[upper] += correction;
            moved[lower] -= correction;
        }
        let positions: Vec<Point3> = moved.iter().map(|p| target_pose.apply(p)).collect();
        self.apply_controls(&positions)
    }

    /// The target's vertices (flat) when the controls are at `positions` (target space,
    /// control order).
    ///
    /// # Errors
    /// `ControlCount` for the wrong number of positions, `NonFinite` for a bad one.
    pub fn apply_controls(&self, positions: &[Point3]) -> Result<DVector, TransferError> {
        let n_controls = self.target_controls.len();
        if positions.len() != n_controls {
            return Err(TransferError::ControlCount { got: positions.len(), expected: n_controls });
        }
        if positions.iter().any(|p| !p.coords.iter().all(|x| x.is_finite())) {
            return Err(TransferError::NonFinite);
        }
        let rest: Vec<Point3> = self.target_controls.iter().map(|&v| self.rest[v]).collect();
        let from: Vec<Point3> = self.stable.iter().map(|&c| rest[c]).collect();
        let to: Vec<Point3> = self.stable.iter().map(|&c| positions[c]).collect();
        let pose =
            estimate_similarity(&from, &to, false).unwrap_or_else(|_| Similarity::identity());
        let current: Vec<Point3> = positions.iter().map(|p| pose.apply_inverse(p)).collect();
        let mut displacement = vec![Vector3::zeros(); self.rest.len()];
        for (c, &v) in self.target_controls.iter().enumerate() {
            displacement[v] = current[c] - rest[c];
        }
        match &self.interpolator {
            Interpolator::Biharmonic(system) => {
                let deltas: Vec<Vector3> = (0..n_controls).map(|c| current[c] - rest[c]).collect();
                for (v, d) in system.solve(&deltas) {
                    displacement[v] = d;
                }
            }
            Interpolator::Barycentric(bindings) => {
                for b in bindings {
                    let z = self.triangles[b.triangle].map(|c| current[c]);
                    displacement[b.vertex] = frame_point(&z, &b.coords) - self.rest[b.vertex];
                }
            }
        }
        self.parts.displace(&self.rest, &rest, &current, &mut displacement);
        Ok(DVector::from_iterator(
            3 * self.rest.len(),
            self.rest.iter().zip(&displacement).flat_map(|(p, d)| {
                let q = pose.apply(&(p + d));
                [q.x, q.y, q.z]
            }),
        ))
    }

    /// The controls' rest positions on the target (control order).
    pub fn rest_controls(&self) -> Vec<Point3> {
        self.target_controls.iter().map(|&v| self.rest[v]).collect()
    }

    /// A target shape (flat, as [`Transfer::apply`] returns it) taken into the source model's
    /// space by undoing the placement (`T⁻¹`, the inverse similarity): the head then stands
    /// where the source stands, faces where it faces and is seen by the source's fitted
    /// cameras as the source is, so it can be measured exactly as the source is, whatever
    /// the head's own axes (y-up, z-up, facing −z) or size.
    pub fn in_source_space(&self, shape: &DVector) -> DVector {
        let t = &self.placement.similarity;
        let mut out = shape.clone();
        for c in out.as_mut_slice().chunks_exact_mut(3) {
            let p = t.apply_inverse(&Point3::new(c[0], c[1], c[2]));
            c.copy_from_slice(&[p.x, p.y, p.z]);
        }
        out
    }
}
