//! The fitted meshes of many frames, as a files-mode fit writes them: every frame's full
//! shape `mean + B·diag(σ)·α + E·β` (the model's `shape_at`) in f32, the precision
//! `shapes.npy` stores, made a block of frames at a time.
//!
//! A block's meshes are the columns of one matrix product, run by the matrix-multiply kernel
//! instead of one vector product per frame, and in f32: the file keeps f32, and the kernel
//! does twice as many f32 as f64 multiply-adds per instruction (the difference from rounding
//! the f64 mesh is a few units in the last place of f32, ~10⁻⁵ mm on a 100 mm head). A clip
//! shares one α, so its identity part `mean + B·diag(σ)·α` (3N × k_id multiply-adds, ≈ 650k
//! for the SFM model) is built once, in f64, and each block adds only `E·[β_f …]` (3N × k_exp
//! per frame); a block whose frames have other identities (per-frame fits, a failed frame in
//! a clip) gets `mean + B·diag(σ)·[α_f …]` as well.

use super::result::FrameFit;
use crate::model::MorphableModel;
use nalgebra::DMatrix;

/// Frames whose meshes are made in one product when they share one identity: only the
/// expression columns are multiplied, and 16 meshes of the SFM model (0.7 MB) stay in cache.
const SHARED_BLOCK: usize = 16;
/// The same when identities differ: the matrix-multiply kernel copies ("packs") the whole
/// identity basis once per product, which at 16 frames cost more than the multiply-adds;
/// 64 meshes are 2.6 MB.
const BLOCK: usize = 64;

/// Calls `each(fit, shape)` for every fit in order with its fitted shape in model space (flat
/// `x0 y0 z0 …`, length 3N, in f32: [`super::fitted_shape`] rounded, up to a few units in
/// the last place); `shape` is only valid during the call.
pub fn for_each_fitted_shape(
    model: &MorphableModel,
    fits: &[FrameFit],
    mut each: impl FnMut(&FrameFit, &[f32]),
) {
    let n3 = model.shape.mean.len();
    let shared_identity = fits.windows(2).all(|w| same_bits(&w[0].identity, &w[1].identity));
    let block_len = if shared_identity { SHARED_BLOCK } else { BLOCK };
    let mut meshes = DMatrix::<f32>::zeros(n3, block_len.min(fits.len()));
    let mean = model.shape.mean.map(|v| v as f32);
    // The scaled identity basis B·diag(σ), made when a block needs it.
    let mut identity_basis: Option<DMatrix<f32>> = None;
    let deltas = model.expressions.as_ref().map(|e| e.deltas.map(|v| v as f32));
    // The identity part of the last shared α, with that α.
    let mut shared: Option<(&[f64], Vec<f32>)> = None;
    for block in fits.chunks(block_len) {
        let mut out = meshes.columns_mut(0, block.len());
        let first = block[0].identity.as_slice();
        if block.iter().all(|f| same_bits(&f.identity, first)) {
            if !shared.as_ref().is_some_and(|(alpha, _)| same_bits(alpha, first)) {
                let base = model.shape.shape_at(first).iter().map(|&v| v as f32).collect();
                shared = Some((first, base));
            }
            if let Some((_, base)) = &shared {
                out.column_iter_mut().for_each(|mut c| c.copy_from_slice(base));
            }
        } else {
            out.column_iter_mut().for_each(|mut c| c.copy_from(&mean));
            let basis = identity_basis.get_or_insert_with(|| {
                let b = &model.shape.basis;
                DMatrix::from_fn(b.nrows(), b.ncols(), |r, c| {
                    (b[(r, c)] * model.shape.sigma(c)) as f32
                })
            });
            let alphas = DMatrix::from_fn(basis.ncols(), block.len(), |c, f| {
                block[f].identity.get(c).map_or(0.0, |&a| a as f32)
            });
            out.gemm(1.0, basis, &alphas, 1.0);
        }
        if let Some(d) = &deltas {
            let beta = DMatrix::from_fn(d.ncols(), block.len(), |c, f| {
                block[f].expression.get(c).map_or(0.0, |&b| b as f32)
            });
            out.gemm(1.0, d, &beta, 1.0);
        }
        for (fit, shape) in block.iter().zip(meshes.as_slice().chunks_exact(n3.max(1))) {
            each(fit, shape);
        }
    }
}

/// Bitwise equality: equal coefficients give the equal identity part, and comparing bits
/// keeps 0.0 / −0.0 and NaN apart the way the arithmetic would.
fn same_bits(a: &[f64], b: &[f64]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::fitted_shape;
    use crate::math::{DVector, Real};
    use crate::model::{Expressions, PcaModel};

    fn model() -> MorphableModel {
        let n3 = 12;
        MorphableModel {
            shape: PcaModel {
                mean: DVector::from_fn(n3, |i, _| (i as Real * 0.7).sin() * 10.0),
                basis: DMatrix::from_fn(n3, 3, |r, c| ((r * 3 + c) as Real * 0.31).cos()),
                eigenvalues: DVector::from_vec(vec![4.0, 2.0, 0.5]),
            },
            expressions: Some(Expressions {
                names: vec!["a".into(), "b".into()],
                deltas: DMatrix::from_fn(n3, 2, |r, c| ((r + 5 * c) as Real * 0.17).sin()),
            }),
            triangles: vec![],
        }
    }

    #[test]
    fn matches_fitted_shape_with_shared_and_changing_identity() {
        let m = model();
        let fit = |frame: usize, id: [Real; 3], ex: [Real; 2]| FrameFit {
            identity: id.to_vec(),
            expression: ex.to_vec(),
            ..FrameFit::unposed(frame)
        };
        // Blocks of one identity, of mixed identities, and a failed frame's zeros.
        let mut fits = vec![
            fit(0, [0.3, -1.2, 0.01], [0.5, 0.0]),
            fit(1, [0.3, -1.2, 0.01], [0.1, 0.9]),
            fit(2, [-0.7, 0.2, 1.5], [0.0, 0.3]),
            fit(3, [0.3, -1.2, 0.01], [1.0 / 3.0, 0.2]),
            FrameFit::unposed(4),
        ];
        fits.extend((5..40).map(|f| fit(f, [0.3, -1.2, 0.01], [0.01 * f as Real, 0.2])));
        fits.push(fit(40, [0.1, 0.2, 0.3], [0.0, 0.0]));
        let mut seen = 0;
        for_each_fitted_shape(&m, &fits, |f, s| {
            let want = fitted_shape(&m, f);
            assert_eq!(s.len(), want.len());
            // f32 products: a few units in the last place of the largest value.
            let scale = want.amax().max(1.0);
            assert!(
                s.iter().zip(want.iter()).all(|(&a, b)| (f64::from(a) - b).abs() <= 1e-6 * scale),
                "frame {}",
                f.frame
            );
            seen += 1;
        });
        assert_eq!(seen, fits.len());
    }
}
