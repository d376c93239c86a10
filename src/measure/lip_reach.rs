//! How far a model can close its lips: the smallest inner-lip gap v62 − v66 its one-sided
//! expressions reach from a given identity, on the frontal projection (x, y) as the head's H
//! measures it (`measure::mesh`, `MeshDistance::Frontal`): sealed lips may still have the
//! upper lip's stomion a little in front of the lower one's, which is no opening.
//!
//! A fit may only add expression blendshapes (β ≥ 0) to the identity's mouth. When none of
//! them brings the inner lips together, the fitted head cannot seal its lips on a closure
//! however well it is fitted, and the gap it keeps is a property of the model, not a fitting
//! error. With the identity fixed, the gap is linear in β, `g(β) = g₀ + D·β` (2-vectors), and
//! its smallest length is a small non-negative least-squares problem.
//!
//! A fit that chooses its identity too (each frame alone) is held by nothing but the prior,
//! so there the model's limit is the smallest gap over every plausible identity: α within
//! the ball holding 99 % of the unit-variance prior's mass, `|α|² ≤ χ²_K(0.99)`, and β ≥ 0
//! ([`InnerLipGap::smallest_plausible`]).

use crate::landmarks::ibug::point::{STOMION_LOWER, STOMION_UPPER};
use crate::math::{DMatrix, DVector};
use crate::model::{LandmarkMap, MorphableModel};

/// The frontal inner-lip gap vector (x, y of v62 − v66) of a model as a linear function of
/// its coefficients: `mean + identity·α + expressions·β`, cut once out of the model.
#[derive(Clone, Debug)]
pub struct InnerLipGap {
    mean: DVector,
    identity: DMatrix,
    expressions: DMatrix,
}

impl InnerLipGap {
    /// The gap of `model` through `map`; `None` when 62 or 66 is unmapped or out of range.
    pub fn of(model: &MorphableModel, map: &LandmarkMap) -> Option<Self> {
        let (up, low) = (map.vertex(STOMION_UPPER)?, map.vertex(STOMION_LOWER)?);
        let at = |v: usize| model.shape.mean.rows(3 * v, 2).into_owned();
        let frontal = |m: DMatrix| m.rows(0, 2).into_owned();
        Some(Self {
            mean: at(up) - at(low),
            identity: frontal(model.rescaled_basis_rows(up)? - model.rescaled_basis_rows(low)?),
            expressions: frontal(model.expression_rows(up)? - model.expression_rows(low)?),
        })
    }

    /// The gap vector with identity α only.
    fn at_identity(&self, identity: &[f64]) -> DVector {
        let mut g = self.mean.clone();
        add_columns(&mut g, &self.identity, identity);
        g
    }

    /// The gap's length (model units) of a shape with identity α and expressions β.
    pub fn length(&self, identity: &[f64], expression: &[f64]) -> f64 {
        let mut g = self.at_identity(identity);
        add_columns(&mut g, &self.expressions, expression);
        g.norm()
    }

    /// The smallest gap (model units) reachable from identity α with any β ≥ 0, and the β
    /// that reach it; `None` on a numerical failure.
    pub fn smallest(&self, identity: &[f64]) -> Option<(f64, Vec<f64>)> {
        let g0 = self.at_identity(identity);
        let d = &self.expressions;
        if d.ncols() == 0 {
            return Some((g0.norm(), Vec::new()));
        }
        // ½βᵀ(DᵀD)β + g₀ᵀDβ is ½|g₀ + Dβ|² less a constant; a vanishing ridge keeps DᵀD
        // invertible when blendshapes do not move these vertices.
        let mut n = d.transpose() * d;
        let ridge = 1e-12 * (1.0 + n.trace());
        for j in 0..n.ncols() {
            n[(j, j)] += ridge;
        }
        let g = -(d.transpose() * &g0);
        let mut free = vec![false; g.len()];
        let beta = crate::fit::shape::nonnegative_quadratic(&n, &g, &mut free)?;
        let gap = (g0 + d * &beta).norm();
        Some((gap, beta.iter().copied().collect()))
    }
}

impl InnerLipGap {
    /// The smallest gap (model units) reachable with an identity α anywhere in the prior's
    /// 99 % ball (`|α|² ≤ χ²_K(0.99)`, K identity components, [`plausible_radius`]) and any
    /// β ≥ 0; `None` on a numerical failure.
    ///
    /// The convex problem min |g₀ + Aα + Dβ|² subject to |α| ≤ R, β ≥ 0 is solved through
    /// its Lagrangian: for a multiplier μ > 0 the best α given β is
    /// `−Aᵀ(AAᵀ + μI)⁻¹(g₀ + Dβ)` (A has two rows, so the inverse is 2×2) and the gap left
    /// is `μ(AAᵀ + μI)⁻¹(g₀ + Dβ)`, whose squared length weighed by the same matrix is a
    /// quadratic in β solved by NNLS; |α| falls as μ grows, and μ is bisected (on its
    /// logarithm) to the smallest value with |α| ≤ R.
    pub fn smallest_plausible(&self) -> Option<f64> {
        let k = self.identity.ncols();
        if k == 0 {
            return self.smallest(&[]).map(|s| s.0);
        }
        let radius = plausible_radius(k);
        let a = &self.identity;
        let aat = a * a.transpose();
        let scale = 1.0 + aat.trace();
        // The gap and |α| at multiplier μ.
        let at = |mu: f64| -> Option<(f64, f64)> {
            let inv = (&aat + DMatrix::identity(2, 2) * mu).try_inverse()?;
            let m = &inv * mu;
            let d = &self.expressions;
            let beta = if d.ncols() == 0 {
                DVector::zeros(0)
            } else {
                let mut n = d.transpose() * &m * d;
                let ridge = 1e-12 * (1.0 + n.trace());
                for j in 0..n.ncols() {
                    n[(j, j)] += ridge;
                }
                let g = -(d.transpose() * &m * &self.mean);
                let mut free = vec![false; g.len()];
                crate::fit::shape::nonnegative_quadratic(&n, &g, &mut free)?
            };
            let target = &self.mean + d * &beta;
            let alpha = -(a.transpose() * &inv * &target);
            Some(((&m * &target).norm(), alpha.norm()))
        };
        // μ from a vanishing fraction of AAᵀ's scale (α nearly free) up to where α is tiny.
        let (mut lo, mut hi) = ((1e-12 * scale).ln(), (1e12 * scale).ln());
        let (gap, norm) = at(lo.exp())?;
        if norm <= radius {
            return Some(gap);
        }
        for _ in 0..100 {
            let mid = 0.5 * (lo + hi);
            if at(mid.exp())?.1 > radius {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        at(hi.exp()).map(|r| r.0)
    }
}

/// 99 % of a K-dimensional unit-variance Gaussian prior lies within this radius of its
/// mean: √χ²_K(0.99), by Wilson and Hilferty's approximation (1931, "The distribution of
/// chi-square", PNAS 17: χ²_K(p) ≈ K(1 − 2/(9K) + z_p·√(2/(9K)))³, z_0.99 = 2.3263; within
/// 1 % of the exact quantile from K = 2 up).
pub fn plausible_radius(k: usize) -> f64 {
    const Z_99: f64 = 2.326_347_874;
    let k = k as f64;
    let c = 2.0 / (9.0 * k);
    (k * (1.0 - c + Z_99 * c.sqrt()).powi(3)).sqrt()
}

/// `g += m·c` over the first columns of `m` that `c` has values for.
fn add_columns(g: &mut DVector, m: &DMatrix, c: &[f64]) {
    let k = c.len().min(m.ncols());
    if k > 0 {
        g.gemv(1.0, &m.columns(0, k), &DVector::from_column_slice(&c[..k]), 1.0);
    }
}

/// The smallest frontal inner-lip gap (model units) `model` reaches with identity `identity` and any
/// expression coefficients β ≥ 0, and the β that reach it. `None` when 62 or 66 is unmapped
/// or out of range.
pub fn smallest_inner_lip_gap(
    model: &MorphableModel,
    map: &LandmarkMap,
    identity: &[f64],
) -> Option<(f64, Vec<f64>)> {
    InnerLipGap::of(model, map)?.smallest(identity)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::model::{Expressions, PcaModel};

    /// Two vertices (62 ↦ 0, 66 ↦ 1) 10 apart in y, one identity mode and the given
    /// expression deltas of the upper vertex's y.
    fn model(deltas: &[f64]) -> (MorphableModel, LandmarkMap) {
        let mean = DVector::from_vec(vec![0.0, 10.0, 0.0, 0.0, 0.0, 0.0]);
        let basis = DMatrix::from_column_slice(6, 1, &[0.0, 1.0, 0.0, 0.0, 0.0, 0.0]);
        let mut d = DMatrix::zeros(6, deltas.len());
        for (j, v) in deltas.iter().enumerate() {
            d[(1, j)] = *v;
        }
        let model = MorphableModel {
            shape: PcaModel { mean, basis, eigenvalues: DVector::from_element(1, 4.0) },
            expressions: Some(Expressions {
                names: (0..deltas.len()).map(|j| format!("e{j}")).collect(),
                deltas: d,
            }),
            triangles: Vec::new(),
        };
        let map = LandmarkMap { to_vertex: [(STOMION_UPPER, 0), (STOMION_LOWER, 1)].into() };
        (model, map)
    }

    #[test]
    fn a_plausible_identity_closes_only_as_far_as_the_prior_allows() {
        // One identity mode moving the upper vertex by 2σ·α (eigenvalue 4): the gap at α is
        // 10 + 2α, so within the 99 % radius of one dimension (√6.63 = 2.58) it reaches
        // 10 − 5.15; with a blendshape closing by 5 per unit β it reaches 0.
        let (opening, _) = model(&[3.0]);
        let map = LandmarkMap { to_vertex: [(STOMION_UPPER, 0), (STOMION_LOWER, 1)].into() };
        let gap = InnerLipGap::of(&opening, &map).unwrap();
        let r = plausible_radius(1);
        assert!((r * r - 6.635).abs() < 0.1, "{r}");
        let reach = gap.smallest_plausible().unwrap();
        assert!((reach - (10.0 - 2.0 * r)).abs() < 1e-6, "{reach}");
        let (closing, _) = model(&[-5.0]);
        let reach = InnerLipGap::of(&closing, &map).unwrap().smallest_plausible().unwrap();
        assert!(reach < 1e-6, "{reach}");
        // Wilson–Hilferty against exact χ² quantiles (K = 2: −2 ln 0.01 = 9.210; K = 63: 92.010).
        assert!((plausible_radius(2).powi(2) - 9.210).abs() < 0.1);
        assert!((plausible_radius(63).powi(2) - 92.01).abs() < 0.3);
    }

    #[test]
    fn a_closing_blendshape_reaches_zero_and_one_sided_opening_ones_reach_nothing() {
        let (closing, map) = model(&[-5.0, 2.0]);
        let (gap, beta) = smallest_inner_lip_gap(&closing, &map, &[0.0]).unwrap();
        assert!(gap < 1e-6, "{gap} {beta:?}");
        assert!((beta[0] - 2.0).abs() < 1e-6 && beta[1].abs() < 1e-12);
        // Only opening blendshapes: the identity's own gap (10 + 2σ·α with σ = 2) is the limit.
        let (opening, map) = model(&[3.0]);
        let (gap, _) = smallest_inner_lip_gap(&opening, &map, &[0.5]).unwrap();
        assert!((gap - 11.0).abs() < 1e-9, "{gap}");
        let unmapped = LandmarkMap { to_vertex: [(STOMION_UPPER, 0)].into() };
        assert!(smallest_inner_lip_gap(&opening, &unmapped, &[0.0]).is_none());
    }
}
