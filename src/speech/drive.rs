//! Driving a morphable model's mouth from estimated mouth motion: the coefficients whose
//! shape moves the mouth vertices by a given displacement from a neutral shape.
//!
//! The speech model estimates mouth vertex displacements Δ (3·V_m values, from the visual
//! PCA basis); a whole head needs model coefficients. With U_m the model's basis rows of the
//! mouth vertices (3·V_m × K) and δ the change of coefficients from the neutral's, the
//! regularised least-squares step is
//! `δ = argmin ‖U_m δ − Δ‖² + λ‖δ‖² = (U_mᵀU_m + λI)⁻¹ U_mᵀ Δ`, one fixed matrix applied per
//! frame. λ = ridge · mean(diag U_mᵀU_m) keeps the coefficients the mouth barely sees (the
//! forehead's, say) at the neutral's, since coefficients are in prior units (α ~ N(0, I)).
//!
//! Which coefficients move: the expression blendshapes when the model has them (a speaker's
//! identity does not change while speaking), otherwise the shape PCA coefficients (models
//! whose PCA spans the articulation, like the demo's).

use super::error::{SpeechError, bad};
use crate::math::{DMatrix, DVector, Point3};
use crate::model::MorphableModel;

/// The fixed map from mouth displacements to coefficient changes of one model.
#[derive(Clone, Debug, PartialEq)]
pub struct MouthDriver {
    /// (U_mᵀU_m + λI)⁻¹ U_mᵀ: K × 3·V_m.
    projection: DMatrix,
    /// The expression coefficients move (else the shape ones).
    drives_expression: bool,
    n_mouth: usize,
}

/// A model's coefficients: shape α and expression β.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Coefficients {
    pub identity: Vec<f64>,
    pub expression: Vec<f64>,
}

impl MouthDriver {
    /// The driver of `model`'s vertices `mouth`, with relative ridge `ridge` (module doc).
    ///
    /// # Errors
    /// No mouth vertices, a vertex the model lacks, a model without components, a ridge that
    /// is not positive and finite.
    pub fn new(model: &MorphableModel, mouth: &[usize], ridge: f64) -> Result<Self, SpeechError> {
        if mouth.is_empty() {
            return Err(SpeechError::Empty("mouth vertices"));
        }
        if !(ridge > 0.0 && ridge.is_finite()) {
            return Err(bad("ridge", ridge.to_string()));
        }
        let drives_expression = model.num_expressions() > 0;
        let k =
            if drives_expression { model.num_expressions() } else { model.num_shape_components() };
        if k == 0 {
            return Err(SpeechError::Empty("model components to drive the mouth with"));
        }
        let mut u = DMatrix::zeros(3 * mouth.len(), k);
        for (i, &v) in mouth.iter().enumerate() {
            let rows = if drives_expression {
                model.expression_rows(v)
            } else {
                model.rescaled_basis_rows(v)
            }
            .ok_or_else(|| {
                bad("mouth vertex", format!("{v} (the model has {})", model.num_vertices()))
            })?;
            u.rows_mut(3 * i, 3).copy_from(&rows);
        }
        let gram = u.tr_mul(&u);
        let lambda = ridge * gram.diagonal().mean();
        if !(lambda > 0.0 && lambda.is_finite()) {
            return Err(SpeechError::Degenerate("model basis (does not move the mouth)".into()));
        }
        let regularised = gram + DMatrix::identity(k, k) * lambda;
        let projection = regularised
            .cholesky()
            .ok_or_else(|| SpeechError::Degenerate("mouth basis normal equations".into()))?
            .solve(&u.transpose());
        Ok(Self { projection, drives_expression, n_mouth: mouth.len() })
    }

    /// The coefficients that move the mouth of `neutral`'s shape by `displacement` (one
    /// vector per mouth vertex, in model space).
    ///
    /// # Errors
    /// A displacement of the wrong length; neutral coefficients of the wrong length for the
    /// part being driven.
    pub fn drive(
        &self,
        neutral: &Coefficients,
        displacement: &[crate::math::Vector3],
    ) -> Result<Coefficients, SpeechError> {
        if displacement.len() != self.n_mouth {
            return Err(SpeechError::DimensionMismatch {
                what: "mouth displacement vertices",
                expected: self.n_mouth,
                got: displacement.len(),
            });
        }
        let delta = DVector::from_iterator(
            3 * self.n_mouth,
            displacement.iter().flat_map(|d| [d.x, d.y, d.z]),
        );
        let step = &self.projection * delta;
        let mut out = neutral.clone();
        let driven = if self.drives_expression { &mut out.expression } else { &mut out.identity };
        if driven.is_empty() {
            driven.resize(step.len(), 0.0);
        }
        if driven.len() != step.len() {
            return Err(SpeechError::DimensionMismatch {
                what: "driven coefficients",
                expected: step.len(),
                got: driven.len(),
            });
        }
        driven.iter_mut().zip(step.iter()).for_each(|(c, s)| *c += s);
        Ok(out)
    }
}

/// A clip's neutral: the mean coefficients over its silent frames (the mouth at rest between
/// words), or over all frames when none is silent.
///
/// # Errors
/// No frames, or frames whose coefficient counts differ.
pub fn neutral_coefficients(
    frames: &[Coefficients],
    silent: &[bool],
) -> Result<Coefficients, SpeechError> {
    let first = frames.first().ok_or(SpeechError::Empty("frames for the neutral"))?;
    let chosen: Vec<&Coefficients> = if silent.iter().take(frames.len()).any(|&s| s) {
        frames.iter().zip(silent).filter(|(_, s)| **s).map(|(c, _)| c).collect()
    } else {
        frames.iter().collect()
    };
    let mean = |part: fn(&Coefficients) -> &Vec<f64>| -> Result<Vec<f64>, SpeechError> {
        let n = part(first).len();
        let mut sum = vec![0.0; n];
        for c in &chosen {
            let v = part(c);
            if v.len() != n {
                return Err(SpeechError::DimensionMismatch {
                    what: "coefficients per frame",
                    expected: n,
                    got: v.len(),
                });
            }
            sum.iter_mut().zip(v).for_each(|(s, x)| *s += x);
        }
        Ok(sum.into_iter().map(|s| s / chosen.len() as f64).collect())
    };
    Ok(Coefficients { identity: mean(|c| &c.identity)?, expression: mean(|c| &c.expression)? })
}

/// The mouth vertices `mouth` of `shape` (a flat 3N model shape).
///
/// # Errors
/// A vertex past the shape's end.
pub fn mouth_points(shape: &DVector, mouth: &[usize]) -> Result<Vec<Point3>, SpeechError> {
    mouth
        .iter()
        .map(|&v| {
            (3 * v + 2 < shape.len())
                .then(|| Point3::new(shape[3 * v], shape[3 * v + 1], shape[3 * v + 2]))
                .ok_or_else(|| {
                    bad("mouth vertex", format!("{v} (the shape has {})", shape.len() / 3))
                })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Vector3;
    use crate::model::morphable::PcaModel;

    /// Three vertices, two PCA components: component 0 moves vertex 0 in x, component 1
    /// moves vertex 2 in y.
    fn model() -> MorphableModel {
        let mean = DVector::zeros(9);
        let mut basis = DMatrix::zeros(9, 2);
        basis[(0, 0)] = 1.0;
        basis[(7, 1)] = 1.0;
        let shape = PcaModel { mean, basis, eigenvalues: DVector::from_vec(vec![4.0, 1.0]) };
        MorphableModel::new(shape, None, Vec::new()).unwrap()
    }

    #[test]
    fn a_reachable_displacement_is_reproduced_up_to_the_ridge() {
        let m = model();
        let driver = MouthDriver::new(&m, &[0, 1], 1e-6).unwrap();
        let neutral = Coefficients { identity: vec![0.5, 0.3], expression: Vec::new() };
        let d = [Vector3::new(0.4, 0.0, 0.0), Vector3::zeros()];
        let got = driver.drive(&neutral, &d).unwrap();
        // √e₀ = 2, so 0.4 in x is 0.2 of component 0; component 1 is unseen by vertices 0–1.
        assert!((got.identity[0] - 0.7).abs() < 1e-5, "{:?}", got.identity);
        assert!((got.identity[1] - 0.3).abs() < 1e-12);
        let before = m.shape_at(&neutral.identity, &[]);
        let after = m.shape_at(&got.identity, &[]);
        assert!((after[0] - before[0] - 0.4).abs() < 1e-5);
    }

    #[test]
    fn bad_inputs_are_errors() {
        let m = model();
        assert!(MouthDriver::new(&m, &[], 1e-3).is_err());
        assert!(MouthDriver::new(&m, &[5], 1e-3).is_err());
        assert!(MouthDriver::new(&m, &[0], 0.0).is_err());
        let driver = MouthDriver::new(&m, &[0], 1e-3).unwrap();
        assert!(driver.drive(&Coefficients::default(), &[]).is_err());
        let p = mouth_points(&DVector::zeros(9), &[2]).unwrap();
        assert_eq!(p, vec![Point3::origin()]);
        assert!(mouth_points(&DVector::zeros(9), &[3]).is_err());
    }

    #[test]
    fn the_neutral_averages_the_silent_frames() {
        let c = |a: f64| Coefficients { identity: vec![a, 2.0 * a], expression: Vec::new() };
        let frames = [c(1.0), c(5.0), c(3.0)];
        let n = neutral_coefficients(&frames, &[true, false, true]).unwrap();
        assert_eq!(n.identity, vec![2.0, 4.0]);
        let all = neutral_coefficients(&frames, &[false; 3]).unwrap();
        assert_eq!(all.identity, vec![3.0, 6.0]);
        assert!(neutral_coefficients(&[], &[]).is_err());
    }
}
