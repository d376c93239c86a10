//! The motion representation (Ma & Deng §3.1, §5.1): per frame the pose-free shape minus the
//! clip's neutral shape, split into facial regions, each reduced by PCA.
//!
//! Regions come from the landmark map: every vertex joins the region of the nearest mapped
//! landmark on the mean shape (mouth 48–67, nose 27–35, eyes 36–47, brows and forehead
//! 17–26, the jaw/cheek of the subject's right 0–8 and left 9–16). Shapes are linear in the
//! model coefficients, `d = B·δ` with `δ = c − c_neutral`, so each region's covariance
//! `B_r C B_rᵀ` is diagonalised through the small M×M matrix `Lᵀ B_rᵀB_r L` (`C = LLᵀ`)
//! instead of the 3N_r×3N_r one. Coefficients are projections in model units (mm) divided
//! by one scale for all regions, so the smoothness weight λ of eq. 1 means the same
//! everywhere; whitening per region would blow up the noise of a region that barely moves.

use super::SaqpError;
use super::corpus::LinearShapes;
use crate::math::{DMatrix, DVector, Point3};
use crate::model::LandmarkMap;
use serde::{Deserialize, Serialize};

/// A facial region of the paper's region-based PCA.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum Region {
    Mouth,
    Nose,
    Eyes,
    Brows,
    /// Jaw and cheek of the subject's right (iBUG 0–8, the chin included).
    RightJaw,
    /// Jaw and cheek of the subject's left (iBUG 9–16).
    LeftJaw,
}

impl Region {
    pub const ALL: [Region; 6] = [
        Region::Mouth,
        Region::Nose,
        Region::Eyes,
        Region::Brows,
        Region::RightJaw,
        Region::LeftJaw,
    ];

    /// The region of a 0-based iBUG landmark.
    pub fn of_landmark(l: usize) -> Option<Region> {
        Some(match l {
            0..=8 => Region::RightJaw,
            9..=16 => Region::LeftJaw,
            17..=26 => Region::Brows,
            27..=35 => Region::Nose,
            36..=47 => Region::Eyes,
            48..=67 => Region::Mouth,
            _ => return None,
        })
    }

    pub fn name(self) -> &'static str {
        match self {
            Region::Mouth => "mouth",
            Region::Nose => "nose",
            Region::Eyes => "eyes",
            Region::Brows => "brows",
            Region::RightJaw => "right jaw",
            Region::LeftJaw => "left jaw",
        }
    }
}

/// What the PCA of one region kept.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct RegionSummary {
    pub region: Region,
    pub vertices: usize,
    pub dims: usize,
    /// Fraction of the region's motion variance the kept dimensions explain (1 when the
    /// region does not move at all).
    pub variance_kept: f64,
}

/// One region's PCA in model-coefficient space.
#[derive(Clone, Debug, PartialEq)]
struct RegionBasis {
    /// `k × M`: region coefficients `a_r = P_r (δ − δ̄)` (before the common scale).
    projection: DMatrix,
    /// `M × k`: `δ̄ + G_r a_r` reproduces the region's motion through the model basis.
    reconstruction: DMatrix,
    /// Offset of this region's coefficients in the concatenated vector.
    offset: usize,
}

/// Region-based PCA of a corpus's motion.
#[derive(Clone, Debug, PartialEq)]
pub struct MotionBasis {
    mean_delta: DVector,
    regions: Vec<RegionBasis>,
    vertex_region: Vec<Region>,
    scale: f64,
    summaries: Vec<RegionSummary>,
}

/// Assigns every vertex to the region of the nearest mapped landmark on the mean shape.
fn assign_regions(
    shapes: &LinearShapes,
    landmarks: &LandmarkMap,
) -> Result<Vec<Region>, SaqpError> {
    let n = shapes.num_vertices();
    let vertex =
        |v: usize| Point3::new(shapes.mean[3 * v], shapes.mean[3 * v + 1], shapes.mean[3 * v + 2]);
    let labelled: Vec<(Point3, Region)> = landmarks
        .pairs()
        .filter(|&(_, v)| v < n)
        .filter_map(|(l, v)| Region::of_landmark(l).map(|r| (vertex(v), r)))
        .collect();
    if labelled.is_empty() {
        return Err(SaqpError::NoLandmarks(n));
    }
    Ok((0..n)
        .map(|v| {
            let p = vertex(v);
            labelled
                .iter()
                .min_by(|a, b| (a.0 - p).norm_squared().total_cmp(&(b.0 - p).norm_squared()))
                .map_or(Region::Mouth, |x| x.1)
        })
        .collect())
}

impl MotionBasis {
    /// Builds the region PCA from motion deltas `δ = c − c_neutral` (one per frame), keeping
    /// per region the fewest components that explain at least `keep` of its variance.
    ///
    /// # Errors
    /// No landmark inside the model, no deltas, or no motion at all.
    pub fn build(
        shapes: &LinearShapes,
        landmarks: &LandmarkMap,
        deltas: &[DVector],
        keep: f64,
    ) -> Result<Self, SaqpError> {
        let vertex_region = assign_regions(shapes, landmarks)?;
        let m = shapes.num_coefficients();
        if deltas.is_empty() {
            return Err(SaqpError::NoMotion);
        }
        let count = deltas.len() as f64;
        let mean_delta = deltas.iter().fold(DVector::zeros(m), |acc, d| acc + d) / count;
        let mut cov = DMatrix::zeros(m, m);
        for d in deltas {
            let x = d - &mean_delta;
            cov.ger(1.0 / count, &x, &x, 1.0);
        }
        let eig = cov.symmetric_eigen();
        let mut l = eig.eigenvectors.clone();
        for (j, mut col) in l.column_iter_mut().enumerate() {
            col *= eig.eigenvalues[j].max(0.0).sqrt();
        }
        let mut grams: Vec<DMatrix> = Region::ALL.iter().map(|_| DMatrix::zeros(m, m)).collect();
        let mut counts = [0usize; 6];
        for (v, r) in vertex_region.iter().enumerate() {
            let ri = Region::ALL.iter().position(|x| x == r).unwrap_or(0);
            counts[ri] += 1;
            let rows = shapes.basis.rows(3 * v, 3);
            grams[ri] += rows.tr_mul(&rows);
        }
        let (mut regions, mut summaries, mut offset, mut kept_total) = (vec![], vec![], 0, 0.0);
        for (ri, h) in grams.iter().enumerate() {
            let g = l.tr_mul(h) * &l;
            let e = g.symmetric_eigen();
            let mut order: Vec<usize> = (0..m).collect();
            order.sort_by(|&a, &b| e.eigenvalues[b].total_cmp(&e.eigenvalues[a]));
            let total: f64 = e.eigenvalues.iter().map(|x| x.max(0.0)).sum();
            let tiny = 1e-12 * total.max(f64::MIN_POSITIVE);
            let (mut k, mut acc) = (0, 0.0);
            while k < m && total > 0.0 && acc < keep * total && e.eigenvalues[order[k]] > tiny {
                acc += e.eigenvalues[order[k]];
                k += 1;
            }
            let mut reconstruction = DMatrix::zeros(m, k);
            for (j, &col) in order.iter().take(k).enumerate() {
                let mu = e.eigenvalues[col];
                reconstruction.set_column(j, &(&l * e.eigenvectors.column(col) / mu.sqrt()));
            }
            let projection = reconstruction.tr_mul(h);
            kept_total += acc;
            summaries.push(RegionSummary {
                region: Region::ALL[ri],
                vertices: counts[ri],
                dims: k,
                variance_kept: if total > 0.0 { acc / total } else { 1.0 },
            });
            regions.push(RegionBasis { projection, reconstruction, offset });
            offset += k;
        }
        if offset == 0 || kept_total <= 0.0 {
            return Err(SaqpError::NoMotion);
        }
        let scale = (kept_total / offset as f64).sqrt();
        Ok(Self { mean_delta, regions, vertex_region, scale, summaries })
    }

    /// Total number of coefficients K (the paper's 27).
    pub fn dims(&self) -> usize {
        self.regions.iter().map(|r| r.projection.nrows()).sum()
    }

    /// Per region: vertices, dimensions kept and the variance they explain.
    pub fn summaries(&self) -> &[RegionSummary] {
        &self.summaries
    }

    /// The region of every vertex.
    pub fn vertex_regions(&self) -> &[Region] {
        &self.vertex_region
    }

    /// The common scale (model units per coefficient unit).
    pub fn scale(&self) -> f64 {
        self.scale
    }

    /// The K region coefficients of a motion delta `δ = c − c_neutral`.
    pub fn encode(&self, delta: &DVector) -> DVector {
        let x = delta - &self.mean_delta;
        let mut a = DVector::zeros(self.dims());
        for r in &self.regions {
            let k = r.projection.nrows();
            a.rows_mut(r.offset, k).copy_from(&(&r.projection * &x / self.scale));
        }
        a
    }

    /// For the given vertices: `(J, o)` with the vertices' displacement from the neutral
    /// shape `= o + J·a` for region coefficients `a` (J is 3n × K, o is 3n).
    pub fn vertex_map(&self, shapes: &LinearShapes, vertices: &[usize]) -> (DMatrix, DVector) {
        let (n, kdim) = (vertices.len(), self.dims());
        let mut j = DMatrix::zeros(3 * n, kdim);
        let mut o = DVector::zeros(3 * n);
        for (i, &v) in vertices.iter().enumerate() {
            let rows = shapes.basis.rows(3 * v, 3);
            o.rows_mut(3 * i, 3).copy_from(&(rows * &self.mean_delta));
            let ri = Region::ALL.iter().position(|x| *x == self.vertex_region[v]).unwrap_or(0);
            let r = &self.regions[ri];
            let k = r.reconstruction.ncols();
            if k > 0 {
                let block = rows * &r.reconstruction * self.scale;
                j.view_mut((3 * i, r.offset), (3, k)).copy_from(&block);
            }
        }
        (j, o)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Four vertices (two mouth, two nose) moved by two model coefficients.
    fn toy() -> (LinearShapes, LandmarkMap) {
        let mean = DVector::from_vec(vec![0., 0., 0., 1., 0., 0., 0., 10., 0., 1., 10., 0.]);
        let mut basis = DMatrix::zeros(12, 2);
        basis[(1, 0)] = 1.0; // mouth vertex 0 moves in y with c0
        basis[(4, 0)] = -1.0;
        basis[(7, 1)] = 0.5; // nose vertices move with c1
        basis[(10, 1)] = 0.5;
        let map =
            LandmarkMap { to_vertex: [(48, 0), (54, 1), (30, 2), (33, 3)].into_iter().collect() };
        (LinearShapes { mean, basis }, map)
    }

    #[test]
    fn regions_split_and_reconstruct_exactly() {
        let (shapes, map) = toy();
        let deltas: Vec<DVector> = (0..20)
            .map(|i| DVector::from_vec(vec![(i as f64 * 0.7).sin(), (i as f64 * 0.3).cos()]))
            .collect();
        let basis = MotionBasis::build(&shapes, &map, &deltas, 0.95).unwrap();
        let s = basis.summaries();
        assert_eq!(s[0].region, Region::Mouth);
        assert_eq!((s[0].vertices, s[0].dims), (2, 1));
        assert_eq!((s[1].vertices, s[1].dims), (2, 1));
        assert_eq!(basis.dims(), 2);
        let verts = [0, 1, 2, 3];
        let (j, o) = basis.vertex_map(&shapes, &verts);
        for d in &deltas {
            let a = basis.encode(d);
            let rec = &o + &j * &a;
            let truth = &shapes.basis * d;
            assert!((rec - truth).norm() < 1e-10);
        }
    }

    #[test]
    fn no_motion_is_an_error() {
        let (shapes, map) = toy();
        let deltas = vec![DVector::zeros(2); 5];
        assert_eq!(MotionBasis::build(&shapes, &map, &deltas, 0.95), Err(SaqpError::NoMotion));
    }
}
