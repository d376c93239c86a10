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
