//! `MorphableModel`: a PCA shape model `S = m + B·diag(√e)·α` plus optional expression
//! blendshapes added as `E·β`; shapes are flat `x0 y0 z0 x1 …` vectors of length 3N.
//!
//! Start with [`MorphableModel::shape_at`] (coefficients → shape) and the per-vertex row
//! helpers the fitter uses ([`MorphableModel::rescaled_basis_rows`],
//! [`MorphableModel::expression_rows`]); [`MorphableModel::validate`] checks a model read
//! from a file before anything else touches it.

use crate::math::{DMatrix, DVector, Point3};
use crate::model::mesh::Mesh;

/// Why a model, or the data it is built from, is unusable.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ModelError {
    /// The mean's length is not 3N.
    #[error("mean has {0} entries, not a multiple of 3 (x y z per vertex)")]
    MeanNotTriples(usize),
    /// The basis does not have one row per mean entry.
    #[error("basis has {rows} rows but the mean has {mean} entries")]
    BasisRows { rows: usize, mean: usize },
    /// One eigenvalue per basis column is required.
    #[error("{eigenvalues} eigenvalues for {columns} basis columns")]
    EigenvalueCount { eigenvalues: usize, columns: usize },
    /// Eigenvalues are variances: finite and not negative.
    #[error("eigenvalue {index} is {value}; variances must be finite and >= 0")]
    BadEigenvalue { index: usize, value: f64 },
    /// Expression deltas must have one row per mean entry.
    #[error("expression blendshapes have {rows} rows but the mean has {mean} entries")]
    ExpressionRows { rows: usize, mean: usize },
    /// One name per expression blendshape.
    #[error("{names} expression names for {columns} blendshapes")]
    ExpressionNames { names: usize, columns: usize },
    /// A triangle points past the last vertex.
    #[error("triangle {index} uses vertex {vertex}, but the model has {num_vertices} vertices")]
    TriangleOutOfRange { index: usize, vertex: u32, num_vertices: usize },
    /// NaN or infinity in a model array.
    #[error("non-finite value in {part} at index {index}")]
    NonFinite { part: &'static str, index: usize },
    /// PCA needs at least two shapes to estimate a variance.
    #[error("PCA needs at least 2 shapes, got {0}")]
    TooFewShapes(usize),
    /// Shapes given to PCA or blendshape building disagree in size.
    #[error("shape {index} has {len} entries, expected {expected} (same topology as the first)")]
    ShapeLength { index: usize, len: usize, expected: usize },
    /// All shapes are identical, so there is no variation to model.
    #[error("the shapes do not vary (total variance is zero)")]
    NoVariance,
    /// A bad `Keep` setting (fraction outside (0, 1], zero components).
    #[error("invalid PCA setting: {0}")]
    InvalidKeep(String),
    /// The eigen-solver produced non-finite output.
    #[error("eigendecomposition failed: {0}")]
    Numerical(String),
}

/// A PCA part: mean (3N), orthonormal basis (3N×K, unit columns), eigenvalues (K).
///
/// Eigenvalues are the variances of the training shapes along each basis column, with the
/// unbiased `n − 1` divisor (as eos and scikit-learn use), so `α ~ N(0, I)` is the prior.
#[derive(Clone, Debug, PartialEq)]
pub struct PcaModel {
    pub mean: DVector,
    pub basis: DMatrix,
    pub eigenvalues: DVector,
}

impl PcaModel {
    /// A model with no components: every shape is the mean. Used for base-mesh +
    /// blendshape models, where all variation is in the expression part.
    ///
    /// ```
    /// let m = lipmap::model::PcaModel::mean_only(nalgebra::DVector::from_element(6, 1.0));
    /// assert_eq!(m.num_components(), 0);
    /// ```
    pub fn mean_only(mean: DVector) -> Self {
        let n = mean.len();
        Self { mean, basis: DMatrix::zeros(n, 0), eigenvalues: DVector::zeros(0) }
    }

    /// Number of components K (basis columns).
    pub fn num_components(&self) -> usize {
        self.basis.ncols()
    }

    /// The basis scaled by standard deviations, `B·diag(√e)` (3N×K): eos's "rescaled" basis,
    /// whose columns move a shape by one standard deviation per unit coefficient.
    /// Negative eigenvalues (invalid) are treated as 0 rather than producing NaN.
    pub fn rescaled_basis(&self) -> DMatrix {
        let mut b = self.basis.clone();
        for (j, mut col) in b.column_iter_mut().enumerate() {
            col *= self.sigma(j);
        }
        b
    }

    /// Standard deviation √e_j of component `j` (0 for a negative or missing eigenvalue).
    pub fn sigma(&self, j: usize) -> f64 {
        self.eigenvalues.get(j).map_or(0.0, |&e| e.max(0.0).sqrt())
    }

    /// `m + B·diag(√e)·α`. Missing coefficients count as 0, extra ones are ignored, so a
    /// caller can pass the leading few components only.
    ///
    /// ```
    /// use nalgebra::{DMatrix, DVector};
    /// let m = lipmap::model::PcaModel {
    ///     mean: DVector::zeros(3),
    ///     basis: DMatrix::from_column_slice(3, 1, &[1.0, 0.0, 0.0]),
    ///     eigenvalues: DVector::from_element(1, 4.0),
    /// };
    /// assert_eq!(m.shape_at(&[1.5])[0], 3.0); // 1.5 standard deviations of 2
    /// ```
    pub fn shape_at(&self, alpha: &[f64]) -> DVector {
        let k = alpha.len().min(self.num_components());
        let scaled = DVector::from_iterator(k, (0..k).map(|j| alpha[j] * self.sigma(j)));
        let mut s = self.mean.clone();
        if k > 0 {
            s.gemv(1.0, &self.basis.columns(0, k), &scaled, 1.0);
        }
        s
    }

    /// Coefficients α of the orthogonal projection of `shape` onto the model:
    /// `α_j = b_jᵀ(S − m) / √e_j` (0 where e_j = 0). `None` when the length is not 3N.
    pub fn coefficients_of(&self, shape: &DVector) -> Option<DVector> {
        if shape.len() != self.mean.len() {
            return None;
        }
        let d = shape - &self.mean;
        let mut a = self.basis.tr_mul(&d);
        for j in 0..a.len() {
            let s = self.sigma(j);
            a[j] = if s > 0.0 { a[j] / s } else { 0.0 };
        }
        Some(a)
    }
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
    /// Builds a model and checks it with [`MorphableModel::validate`].
    ///
    /// # Errors
    /// The first inconsistency found (sizes, triangle range, non-finite values).
    pub fn new(
        shape: PcaModel,
        expressions: Option<Expressions>,
        triangles: Vec<[u32; 3]>,
    ) -> Result<Self, ModelError> {
        let m = Self { shape, expressions, triangles };
        m.validate()?;
        Ok(m)
    }

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

    /// Names of the expression blendshapes, in column order (empty when none).
    pub fn expression_names(&self) -> &[String] {
        self.expressions.as_ref().map_or(&[], |e| e.names.as_slice())
    }

    /// Checks every invariant the fitter relies on: mean length 3N, basis rows = mean
    /// length, one non-negative eigenvalue per column, expression rows = mean length and
    /// one name each, triangles in range, every number finite.
    ///
    /// # Errors
    /// A [`ModelError`] describing the first problem found.
    pub fn validate(&self) -> Result<(), ModelError> {
        let s = &self.shape;
        let len = s.mean.len();
        if !len.is_multiple_of(3) {
            return Err(ModelError::MeanNotTriples(len));
        }
        if s.basis.nrows() != len {
            return Err(ModelError::BasisRows { rows: s.basis.nrows(), mean: len });
        }
        if s.eigenvalues.len() != s.basis.ncols() {
            return Err(ModelError::EigenvalueCount {
                eigenvalues: s.eigenvalues.len(),
                columns: s.basis.ncols(),
            });
        }
        if let Some((index, &value)) =
            s.eigenvalues.iter().enumerate().find(|(_, e)| !e.is_finite() || **e < 0.0)
        {
            return Err(ModelError::BadEigenvalue { index, value });
        }
        check_finite("mean", s.mean.as_slice())?;
        check_finite("basis", s.basis.as_slice())?;
        if let Some(e) = &self.expressions {
            if e.deltas.nrows() != len {
                return Err(ModelError::ExpressionRows { rows: e.deltas.nrows(), mean: len });
            }
            if e.names.len() != e.deltas.ncols() {
                return Err(ModelError::ExpressionNames {
                    names: e.names.len(),
                    columns: e.deltas.ncols(),
                });
            }
            check_finite("expression blendshapes", e.deltas.as_slice())?;
        }
        let n = self.num_vertices();
        for (index, t) in self.triangles.iter().enumerate() {
            if let Some(&vertex) = t.iter().find(|&&v| v as usize >= n) {
                return Err(ModelError::TriangleOutOfRange { index, vertex, num_vertices: n });
            }
        }
        Ok(())
    }

    /// The shape `S = m + B·diag(√e)·α + E·β` (3N). Missing coefficients count as 0 and
    /// extra ones are ignored, so `&[]` gives the mean (and `beta = &[]` no expression).
    ///
    /// ```
    /// use nalgebra::{DMatrix, DVector};
    /// use lipmap::model::{Expressions, MorphableModel, PcaModel};
    /// let model = MorphableModel {
    ///     shape: PcaModel::mean_only(DVector::zeros(3)),
    ///     expressions: Some(Expressions {
    ///         names: vec!["open".into()],
    ///         deltas: DMatrix::from_column_slice(3, 1, &[0.0, -2.0, 0.0]),
    ///     }),
    ///     triangles: vec![],
    /// };
    /// assert_eq!(model.shape_at(&[], &[0.5])[1], -1.0);
    /// ```
    pub fn shape_at(&self, alpha: &[f64], beta: &[f64]) -> DVector {
        let mut s = self.shape.shape_at(alpha);
        if let Some(e) = &self.expressions {
            let k = beta.len().min(e.deltas.ncols());
            if k > 0 {
                let b = DVector::from_column_slice(&beta[..k]);
                s.gemv(1.0, &e.deltas.columns(0, k), &b, 1.0);
            }
        }
        s
    }

    /// The 3×K block of the rescaled basis `B·diag(√e)` for `vertex` (rows x, y, z): how
    /// the vertex moves per unit of each shape coefficient. `None` past the last vertex.
    pub fn rescaled_basis_rows(&self, vertex: usize) -> Option<DMatrix> {
        if vertex >= self.num_vertices() {
            return None;
        }
        let mut rows = self.shape.basis.rows(3 * vertex, 3).into_owned();
        for (j, mut col) in rows.column_iter_mut().enumerate() {
            col *= self.shape.sigma(j);
        }
        Some(rows)
    }

    /// The 3×E block of the expression deltas for `vertex` (3×0 when the model has no
    /// expressions). `None` past the last vertex.
    pub fn expression_rows(&self, vertex: usize) -> Option<DMatrix> {
        if vertex >= self.num_vertices() {
            return None;
        }
        Some(match &self.expressions {
            Some(e) => e.deltas.rows(3 * vertex, 3).into_owned(),
            None => DMatrix::zeros(3, 0),
        })
    }

    /// The whole rescaled basis `B·diag(√e)` (3N×K); compute once and keep it when
    /// fitting many frames.
    pub fn rescaled_basis(&self) -> DMatrix {
        self.shape.rescaled_basis()
    }

    /// Vertex `i` of a flat shape vector, or `None` when `i` is past the end of `shape`.
    pub fn vertex(&self, shape: &DVector, i: usize) -> Option<Point3> {
        (3 * i + 2 < shape.len())
            .then(|| Point3::new(shape[3 * i], shape[3 * i + 1], shape[3 * i + 2]))
    }

    /// Vertex `i` of the mean shape, or `None` past the last vertex.
    pub fn mean_vertex(&self, i: usize) -> Option<Point3> {
        self.vertex(&self.shape.mean, i)
    }

    /// The mean shape as a mesh with the model's triangles.
    pub fn mean_mesh(&self) -> Mesh {
        self.to_mesh(&self.shape.mean)
    }

    /// A flat shape (3N, e.g. from [`MorphableModel::shape_at`]) as a mesh with the
    /// model's triangles; a trailing partial vertex is dropped.
    pub fn to_mesh(&self, shape: &DVector) -> Mesh {
        let faces = self.triangles.iter().map(|t| t.to_vec()).collect();
        Mesh::from_flat(shape.as_slice(), faces)
    }
}

fn check_finite(part: &'static str, values: &[f64]) -> Result<(), ModelError> {
    // Whole blocks tested without an early exit (which vectorises; a model holds millions
    // of values), the first bad value looked for only in a block that has one.
    const BLOCK: usize = 256;
    let finite = |block: &[f64]| block.iter().fold(true, |ok, v| ok & v.is_finite());
    match values.chunks(BLOCK).position(|block| !finite(block)) {
        Some(b) => {
            let block = &values[b * BLOCK..];
            let index = b * BLOCK + block.iter().position(|v| !v.is_finite()).unwrap_or(0);
            Err(ModelError::NonFinite { part, index })
        }
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn toy() -> MorphableModel {
        // Two vertices, two orthonormal components, one expression.
        let mut basis = DMatrix::zeros(6, 2);
        basis[(0, 0)] = 1.0;
        basis[(4, 1)] = 1.0;
        MorphableModel {
            shape: PcaModel {
                mean: DVector::from_vec(vec![0.0, 0.0, 0.0, 1.0, 1.0, 1.0]),
                basis,
                eigenvalues: DVector::from_vec(vec![4.0, 9.0]),
            },
            expressions: Some(Expressions {
                names: vec!["e".into()],
                deltas: DMatrix::from_column_slice(6, 1, &[0.0, 0.0, 1.0, 0.0, 0.0, 0.0]),
            }),
            triangles: vec![[0, 1, 1]],
        }
    }

    #[test]
    fn shape_at_combines_identity_and_expression() {
        let m = toy();
        let s = m.shape_at(&[1.0, -1.0], &[2.0]);
        assert_eq!(s.as_slice(), &[2.0, 0.0, 2.0, 1.0, -2.0, 1.0]);
        assert_eq!(m.vertex(&s, 1), Some(Point3::new(1.0, -2.0, 1.0)));
        assert_eq!(m.vertex(&s, 2), None);
    }

    #[test]
    fn rows_match_shape_derivative() {
        let m = toy();
        let r = m.rescaled_basis_rows(1).unwrap();
        assert_eq!(r[(1, 1)], 3.0);
        assert_eq!(r[(0, 0)], 0.0);
        assert_eq!(m.expression_rows(0).unwrap()[(2, 0)], 1.0);
        assert!(m.rescaled_basis_rows(2).is_none());
    }

    #[test]
    fn coefficients_round_trip() {
        let m = toy();
        let s = m.shape.shape_at(&[0.5, -0.25]);
        let a = m.shape.coefficients_of(&s).unwrap();
        assert!((a[0] - 0.5).abs() < 1e-12 && (a[1] + 0.25).abs() < 1e-12);
    }

    #[test]
    fn validate_names_the_problem() {
        let mut m = toy();
        assert_eq!(m.validate(), Ok(()));
        m.triangles.push([0, 1, 7]);
        assert!(matches!(m.validate(), Err(ModelError::TriangleOutOfRange { vertex: 7, .. })));
        let mut m = toy();
        m.shape.eigenvalues = DVector::from_vec(vec![1.0]);
        assert!(matches!(m.validate(), Err(ModelError::EigenvalueCount { .. })));
        let mut m = toy();
        m.shape.mean[2] = f64::NAN;
        assert_eq!(m.validate(), Err(ModelError::NonFinite { part: "mean", index: 2 }));
        // Past the first of the blocks the check reads at once, the first bad value is named.
        for (bad, index) in [(f64::INFINITY, 700), (f64::NAN, 256), (f64::NEG_INFINITY, 255)] {
            let mut values = vec![1.0; 1000];
            (values[index], values[900]) = (bad, f64::NAN);
            assert_eq!(
                check_finite("basis", &values),
                Err(ModelError::NonFinite { part: "basis", index })
            );
        }
        let mut m = toy();
        m.expressions.as_mut().unwrap().names.clear();
        assert!(matches!(m.validate(), Err(ModelError::ExpressionNames { .. })));
    }
}
