//! The fitted meshes of many frames, as a files-mode fit writes them: every frame's full
//! shape `mean + B·diag(σ)·α + E·β` (the model's `shape_at`), made frame after frame into
//! one reused buffer.
//!
//! The identity part `mean + B·diag(σ)·α` is 3N × k_id multiply-adds (≈ 650k for the SFM
//! model) where the expressions are 3N × k_exp (≈ 62k): a clip shares one α, so the identity
//! part is built once per run of frames with the same α and only the expressions per frame.
//! The sums run in the order `MorphableModel::shape_at` runs them (mean, then identity
//! columns, then expression columns, one multiply-add each), so the values are the same to
//! the bit.

use super::result::FrameFit;
use crate::math::Real;
use crate::model::MorphableModel;

/// Calls `each(fit, shape)` for every fit in order with its fitted shape in model space (flat
/// `x0 y0 z0 …`, length 3N, equal to [`super::fitted_shape`]); `shape` is only valid during
/// the call.
pub fn for_each_fitted_shape(
    model: &MorphableModel,
    fits: &[FrameFit],
    mut each: impl FnMut(&FrameFit, &[Real]),
) {
    let mut identity: Option<(&[Real], Vec<Real>)> = None;
    let mut shape = vec![0.0; model.shape.mean.len()];
    for fit in fits {
        let same = identity.as_ref().is_some_and(|(alpha, _)| same_bits(alpha, &fit.identity));
        if !same {
            let part = model.shape.shape_at(&fit.identity);
            identity = Some((&fit.identity, part.as_slice().to_vec()));
        }
        let Some((_, part)) = &identity else { continue };
        shape.copy_from_slice(part);
        if let Some(e) = &model.expressions {
            let k = fit.expression.len().min(e.deltas.ncols());
            // One column at a time, as nalgebra's gemv in `shape_at` adds them; the deltas
            // are column-major, so each column is one contiguous slice.
            let columns = e.deltas.as_slice().chunks_exact(e.deltas.nrows().max(1));
            for (&b, column) in fit.expression[..k].iter().zip(columns) {
                for (s, &d) in shape.iter_mut().zip(column) {
                    *s += d * b;
                }
            }
        }
        each(fit, &shape);
    }
}

/// Bitwise equality: equal coefficients give the equal identity part, and comparing bits
/// keeps 0.0 / −0.0 and NaN apart the way the arithmetic would.
fn same_bits(a: &[Real], b: &[Real]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(x, y)| x.to_bits() == y.to_bits())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::fitted_shape;
    use crate::math::{DMatrix, DVector};
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
    fn matches_fitted_shape_bit_for_bit_with_shared_and_changing_identity() {
        let m = model();
        let fit = |frame: usize, id: [Real; 3], ex: [Real; 2]| FrameFit {
            identity: id.to_vec(),
            expression: ex.to_vec(),
            ..FrameFit::unposed(frame)
        };
        let fits = vec![
            fit(0, [0.3, -1.2, 0.01], [0.5, 0.0]),
            fit(1, [0.3, -1.2, 0.01], [0.1, 0.9]),
            fit(2, [-0.7, 0.2, 1.5], [0.0, 0.3]),
            fit(3, [0.3, -1.2, 0.01], [1.0 / 3.0, 0.2]),
            FrameFit::unposed(4),
        ];
        let mut seen = 0;
        for_each_fitted_shape(&m, &fits, |f, s| {
            let want = fitted_shape(&m, f);
            assert_eq!(s.len(), want.len());
            assert!(
                s.iter().zip(want.iter()).all(|(a, b)| a.to_bits() == b.to_bits()),
                "frame {}",
                f.frame
            );
            seen += 1;
        });
        assert_eq!(seen, fits.len());
    }
}
