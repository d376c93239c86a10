//! `MorphableModel`: a PCA shape model `S = m + B·diag(√e)·α` plus optional expression
//! blendshapes added as `E·β`; shapes are flat `x0 y0 z0 x1 …` vectors of length 3N.

use crate::math::{DMatrix, DVector};

/// A PCA part: mean (3N), orthonormal basis (3N×K, unit columns), eigenvalues (K).
#[derive(Clone, Debug, PartialEq)]
pub struct PcaModel {
    pub mean: DVector,
    pub basis: DMatrix,
    pub eigenvalues: DVector,
}

/// Expression blendshapes: column j of `deltas` (3N) is the offset of blendshape `names[j]`.
#[derive(Clone, Debug, PartialEq)]
pub struct Expressions {
    pub names: Vec<String>,
    pub deltas: DMatrix,
}

/// A morphable model of one topology.
#[derive(Clone, Debug, PartialEq)]
pub struct MorphableModel {
    pub shape: PcaModel,
    pub expressions: Option<Expressions>,
    /// 0-based triangles; may be empty for point-only models.
    pub triangles: Vec<[u32; 3]>,
}

impl MorphableModel {
    /// Number of vertices N.
    pub fn num_vertices(&self) -> usize {
        self.shape.mean.len() / 3
    }

    /// Number of shape components K.
    pub fn num_shape_components(&self) -> usize {
        self.shape.basis.ncols()
    }

    /// Number of expression blendshapes (0 when none).
    pub fn num_expressions(&self) -> usize {
        self.expressions.as_ref().map_or(0, |e| e.deltas.ncols())
    }
}
