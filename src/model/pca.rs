//! PCA model building: from a set of same-topology shapes (flat 3N vectors) to a
//! [`PcaModel`] with an orthonormal basis and per-component variances.
//!
//! Start at [`build_pca_from_shapes`]; [`build_pca_with_summary`] also returns the full
//! spectrum so callers can report [`PcaSummary::variance_explained`].
//!
//! Method (standard PCA, e.g. Jolliffe, *Principal Component Analysis*, §3.5): centre the
//! n shapes, `X = [s_1 − m … s_n − m]` (3N×n). When n ≤ 3N (the usual case: 161 poses of a
//! 6,000-vertex head) eigendecompose the small Gram matrix `G = XᵀX` (n×n): if `G·v = λ·v`
//! then `u = X·v/√λ` is a unit eigenvector of the covariance `X·Xᵀ/(n−1)` with variance
//! `λ/(n−1)`. Otherwise eigendecompose `X·Xᵀ` (3N×3N) directly. Eigenvalues are variances
//! with the unbiased `n − 1` divisor, as eos's model builder and scikit-learn's
//! `explained_variance_` use. Each basis column's sign is fixed so that its largest-magnitude
//! entry is positive, which makes the output reproducible across platforms.

use crate::math::{DMatrix, DVector};
use crate::model::morphable::{ModelError, PcaModel};

/// Default fraction of the total variance kept (98 %, as in the thesis this tool follows).
pub const DEFAULT_VARIANCE_FRACTION: f64 = 0.98;

/// How many principal components to keep.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Keep {
    /// The fewest leading components whose variances sum to at least this fraction of the
    /// total (in (0, 1]).
    VarianceFraction(f64),
    /// Exactly this many leading components (fewer when the data has lower rank).
    Components(usize),
}

impl Default for Keep {
    fn default() -> Self {
        Keep::VarianceFraction(DEFAULT_VARIANCE_FRACTION)
    }
}

/// Which eigenproblem was solved.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PcaMethod {
    /// The n×n Gram matrix `XᵀX` (n shapes ≤ 3N).
    Gram,
    /// The 3N×3N scatter matrix `XXᵀ` (more shapes than coordinates).
    Covariance,
}

/// A built model together with the whole spectrum it was cut from.
#[derive(Clone, Debug, PartialEq)]
pub struct PcaSummary {
    /// The truncated model.
    pub model: PcaModel,
    /// Every non-zero variance of the data, descending (the kept ones first).
    pub all_eigenvalues: DVector,
    /// The eigenproblem used.
    pub method: PcaMethod,
    /// How many shapes the model was built from.
    pub shapes: usize,
}

impl PcaSummary {
    /// Fraction of the total variance the kept components explain, in [0, 1].
    pub fn variance_explained(&self) -> f64 {
        variance_explained(&self.all_eigenvalues, self.model.num_components())
    }
}

/// Fraction of the total of `eigenvalues` held by the first `k` entries (0 when the total
/// is 0). `eigenvalues` must be the full spectrum, descending.
///
/// ```
/// let e = nalgebra::DVector::from_vec(vec![3.0, 1.0]);
/// assert_eq!(lipmap::model::pca::variance_explained(&e, 1), 0.75);
/// ```
pub fn variance_explained(eigenvalues: &DVector, k: usize) -> f64 {
    let total: f64 = eigenvalues.iter().sum();
    if total <= 0.0 {
        return 0.0;
    }
    eigenvalues.iter().take(k).sum::<f64>() / total
}

/// PCA of same-topology shapes (each a flat `x0 y0 z0 …` vector of length 3N).
///
/// # Errors
/// Fewer than 2 shapes, shapes of different lengths, a length not a multiple of 3, a bad
/// `keep`, identical shapes (no variance) or non-finite input.
///
/// ```
/// use lipmap::model::pca::{build_pca_from_shapes, Keep};
/// use nalgebra::DVector;
/// let shapes = [DVector::from_vec(vec![0.0, 0.0, 0.0]), DVector::from_vec(vec![2.0, 0.0, 0.0])];
/// let m = build_pca_from_shapes(&shapes, Keep::default()).unwrap();
/// assert_eq!(m.num_components(), 1);
/// assert!((m.eigenvalues[0] - 2.0).abs() < 1e-12); // variance of {-1, 1} with n - 1
/// ```
pub fn build_pca_from_shapes(shapes: &[DVector], keep: Keep) -> Result<PcaModel, ModelError> {
    build_pca_with_summary(shapes, keep).map(|s| s.model)
}

/// Like [`build_pca_from_shapes`], also returning the full spectrum and the method used.
///
/// # Errors
/// As [`build_pca_from_shapes`].
pub fn build_pca_with_summary(shapes: &[DVector], keep: Keep) -> Result<PcaSummary, ModelError> {
    check_keep(keep)?;
    let n = shapes.len();
    if n < 2 {
        return Err(ModelError::TooFewShapes(n));
    }
    let d = shapes[0].len();
    if !d.is_multiple_of(3) {
        return Err(ModelError::MeanNotTriples(d));
    }
    for (index, s) in shapes.iter().enumerate() {
        if s.len() != d {
            return Err(ModelError::ShapeLength { index, len: s.len(), expected: d });
        }
        if let Some(i) = s.iter().position(|v| !v.is_finite()) {
            return Err(ModelError::NonFinite { part: "shape", index: index * d + i });
        }
    }
    let mut mean = DVector::zeros(d);
    for s in shapes {
        mean += s;
    }
    mean /= n as f64;
    let mut x = DMatrix::zeros(d, n);
    for (j, s) in shapes.iter().enumerate() {
        x.column_mut(j).copy_from(&(s - &mean));
    }
    let dof = (n - 1) as f64;

    let (method, values, vectors) = if n <= d {
        // Gram path. `xt * x` goes through the blocked gemm kernel, much faster than a
        // transposed product for tall X.
        let xt = x.transpose();
        let gram = &xt * &x;
        let (vals, vecs) = sorted_symmetric_eigen(gram)?;
        (PcaMethod::Gram, vals, vecs)
    } else {
        let scatter = &x * x.transpose();
        let (vals, vecs) = sorted_symmetric_eigen(scatter)?;
        (PcaMethod::Covariance, vals, vecs)
    };

    // Eigenvalues below this are round-off of a rank-deficient matrix (centring alone
    // removes one dimension), not variation in the data.
    let largest = values.first().copied().unwrap_or(0.0);
    if largest.is_nan() || largest <= 0.0 {
        return Err(ModelError::NoVariance);
    }
    let tolerance = largest * (n.max(d) as f64) * f64::EPSILON * 16.0;
    let rank = values.iter().take_while(|&&v| v > tolerance).count();
    if rank == 0 {
        return Err(ModelError::NoVariance);
    }
    let all_eigenvalues = DVector::from_iterator(rank, values[..rank].iter().map(|v| v / dof));
    let k = match keep {
        Keep::Components(k) => k.min(rank),
        Keep::VarianceFraction(f) => {
            let total: f64 = all_eigenvalues.iter().sum();
            let mut cumulative = 0.0;
            let mut k = rank;
            for (i, v) in all_eigenvalues.iter().enumerate() {
                cumulative += v;
                // A relative slack so that f = 1.0 does not miss by round-off.
                if cumulative >= f * total * (1.0 - 1e-12) {
                    k = i + 1;
                    break;
                }
            }
            k
        }
    };

    let mut basis = match method {
        PcaMethod::Gram => {
            let mut v = vectors.columns(0, k).into_owned();
            for (j, mut col) in v.column_iter_mut().enumerate() {
                col /= values[j].sqrt();
            }
            &x * v
        }
        PcaMethod::Covariance => vectors.columns(0, k).into_owned(),
    };
    for mut col in basis.column_iter_mut() {
        let (imax, _) = col
            .iter()
            .enumerate()
            .fold((0, 0.0), |acc, (i, v)| if v.abs() > acc.1 { (i, v.abs()) } else { acc });
        if col[imax] < 0.0 {
            col.neg_mut();
        }
    }
    let eigenvalues = DVector::from_iterator(k, all_eigenvalues.iter().take(k).copied());
    Ok(PcaSummary {
        model: PcaModel { mean, basis, eigenvalues },
        all_eigenvalues,
        method,
        shapes: n,
    })
}

fn check_keep(keep: Keep) -> Result<(), ModelError> {
    match keep {
        Keep::VarianceFraction(f) if !(f > 0.0 && f <= 1.0) => {
            Err(ModelError::InvalidKeep(format!("variance fraction {f} is outside (0, 1]")))
        }
        Keep::Components(0) => Err(ModelError::InvalidKeep("zero components requested".into())),
        _ => Ok(()),
    }
}

/// Symmetric eigendecomposition with eigenvalues sorted descending (vectors permuted alike).
fn sorted_symmetric_eigen(m: DMatrix) -> Result<(Vec<f64>, DMatrix), ModelError> {
    let eig = m.symmetric_eigen();
    if eig.eigenvalues.iter().any(|v| !v.is_finite()) {
        return Err(ModelError::Numerical("non-finite eigenvalue".into()));
    }
    let mut order: Vec<usize> = (0..eig.eigenvalues.len()).collect();
    order.sort_by(|&a, &b| eig.eigenvalues[b].total_cmp(&eig.eigenvalues[a]));
    let values = order.iter().map(|&i| eig.eigenvalues[i]).collect();
    let vectors = DMatrix::from_fn(eig.eigenvectors.nrows(), order.len(), |r, c| {
        eig.eigenvectors[(r, order[c])]
    });
    Ok((values, vectors))
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng, rngs::StdRng};

    /// Shapes = mean + known orthogonal directions with known spreads + tiny noise.
    fn synthetic(n: usize, d: usize, seed: u64) -> Vec<DVector> {
        let mut rng = StdRng::seed_from_u64(seed);
        let mean = DVector::from_fn(d, |i, _| i as f64 * 0.1);
        let dirs: Vec<DVector> = (0..3)
            .map(|k| DVector::from_fn(d, |i, _| if i % 3 == k { 1.0 } else { 0.0 }).normalize())
            .collect();
        let spreads = [10.0, 3.0, 1.0];
        (0..n)
            .map(|_| {
                let mut s = mean.clone();
                for (dir, sd) in dirs.iter().zip(spreads) {
                    s += dir * (sd * rng.random_range(-1.0..1.0));
                }
                s
            })
            .collect()
    }

    fn orthonormality_error(b: &DMatrix) -> f64 {
        (b.transpose() * b - DMatrix::identity(b.ncols(), b.ncols())).abs().max()
    }

    #[test]
    fn gram_and_covariance_paths_agree() {
        // 12 shapes × 9 coordinates takes the covariance path; 12 × 30 the Gram path.
        for d in [9, 30] {
            let shapes = synthetic(12, d, 7);
            let s = build_pca_with_summary(&shapes, Keep::Components(3)).unwrap();
            assert_eq!(s.method, if d == 9 { PcaMethod::Covariance } else { PcaMethod::Gram });
            assert!(orthonormality_error(&s.model.basis) < 1e-10);
            // Total variance is preserved: the sum of eigenvalues equals the trace of the
            // sample covariance.
            let m = &s.model.mean;
            let trace: f64 = shapes.iter().map(|x| (x - m).norm_squared()).sum::<f64>()
                / (shapes.len() - 1) as f64;
            assert!((s.all_eigenvalues.sum() - trace).abs() < 1e-8 * trace);
            assert!((s.variance_explained() - 1.0).abs() < 1e-9);
            // Every shape is reconstructed exactly by 3 components.
            for x in &shapes {
                let a = s.model.coefficients_of(x).unwrap();
                let r = s.model.shape_at(a.as_slice());
                assert!((r - x).norm() < 1e-9);
            }
        }
    }

    #[test]
    fn variance_fraction_picks_the_fewest_components() {
        let shapes = synthetic(40, 30, 3);
        let all = build_pca_with_summary(&shapes, Keep::VarianceFraction(1.0)).unwrap();
        let e = &all.all_eigenvalues;
        let f1 = variance_explained(e, 1);
        let one = build_pca_from_shapes(&shapes, Keep::VarianceFraction(f1 * 0.999)).unwrap();
        assert_eq!(one.num_components(), 1);
        let two = build_pca_from_shapes(&shapes, Keep::VarianceFraction(f1 * 1.001)).unwrap();
        assert_eq!(two.num_components(), 2);
        assert!(e[0] >= e[1] && e[1] >= e[2]);
    }

    #[test]
    fn degenerate_input_is_an_error() {
        let one = vec![DVector::zeros(6)];
        assert_eq!(build_pca_from_shapes(&one, Keep::default()), Err(ModelError::TooFewShapes(1)));
        let same = vec![DVector::zeros(6), DVector::zeros(6)];
        assert_eq!(build_pca_from_shapes(&same, Keep::default()), Err(ModelError::NoVariance));
        let mixed = vec![DVector::zeros(6), DVector::zeros(9)];
        assert!(matches!(
            build_pca_from_shapes(&mixed, Keep::default()),
            Err(ModelError::ShapeLength { index: 1, .. })
        ));
        let two = synthetic(4, 9, 1);
        assert!(build_pca_from_shapes(&two, Keep::VarianceFraction(1.5)).is_err());
        assert!(build_pca_from_shapes(&two, Keep::Components(0)).is_err());
        let mut nan = synthetic(4, 9, 1);
        nan[2][4] = f64::NAN;
        assert!(matches!(
            build_pca_from_shapes(&nan, Keep::default()),
            Err(ModelError::NonFinite { .. })
        ));
    }

    #[test]
    fn rank_limits_component_count() {
        let shapes = synthetic(5, 30, 9);
        // 5 shapes span at most 4 directions after centring; the data has 3.
        let m = build_pca_from_shapes(&shapes, Keep::Components(10)).unwrap();
        assert_eq!(m.num_components(), 3);
    }
}
