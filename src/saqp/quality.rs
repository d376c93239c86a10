//! Ground-truth synthesis quality (Ma & Deng eq. 8): marker RMSE of positions and velocities
//! between synthesized and recorded motion, mouth markers weighted by ω_m, mapped to a
//! five-point scale by `5 − 4·Q/ξ`.
//!
//! Markers are the mapped landmark vertices plus face vertices spread evenly over the
//! landmarks' bounding box (farthest-point sampling on the mean shape), so the measure does
//! not depend on the mesh's resolution, as the paper argues for markers.

use super::corpus::LinearShapes;
use super::motion::{MotionBasis, Region};
use crate::math::{DMatrix, DVector, Point3};
use crate::model::LandmarkMap;
use serde::{Deserialize, Serialize};

/// λ₁, the weight of the position term of eq. 8.
pub const LAMBDA_POSITION: f64 = 0.64;
/// λ₂, the weight of the velocity term of eq. 8.
pub const LAMBDA_VELOCITY: f64 = 0.36;

/// The marker vertices and how to get their motion.
#[derive(Clone, Debug, PartialEq)]
pub struct MarkerSet {
    pub vertices: Vec<usize>,
    /// Whether each marker lies in the mouth region (weighted by ω_m).
    pub mouth: Vec<bool>,
    /// `3n × M`: marker displacement from the neutral shape for a model delta δ.
    pub model_rows: DMatrix,
    /// `3n × K` and `3n`: marker displacement `o + J·a` for region coefficients a.
    pub jacobian: DMatrix,
    pub offset: DVector,
}

impl MarkerSet {
    /// The landmark vertices and `extra` evenly spread face vertices.
    pub fn build(
        shapes: &LinearShapes,
        landmarks: &LandmarkMap,
        basis: &MotionBasis,
        extra: usize,
    ) -> Self {
        let n = shapes.num_vertices();
        let p = |v: usize| {
            Point3::new(shapes.mean[3 * v], shapes.mean[3 * v + 1], shapes.mean[3 * v + 2])
        };
        let mut vertices: Vec<usize> = Vec::new();
        for (_, v) in landmarks.pairs() {
            if v < n && !vertices.contains(&v) {
                vertices.push(v);
            }
        }
        let (mut lo, mut hi) =
            (Point3::from([f64::INFINITY; 3]), Point3::from([f64::NEG_INFINITY; 3]));
        for &v in &vertices {
            lo = lo.inf(&p(v));
            hi = hi.sup(&p(v));
        }
        let margin = (hi - lo) * 0.1;
        let (lo, hi) = (lo - margin, hi + margin);
        let candidates: Vec<usize> = (0..n)
            .filter(|&v| {
                let q = p(v);
                (0..3).all(|a| q[a] >= lo[a] && q[a] <= hi[a])
            })
            .collect();
        let mut dist: Vec<f64> = candidates
            .iter()
            .map(|&c| {
                vertices.iter().map(|&v| (p(v) - p(c)).norm_squared()).fold(f64::INFINITY, f64::min)
            })
            .collect();
        for _ in 0..extra {
            let best =
                dist.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)).map(|(i, d)| (i, *d));
            let Some((i, d)) = best else { break };
            if d <= 0.0 {
                break;
            }
            let v = candidates[i];
            vertices.push(v);
            for (j, &c) in candidates.iter().enumerate() {
                dist[j] = dist[j].min((p(v) - p(c)).norm_squared());
            }
        }
        let regions = basis.vertex_regions();
        let mouth = vertices.iter().map(|&v| regions[v] == Region::Mouth).collect();
        let mut model_rows = DMatrix::zeros(3 * vertices.len(), shapes.num_coefficients());
        for (i, &v) in vertices.iter().enumerate() {
            model_rows.rows_mut(3 * i, 3).copy_from(&shapes.basis.rows(3 * v, 3));
        }
        let (jacobian, offset) = basis.vertex_map(shapes, &vertices);
        Self { vertices, mouth, model_rows, jacobian, offset }
    }

    pub fn len(&self) -> usize {
        self.vertices.len()
    }

    pub fn is_empty(&self) -> bool {
        self.vertices.is_empty()
    }

    /// Marker displacements of a frame given by its region coefficients.
    pub fn from_coefficients(&self, a: &DVector) -> DVector {
        &self.offset + &self.jacobian * a
    }
}

/// The squared-error sums of eq. 8, kept apart by marker class so that ω_m can be changed
/// without resynthesizing.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct QualityParts {
    pub position_mouth: f64,
    pub position_other: f64,
    pub velocity_mouth: f64,
    pub velocity_other: f64,
    /// F, the frame count.
    pub frames: usize,
    pub markers: usize,
}

impl QualityParts {
    /// Accumulates synthesized against recorded marker displacements (3 values per marker
    /// per frame); velocities are frame differences times `fps`.
    pub fn measure(truth: &[DVector], synth: &[DVector], mouth: &[bool], fps: f64) -> Self {
        let mut q = Self { frames: truth.len(), markers: mouth.len(), ..Self::default() };
        let mut add = |d: &DVector, pos: bool| {
            for (m, &is_mouth) in mouth.iter().enumerate() {
                let e = d[3 * m].powi(2) + d[3 * m + 1].powi(2) + d[3 * m + 2].powi(2);
                match (pos, is_mouth) {
                    (true, true) => q.position_mouth += e,
                    (true, false) => q.position_other += e,
                    (false, true) => q.velocity_mouth += e,
                    (false, false) => q.velocity_other += e,
                }
            }
        };
        for (t, (g, s)) in truth.iter().zip(synth).enumerate() {
            add(&(s - g), true);
            if t + 1 < truth.len() {
                let dv = ((&synth[t + 1] - s) - (&truth[t + 1] - g)) * fps;
                add(&dv, false);
            }
        }
        q
    }

    /// Q of eq. 8 with mouth weight ω_m (per marker, so Q is in model units).
    pub fn q(&self, omega_m: f64) -> f64 {
        let denom = (self.frames.max(1) * self.markers.max(1)) as f64;
        let w2 = omega_m * omega_m;
        LAMBDA_POSITION * ((w2 * self.position_mouth + self.position_other) / denom).sqrt()
            + LAMBDA_VELOCITY * ((w2 * self.velocity_mouth + self.velocity_other) / denom).sqrt()
    }
}

/// The five-point score of an error `q` when `xi` is the largest error of the data set.
pub fn likert(q: f64, xi: f64) -> f64 {
    5.0 - 4.0 * q / xi
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn eq8_by_hand() {
        // Two markers (mouth, other), two frames; synth off by (1,0,0) on the mouth marker
        // in frame 0 only.
        let truth = vec![DVector::zeros(6), DVector::zeros(6)];
        let mut s0 = DVector::zeros(6);
        s0[0] = 1.0;
        let synth = vec![s0, DVector::zeros(6)];
        let q = QualityParts::measure(&truth, &synth, &[true, false], 10.0);
        assert_eq!((q.position_mouth, q.velocity_mouth), (1.0, 100.0));
        let want = 0.64 * (9.0f64 / 4.0).sqrt() + 0.36 * (900.0f64 / 4.0).sqrt();
        assert!((q.q(3.0) - want).abs() < 1e-12);
        assert!((likert(q.q(3.0), 2.0 * q.q(3.0)) - 3.0).abs() < 1e-12);
    }
}
