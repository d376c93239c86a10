//! The fitted meshes of many frames, as a files-mode fit writes them: every frame's full
//! shape `mean + B·diag(σ)·α + E·β` (the model's `shape_at`) in f32, the precision
//! `shapes.npy` stores, made a block of frames at a time.
//!
//! Each mesh entry is two sums of f32 fused multiply-adds, each begun at 0 and taken over
//! the columns in order, added in turn to the start value: `(m + Σₖ bₖαₖ) + Σₑ eₑβₑ` — the
//! arithmetic of the packed f32 matrix product this replaced, so the values are the same
//! bits (the file keeps f32; the difference from rounding the f64 mesh is a few units in the
//! last place of f32, ~10⁻⁵ mm on a 100 mm head). Fused multiply-adds round once whatever
//! the vector width, so every CPU gives the same bits. A clip shares one α, so its start
//! value `mean + B·diag(σ)·α` (3N × k_id multiply-adds, ≈ 650k for the SFM model) is made
//! once, in f64, and each frame adds only `E·β`; a block whose frames have other identities
//! (per-frame fits, a failed frame in a clip) starts from the mean and adds `B·diag(σ)·α_f`
//! as well.
//!
//! The bases are copied once per call into tiles of rows ([`Tiles`]): a tile's columns lie
//! one after the other, so a frame's entries of a tile are summed in registers over a
//! contiguous run of memory, and the tile (12 KB of the SFM identity basis) stays in the
//! first-level cache while every frame of a block passes over it, two frames at a time
//! ([`mesh_tile_pair`]). A general matrix product instead copies ("packs") its operands
//! again for every block of frames.

use super::result::FrameFit;
use crate::model::MorphableModel;
use nalgebra::DMatrix;
use pulp::Simd;

/// Frames whose meshes are made together: the tiles are read from memory once per block,
/// and 64 meshes of the SFM model are 2.6 MB.
const BLOCK: usize = 64;
/// Vector registers of sums per tile and frame: a tile is `ACC` vectors of rows (48 rows
/// with AVX2). Two frames' sums, the column's vector and the two broadcast coefficients take
/// 15 of the 16 registers ([`mesh_tile_pair`]).
const ACC: usize = 6;

/// Calls `each(fits, shapes)` for consecutive blocks of `fits` in order, `shapes[i]` the
/// fitted shape of `fits[i]` in model space (flat `x0 y0 z0 …`, length 3N, in f32:
/// [`super::fitted_shape`] rounded, up to a few units in the last place), so that a writer
/// can hand a block to the file in one call; `shapes` is only valid during the call.
pub fn for_each_block_of_fitted_shapes(
    model: &MorphableModel,
    fits: &[FrameFit],
    each: impl FnMut(&[FrameFit], &[&[f32]]),
) {
    pulp::Arch::new().dispatch(Meshes { model, fits, each });
}

/// [`for_each_block_of_fitted_shapes`]'s work, run compiled for the CPU's widest vectors (pulp's
/// run-time dispatch; the sums are in [`mesh_tile_pair`]).
struct Meshes<'a, F> {
    model: &'a MorphableModel,
    fits: &'a [FrameFit],
    each: F,
}

impl<F: FnMut(&[FrameFit], &[&[f32]])> pulp::WithSimd for Meshes<'_, F> {
    type Output = ();

    #[inline(always)]
    fn with_simd<S: Simd>(self, simd: S) {
        let Meshes { model, fits, mut each } = self;
        let n3 = model.shape.mean.len();
        let rows = ACC * S::F32_LANES;
        let padded = n3.div_ceil(rows) * rows;
        let mean = padded_f32(model.shape.mean.iter().copied(), padded);
        // The scaled identity basis B·diag(σ), tiled when a block needs it.
        let mut identity: Option<Tiles> = None;
        let expressions =
            model.expressions.as_ref().map(|e| Tiles::new(rows, n3, &e.deltas, |_| 1.0));
        let k_exp = expressions.as_ref().map_or(0, |t| t.cols);
        // The start value of the last shared α, with that α.
        let mut shared: Option<(&[f64], Vec<f32>)> = None;
        let block_len = BLOCK.min(fits.len());
        let mut meshes = vec![0f32; padded * block_len];
        let mut alphas = Vec::new();
        let mut betas = vec![0f32; k_exp * block_len];
        let mut spare = vec![0f32; rows];
        for block in fits.chunks(block_len.max(1)) {
            let first = block[0].identity.as_slice();
            let one_identity = block.iter().all(|f| same_bits(&f.identity, first));
            let (start, per_frame) = if one_identity {
                if !shared.as_ref().is_some_and(|(alpha, _)| same_bits(alpha, first)) {
                    let base = padded_f32(model.shape.shape_at(first).iter().copied(), padded);
                    shared = Some((first, base));
                }
                (shared.as_ref().map_or(&mean, |(_, base)| base), None)
            } else {
                let tiles = identity.get_or_insert_with(|| {
                    Tiles::new(rows, n3, &model.shape.basis, |c| model.shape.sigma(c))
                });
                alphas.clear();
                alphas.extend(block.iter().flat_map(|f| coefficients(&f.identity, tiles.cols)));
                (&mean, Some(&*tiles))
            };
            betas.clear();
            betas.extend(block.iter().flat_map(|f| coefficients(&f.expression, k_exp)));
            for t in 0..padded / rows {
                let span = t * rows..(t + 1) * rows;
                let start = &start[span.clone()];
                let identity = |f: usize| match per_frame {
                    Some(tiles) => (tiles.tile(t), &alphas[f * tiles.cols..][..tiles.cols]),
                    None => (&[][..], &[][..]),
                };
                let expression = |f: usize| match &expressions {
                    Some(tiles) => (tiles.tile(t), &betas[f * k_exp..][..k_exp]),
                    None => (&[][..], &[][..]),
                };
                let mut frames = meshes.chunks_exact_mut(padded).take(block.len()).enumerate();
                while let Some((f, mesh)) = frames.next() {
                    // A frame left over is paired with itself, its copy made in `spare`.
                    let (g, second) = match frames.next() {
                        Some((g, next)) => (g, &mut next[span.clone()]),
                        None => (f, &mut spare[..]),
                    };
                    let parts = [[identity(f), identity(g)], [expression(f), expression(g)]];
                    mesh_tile_pair(simd, [&mut mesh[span.clone()], second], start, parts);
                }
            }
            let shapes: Vec<&[f32]> =
                meshes.chunks_exact(padded).take(block.len()).map(|m| &m[..n3]).collect();
            each(block, &shapes);
        }
    }
}

/// A basis's rows in tiles of `rows` (the last padded with zeros): tile t holds its rows of
/// column 0, then of column 1, …, so one tile is one contiguous block.
struct Tiles {
    rows: usize,
    cols: usize,
    data: Vec<f32>,
}

impl Tiles {
    /// Tiles of the first `n` rows of `matrix` (at least `n` rows), column c times
    /// `scale(c)`.
    fn new(rows: usize, n: usize, matrix: &DMatrix<f64>, scale: impl Fn(usize) -> f64) -> Self {
        let columns = matrix.as_slice().chunks_exact(matrix.nrows().max(1)).take(matrix.ncols());
        let cols = columns.len();
        let tiles = n.div_ceil(rows);
        let mut data = vec![0f32; tiles * rows * cols];
        for (c, column) in columns.enumerate() {
            let scale = scale(c);
            for (t, rows_of_tile) in column[..n].chunks(rows).enumerate() {
                let to = &mut data[(t * cols + c) * rows..][..rows_of_tile.len()];
                to.iter_mut().zip(rows_of_tile).for_each(|(to, &v)| *to = (v * scale) as f32);
            }
        }
        Self { rows, cols, data }
    }

    fn tile(&self, t: usize) -> &[f32] {
        &self.data[t * self.rows * self.cols..][..self.rows * self.cols]
    }
}

/// `values` in f32, then zeros up to `len`.
fn padded_f32(values: impl Iterator<Item = f64>, len: usize) -> Vec<f32> {
    let mut out: Vec<f32> = values.map(|v| v as f32).collect();
    out.resize(len, 0.0);
    out
}

/// `cols` coefficients in f32, missing ones 0 (a failed frame has none), extra ones left
/// out.
fn coefficients(c: &[f64], cols: usize) -> impl Iterator<Item = f32> + '_ {
    (0..cols).map(|j| c.get(j).map_or(0.0, |&v| v as f32))
}

/// One tile of two frames' meshes: each `out = (start + Σₖ tile₁[:, k]·c₁[k]) + Σₖ
/// tile₂[:, k]·c₂[k]` over the parts, with that frame's coefficients, each sum made first
/// (from 0, in the order of k, one fused multiply-add per product) and then added, the
/// rounding of a packed matrix product's kernel, which this replaced; a part without
/// coefficients adds nothing. `parts[p][i]` is frame i's part p (the same tile for both
/// frames); `start` and each `out` are one tile's rows (`ACC` vectors), and both `out` are
/// written over.
///
/// Each vector of a tile's column is loaded once for both frames' sums, half a load per
/// multiply-add instead of one. On this project's machine that took the meshes of 1,000
/// per-frame fits from 29–31 ms (one frame at a time, twelve sums over 96 rows) to 18–24 ms
/// (docs/performance.md).
#[inline(always)]
fn mesh_tile_pair<S: Simd>(
    simd: S,
    out: [&mut [f32]; 2],
    start: &[f32],
    parts: [[(&[f32], &[f32]); 2]; 2],
) {
    let rows = start.len();
    let [first, second] = out;
    first.copy_from_slice(start);
    second.copy_from_slice(start);
    for [(tile, c0), (_, c1)] in parts {
        if c0.is_empty() {
            continue;
        }
        let mut sums = [[simd.splat_f32s(0.0); ACC]; 2];
        for ((column, &a), &b) in tile.chunks_exact(rows).zip(c0).zip(c1) {
            let (a, b) = (simd.splat_f32s(a), simd.splat_f32s(b));
            for (i, &x) in S::as_simd_f32s(column).0[..ACC].iter().enumerate() {
                sums[0][i] = simd.mul_add_f32s(x, a, sums[0][i]);
                sums[1][i] = simd.mul_add_f32s(x, b, sums[1][i]);
            }
        }
        for (out, sum) in [&mut *first, &mut *second].into_iter().zip(sums) {
            for (v, s) in S::as_mut_simd_f32s(out).0[..ACC].iter_mut().zip(sum) {
                *v = simd.add_f32s(*v, s);
            }
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

    /// `each(fit, shape)` for every fit in order, through the blocks.
    fn for_each_fitted_shape(
        m: &MorphableModel,
        fits: &[FrameFit],
        mut each: impl FnMut(&FrameFit, &[f32]),
    ) {
        for_each_block_of_fitted_shapes(m, fits, |block, shapes| {
            assert_eq!(block.len(), shapes.len());
            block.iter().zip(shapes).for_each(|(fit, shape)| each(fit, shape));
        });
    }

    fn model() -> MorphableModel {
        model_of(12, 3)
    }

    /// n3 rows, k_id identity components, two expressions.
    fn model_of(n3: usize, k_id: usize) -> MorphableModel {
        MorphableModel {
            shape: PcaModel {
                mean: DVector::from_fn(n3, |i, _| (i as Real * 0.7).sin() * 10.0),
                basis: DMatrix::from_fn(n3, k_id, |r, c| ((r * 3 + c) as Real * 0.31).cos()),
                eigenvalues: DVector::from_fn(k_id, |c, _| 4.0 / (c + 1) as Real),
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

    /// The arithmetic the module states, one entry at a time: each sum from 0 by fused
    /// multiply-adds in column order, then added; so the bits cannot depend on the vector
    /// width, the tile or the block.
    #[test]
    fn entries_are_the_stated_sums_to_the_bit() {
        // Several tiles and a part-filled one; an odd number of identity columns.
        let m = model_of(3 * 150, 7);
        let b = m.shape.rescaled_basis();
        let d = &m.expressions.as_ref().unwrap().deltas;
        let sum = |row: &[f64], c: &[f64]| {
            row.iter().zip(c).fold(0f32, |s, (&b, &c)| (b as f32).mul_add(c as f32, s))
        };
        let row = |m: &DMatrix<Real>, r: usize| m.row(r).iter().copied().collect::<Vec<_>>();
        let fit = |frame: usize| FrameFit {
            identity: (0..7).map(|c| ((frame * 7 + c) as Real * 0.9).sin()).collect(),
            expression: vec![0.3 * frame as Real, -0.2],
            ..FrameFit::unposed(frame)
        };
        // Other identities per frame (past one block), then one shared identity.
        let per_frame: Vec<FrameFit> = (0..BLOCK + 3).map(fit).collect();
        let shared: Vec<FrameFit> =
            (0..5).map(|f| FrameFit { identity: fit(0).identity, ..fit(f) }).collect();
        for (fits, one_identity) in [(per_frame, false), (shared, true)] {
            let mut seen = 0;
            for_each_fitted_shape(&m, &fits, |f, s| {
                let start = m.shape.shape_at(&f.identity);
                for (r, &got) in s.iter().enumerate() {
                    let start = if one_identity {
                        start[r] as f32
                    } else {
                        m.shape.mean[r] as f32 + sum(&row(&b, r), &f.identity)
                    };
                    let want = start + sum(&row(d, r), &f.expression);
                    assert_eq!(got.to_bits(), want.to_bits(), "frame {} row {r}", f.frame);
                }
                seen += 1;
            });
            assert_eq!(seen, fits.len());
        }
    }
}
