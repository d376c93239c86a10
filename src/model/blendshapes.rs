//! Base mesh + blendshapes models (no PCA): each blendshape is a delta from the base, so a
//! shape is `base + Σ β_j·delta_j`. Also attaches blendshapes to an existing PCA model.
//!
//! Such a model has a shape part with **zero components** (`PcaModel::mean_only(base)`) and
//! all its variation in `expressions`; a fitter then solves for β only (α is empty). Files
//! are read elsewhere (`io::obj`, `io::makehuman_target`); here everything is in memory.

use crate::math::DVector;
use crate::model::mesh::Mesh;
use crate::model::morphable::{Expressions, ModelError, MorphableModel, PcaModel};

/// One named blendshape: the per-coordinate offset (3N) from the base shape.
#[derive(Clone, Debug, PartialEq)]
pub struct Blendshape {
    pub name: String,
    pub delta: DVector,
}

impl Blendshape {
    /// The blendshape that turns `base` into `target` (both flat 3N shapes): `target − base`.
    ///
    /// # Errors
    /// [`ModelError::ShapeLength`] when the two differ in length (index 0 names the target).
    pub fn from_target_shape(
        name: impl Into<String>,
        base: &DVector,
        target: &DVector,
    ) -> Result<Self, ModelError> {
        if base.len() != target.len() {
            return Err(ModelError::ShapeLength {
                index: 0,
                len: target.len(),
                expected: base.len(),
            });
        }
        Ok(Self { name: name.into(), delta: target - base })
    }
}

/// Stacks blendshapes as the columns of an [`Expressions`] block for a 3N-long shape.
///
/// # Errors
/// [`ModelError::ShapeLength`] (with the blendshape's index) when a delta's length is not
/// `len`.
pub fn expressions_from_blendshapes(
    len: usize,
    blendshapes: &[Blendshape],
) -> Result<Expressions, ModelError> {
    let mut deltas = crate::math::DMatrix::zeros(len, blendshapes.len());
    for (j, b) in blendshapes.iter().enumerate() {
        if b.delta.len() != len {
            return Err(ModelError::ShapeLength { index: j, len: b.delta.len(), expected: len });
        }
        deltas.column_mut(j).copy_from(&b.delta);
    }
    Ok(Expressions { names: blendshapes.iter().map(|b| b.name.clone()).collect(), deltas })
}

/// A model of `base` plus blendshapes: zero shape components, one expression per
/// blendshape, the base's faces fan-triangulated.
///
/// # Errors
/// A blendshape of the wrong length, a face out of range or non-finite values.
///
/// ```
/// use lipmap::model::{Mesh, blendshapes::{Blendshape, build_blendshape_model}};
/// use nalgebra::DVector;
/// let base = Mesh::from_flat(&[0.0, 0.0, 0.0], vec![]);
/// let open = Blendshape { name: "jawOpen".into(), delta: DVector::from_vec(vec![0.0, -1.0, 0.0]) };
/// let m = build_blendshape_model(&base, vec![open]).unwrap();
/// assert_eq!(m.num_shape_components(), 0);
/// assert_eq!(m.shape_at(&[], &[0.5])[1], -0.5);
/// ```
pub fn build_blendshape_model(
    base: &Mesh,
    blendshapes: Vec<Blendshape>,
) -> Result<MorphableModel, ModelError> {
    let mean = base.to_flat();
    let expressions = expressions_from_blendshapes(mean.len(), &blendshapes)?;
    let expressions = (!blendshapes.is_empty()).then_some(expressions);
    MorphableModel::new(PcaModel::mean_only(mean), expressions, base.triangles())
}

/// Appends blendshapes to a model's expressions (creating the block if it has none).
///
/// # Errors
/// A blendshape whose length is not the model's 3N.
pub fn add_blendshapes(
    mut model: MorphableModel,
    blendshapes: &[Blendshape],
) -> Result<MorphableModel, ModelError> {
    let len = model.shape.mean.len();
    let new = expressions_from_blendshapes(len, blendshapes)?;
    model.expressions = Some(match model.expressions.take() {
        None => new,
        Some(old) => {
            let mut names = old.names;
            names.extend(new.names);
            let cols = old.deltas.ncols() + new.deltas.ncols();
            let mut deltas = crate::math::DMatrix::zeros(len, cols);
            deltas.columns_mut(0, old.deltas.ncols()).copy_from(&old.deltas);
            deltas.columns_mut(old.deltas.ncols(), new.deltas.ncols()).copy_from(&new.deltas);
            Expressions { names, deltas }
        }
    });
    model.validate()?;
    Ok(model)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base_plus_blendshapes_reproduces_targets() {
        let base =
            Mesh::from_flat(&[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0, 0.0], vec![vec![0, 1, 2]]);
        let flat = base.to_flat();
        let target = DVector::from_vec(vec![0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 0.0, 2.0, 0.0]);
        let b = Blendshape::from_target_shape("t", &flat, &target).unwrap();
        let m = build_blendshape_model(&base, vec![b.clone()]).unwrap();
        assert_eq!(m.shape_at(&[], &[1.0]), target);
        assert_eq!(m.triangles, vec![[0, 1, 2]]);
        let m2 = add_blendshapes(m, &[Blendshape { name: "u".into(), ..b }]).unwrap();
        assert_eq!(m2.num_expressions(), 2);
        assert_eq!(m2.expression_names(), ["t".to_string(), "u".to_string()]);
        let short = Blendshape { name: "s".into(), delta: DVector::zeros(3) };
        assert!(matches!(
            build_blendshape_model(&base, vec![short]),
            Err(ModelError::ShapeLength { index: 0, len: 3, expected: 9 })
        ));
    }
}
