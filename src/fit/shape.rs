//! The regularised linear shape fit (eos's `fit_shape_to_landmarks_linear`) over the model rows
//! of the mapped landmark vertices only, precomputed once per model, map, set and weights.
//!
//! With the camera fixed, landmark i's projection is affine in the coefficients c = [α; β]:
//! `x̂ᵢ = s·R₂·(mᵢ + Bᵢ·c) + s·t` (R₂ = rows r1, r2; ṽ = H − v). The fit solves
//! `(AᵀΩA + Λ)·c = −AᵀΩb` with `Aᵢ = s·R₂·Bᵢ`, `bᵢ = s·R₂·mᵢ + s·t − xᵢ`, `Ω = wᵢ/σ²` and
//! `Λ = diag(λ)`. Because `AᵢᵀAᵢ = s²·Bᵢᵀ·Q·Bᵢ` with `Q = r1r1ᵀ + r2r2ᵀ`, the normal matrix is
//! `s²/σ²·Σⱼₖ Qⱼₖ·Mⱼₖ` where `Mⱼₖ = Σᵢ wᵢ·Bᵢ[j,:]ᵀBᵢ[k,:]` are six fixed K×K matrices: building it
//! costs 6K² instead of 2L·K², whatever the pose.

use crate::landmarks::{LandmarkSet, N_LANDMARKS};
use crate::math::{DMatrix, DVector, Point2, Point3, Real, Vector3};
use crate::model::{LandmarkMap, MorphableModel};
use std::sync::{Arc, Mutex};

use super::camera::{OrthoPose, PoseResidual};

/// Declares `fn name<'a>(args…) -> Out`, which runs the `#[inline(always)]` function
/// `kernel(args…)` compiled for the widest vector instructions the CPU has (AVX2 where
/// present, detected at run time by pulp; the build itself targets baseline x86-64, two
/// doubles per instruction): the loops of `kernel` and of the `#[inline(always)]` helpers it
/// calls, such as [`dot`] and [`axpy`], then work on four doubles at a time. Vector width does
/// not change the results: each lane does the same operations in the same order.
///
/// Only code inlined into pulp's target-feature function gets the wider instructions: a
/// closure or a function reached through `FnOnce` is compiled on its own, for the baseline,
/// hence a declared function calling `kernel` by name.
///
/// `= simd kernel` passes pulp's token first, `kernel(simd, args…)`, for a kernel written
/// in pulp's vector types: the compiler vectorises a loop only when it can prove that the
/// slices it stores to do not overlap those it loads from, and across several columns of
/// one matrix it cannot.
macro_rules! vectorised {
    (@with $(#[$meta:meta])* $vis:vis fn $name:ident<$lt:lifetime>($($arg:ident: $ty:ty),*)
        -> $out:ty, $simd:ident => $call:expr) => {
        $(#[$meta])*
        $vis fn $name<$lt>($($arg: $ty),*) -> $out {
            struct Op<$lt>($($ty),*);
            impl<$lt> pulp::WithSimd for Op<$lt> {
                type Output = $out;
                #[inline(always)]
                fn with_simd<S: pulp::Simd>(self, $simd: S) -> $out {
                    let Op($($arg),*) = self;
                    $call
                }
            }
            pulp::Arch::new().dispatch(Op($($arg),*))
        }
    };
    ($(#[$meta:meta])* $vis:vis fn $name:ident<$lt:lifetime>($($arg:ident: $ty:ty),* $(,)?)
        -> $out:ty = simd $kernel:path) => {
        vectorised! { @with $(#[$meta])* $vis fn $name<$lt>($($arg: $ty),*) -> $out,
            simd => $kernel(simd, $($arg),*) }
    };
    ($(#[$meta:meta])* $vis:vis fn $name:ident<$lt:lifetime>($($arg:ident: $ty:ty),* $(,)?)
        -> $out:ty = $kernel:path) => {
        vectorised! { @with $(#[$meta])* $vis fn $name<$lt>($($arg: $ty),*) -> $out,
            _simd => $kernel($($arg),*) }
    };
}
pub(crate) use vectorised;

/// eos's data-term variance: `Ω = I/σ²` with σ = √3 px (its default). lipmap keeps the
/// convention so its λ means what eos's λ means.
pub const EOS_SIGMA_SQUARED: Real = 3.0;

/// Model rows of the landmark vertices a fit uses: mean, rescaled identity basis
/// `B·diag(√e)` and expression deltas, plus the weighted Gram blocks `Mⱼₖ`.
#[derive(Clone, Debug)]
pub struct LandmarkBasis {
    /// 0-based iBUG indices, ascending.
    pub landmarks: Vec<usize>,
    /// The model vertex of each landmark.
    pub vertices: Vec<usize>,
    /// Which entries stand for one side of an inner-lip pair in contact ([`LipContact`])
    /// rather than for their landmark's own vertex; all `None` in a basis made by
    /// [`LandmarkBasis::new`].
    pub contact: Vec<Option<LipContact>>,
    /// Per-landmark weight wᵢ (> 0).
    pub weights: Vec<Real>,
    /// The lip-contact gain γ of the contact entries (1 when there are none).
    pub gain: Real,
    /// Identity components (first columns of the rows).
    pub k_id: usize,
    /// Expression blendshapes (last columns).
    pub k_exp: usize,
    mean: Vec<Vector3>,
    /// Row-major rows: landmark i, axis j at `rows[(3i + j)·K ..][..K]`.
    rows: Vec<Real>,
    /// Gram blocks over all entries.
    gram: Arc<GramBlocks>,
    /// Gram blocks of the entry sets frames used lately (see [`LandmarkBasis::used_grams`]).
    used_grams: UsedGramCache,
    /// Per expression e, the nine rows `Σᵢ wᵢ·Eᵢ[a,e]·Bᵢ[b,:]` (a, b = x, y, z; row 3a + b;
    /// K each): the expression rows of the ordered Gram blocks, which the joint solver's
    /// pose–coefficient coupling is made of (`fit::joint`).
    expression_moments: Vec<Real>,
    /// `Σᵢ wᵢ·Bᵢ[b,:]` for b = x, y, z (3 rows of K).
    row_sums: Vec<Real>,
    /// `rows` by blocks of four columns: block c holds, landmark after landmark and axis
    /// after axis, columns 4c..4c + 4 (past K: 0), so that a kernel summing over the
    /// landmarks for four columns reads one contiguous run ([`LandmarkBasis::column_block`]).
    row_blocks: Vec<[Real; 4]>,
    /// Each landmark's expression deltas as points, `[E_x, E_y, E_z, 0]` at `i·k_exp + e`:
    /// a frame's offset `Eᵢ·β` is then a sum of four-wide terms.
    expression_points: Vec<[Real; 4]>,
}

/// One entry of a basis: a landmark's vertex, or one side of a lip contact.
#[derive(Clone, Copy, Debug)]
struct Entry {
    landmark: usize,
    vertex: usize,
    weight: Real,
    contact: Option<LipContact>,
}

/// One side of an inner-lip pair (upper u, lower l) seen as a contact: on a frame whose inner
/// lips meet, the pair's two landmarks are replaced by two entries at the affine combinations
/// `mid ± γ·d/2` of their vertices (mid = (v_u + v_l)/2, d = v_u − v_l), both observed at the
/// tracked pair's midpoint m: lips in contact have no gap, whatever gap the tracker's noise
/// leaves between its two points. Their squared residuals sum to `2|mid − m|² + γ²/2·|d|²`:
/// the midpoint keeps the weight the two points gave it, and the gap is held at 0 with γ²
/// times their weight, i.e. the variance the contact's precision says (`docs/closure.md`).
/// Affine combinations keep the translation, so every solver takes the entries as
/// landmarks.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LipContact {
    /// 0-based iBUG ids of the pair.
    pub upper: usize,
    pub lower: usize,
    /// +1 for the entry on the upper side, −1 for the lower.
    pub side: Real,
}

/// Index pairs of the six Gram blocks, matching `LandmarkBasis::gram`.
pub(crate) const GRAM_PAIRS: [(usize, usize); 6] = [(0, 0), (1, 1), (2, 2), (0, 1), (0, 2), (1, 2)];

/// Whether landmark `l` (0-based iBUG id) mapped to vertex `v` can drive a fit on a model of
/// `n_vertices` vertices: in `set`, an existing vertex, and a finite weight > 0 (`weights`
/// indexed by landmark; missing or empty = 1). Map checks before a fit count with this rule.
pub fn is_usable_landmark(
    l: usize,
    v: usize,
    n_vertices: usize,
    set: LandmarkSet,
    weights: &[Real],
) -> bool {
    let w = weights.get(l).copied().unwrap_or(1.0);
    l < N_LANDMARKS && set.contains(l) && v < n_vertices && w.is_finite() && w > 0.0
}

impl LandmarkBasis {
    /// Precomputes the rows of the landmarks of `set` that `map` maps to a vertex of `model`,
    /// weighted by `weights` (indexed by 0-based iBUG id; missing or empty = 1; landmarks with
    /// a weight ≤ 0 or non-finite are left out).
    pub fn new(
        model: &MorphableModel,
        map: &LandmarkMap,
        set: LandmarkSet,
        weights: &[Real],
    ) -> Self {
        let n = model.num_vertices();
        let pairs: Vec<(usize, usize, Real)> = map
            .pairs()
            .filter(|&(l, v)| is_usable_landmark(l, v, n, set, weights))
            .map(|(l, v)| (l, v, weights.get(l).copied().unwrap_or(1.0)))
            .collect();
        Self::from_vertices(model, &pairs)
    }

    /// As [`LandmarkBasis::new`] from explicit (landmark, vertex, weight) triples.
    pub fn from_vertices(model: &MorphableModel, pairs: &[(usize, usize, Real)]) -> Self {
        let entries: Vec<Entry> = pairs
            .iter()
            .map(|&(l, v, w)| Entry { landmark: l, vertex: v, weight: w, contact: None })
            .collect();
        Self::from_entries(model, &entries, 1.0)
    }

    /// This basis plus, for each inner-lip pair (`landmarks::closure::INNER_LIP_PAIRS`) both
    /// of whose landmarks it has, the two [`LipContact`] entries with gain γ = `gain` (≥ 1).
    /// Frames whose lips meet use them instead of the pair's own entries
    /// ([`FrameObservations::new`]); the others leave them out.
    pub fn with_lip_contact(&self, model: &MorphableModel, gain: Real) -> Self {
        let mut entries: Vec<Entry> = (0..self.len())
            .filter(|&i| self.contact[i].is_none())
            .map(|i| Entry {
                landmark: self.landmarks[i],
                vertex: self.vertices[i],
                weight: self.weights[i],
                contact: None,
            })
            .collect();
        let at = |l: usize| entries.iter().position(|e| e.landmark == l);
        let mut added = Vec::new();
        for (upper, lower) in crate::landmarks::closure::INNER_LIP_PAIRS {
            let (Some(u), Some(d)) = (at(upper), at(lower)) else { continue };
            let weight = 0.5 * (entries[u].weight + entries[d].weight);
            for (side, e) in [(1.0, u), (-1.0, d)] {
                added.push(Entry {
                    landmark: entries[e].landmark,
                    vertex: entries[e].vertex,
                    weight,
                    contact: Some(LipContact { upper, lower, side }),
                });
            }
        }
        entries.extend(added);
        Self::from_entries(model, &entries, gain.max(1.0))
    }

    /// The basis of `entries`; contact entries combine the rows of their pair's vertices
    /// with gain `gain`.
    fn from_entries(model: &MorphableModel, entries: &[Entry], gain: Real) -> Self {
        let k_id = model.num_shape_components();
        let k_exp = model.num_expressions();
        let k = k_id + k_exp;
        let l = entries.len();
        let vertex_of = |landmark: usize| {
            entries.iter().find(|e| e.landmark == landmark && e.contact.is_none()).map(|e| e.vertex)
        };
        let mut rows = vec![0.0; 3 * l * k];
        let mut mean = Vec::with_capacity(l);
        let m = &model.shape.mean;
        for (i, e) in entries.iter().enumerate() {
            // (vertex, factor) terms of the entry's point.
            let terms: Vec<(usize, Real)> = match e.contact {
                None => vec![(e.vertex, 1.0)],
                Some(c) => {
                    let (u, d) = (vertex_of(c.upper), vertex_of(c.lower));
                    let (u, d) = (u.unwrap_or(e.vertex), d.unwrap_or(e.vertex));
                    let a = 0.5 * (1.0 + c.side * gain);
                    vec![(u, a), (d, 1.0 - a)]
                }
            };
            let mut p = Vector3::zeros();
            for &(v, f) in &terms {
                p += f * Vector3::new(m[3 * v], m[3 * v + 1], m[3 * v + 2]);
            }
            mean.push(p);
            for j in 0..3 {
                let row = &mut rows[(3 * i + j) * k..(3 * i + j + 1) * k];
                for &(v, f) in &terms {
                    for (c, r) in row.iter_mut().enumerate().take(k_id) {
                        *r += f * model.shape.basis[(3 * v + j, c)] * model.shape.sigma(c);
                    }
                    if let Some(ex) = &model.expressions {
                        for c in 0..k_exp {
                            row[k_id + c] += f * ex.deltas[(3 * v + j, c)];
                        }
                    }
                }
            }
        }
        let weights: Vec<Real> = entries.iter().map(|e| e.weight).collect();
        let gram = Arc::new(GramBlocks::of_entries(&rows, &weights, k, 0..l));
        let mut expression_moments = vec![0.0; k_exp * 9 * k];
        for (e, block) in expression_moments.chunks_exact_mut(9 * k.max(1)).enumerate() {
            for (ab, row) in block.chunks_exact_mut(k).enumerate() {
                let (a, b) = (ab / 3, ab % 3);
                for i in 0..l {
                    let f = weights[i] * rows[(3 * i + a) * k + k_id + e];
                    axpy(f, &rows[(3 * i + b) * k..(3 * i + b + 1) * k], row);
                }
            }
        }
        let mut row_sums = vec![0.0; 3 * k];
        for (b, row) in row_sums.chunks_exact_mut(k.max(1)).enumerate().take(3) {
            for i in 0..l {
                axpy(weights[i], &rows[(3 * i + b) * k..(3 * i + b + 1) * k], row);
            }
        }
        let expression_points = (0..l)
            .flat_map(|i| {
                let rows = &rows[3 * i * k..3 * (i + 1) * k];
                (k_id..k).map(move |c| [rows[c], rows[k + c], rows[2 * k + c], 0.0])
            })
            .collect();
        let row_blocks = (0..k.div_ceil(4))
            .flat_map(|c| {
                rows.chunks_exact(k.max(1))
                    .map(move |r| std::array::from_fn(|j| r.get(4 * c + j).copied().unwrap_or(0.0)))
            })
            .collect();
        Self {
            landmarks: entries.iter().map(|e| e.landmark).collect(),
            vertices: entries.iter().map(|e| e.vertex).collect(),
            contact: entries.iter().map(|e| e.contact).collect(),
            gain,
            weights,
            k_id,
            k_exp,
            mean,
            rows,
            gram,
            used_grams: UsedGramCache::default(),
            expression_moments,
            row_sums,
            row_blocks,
            expression_points,
        }
    }

    /// Number of landmarks L.
    pub fn len(&self) -> usize {
        self.landmarks.len()
    }

    pub fn is_empty(&self) -> bool {
        self.landmarks.is_empty()
    }

    /// Total coefficients K = identity + expression.
    pub fn num_coefficients(&self) -> usize {
        self.k_id + self.k_exp
    }

    /// Row `axis` (0 x, 1 y, 2 z) of landmark `i`: K coefficients.
    #[inline(always)]
    pub fn row(&self, i: usize, axis: usize) -> &[Real] {
        let k = self.num_coefficients();
        &self.rows[(3 * i + axis) * k..(3 * i + axis + 1) * k]
    }

    /// Columns 4c..4c + 4 of every row, landmark after landmark, axis after axis (3L
    /// entries; columns past K are 0).
    #[inline]
    pub(crate) fn column_block(&self, c: usize) -> &[[Real; 4]] {
        let n = 3 * self.len();
        &self.row_blocks[c * n..(c + 1) * n]
    }

    /// The expression part of row `axis` of landmark `i` (k_exp coefficients).
    #[inline]
    pub(crate) fn expression_row(&self, i: usize, axis: usize) -> &[Real] {
        &self.row(i, axis)[self.k_id..]
    }

    /// The nine rows `Σᵢ wᵢ·Eᵢ[a,e]·Bᵢ[b,:]` of expression `e` (row 3a + b, K each).
    pub(crate) fn expression_moments(&self, e: usize) -> &[Real] {
        let k9 = 9 * self.num_coefficients();
        &self.expression_moments[e * k9..(e + 1) * k9]
    }

    /// `Σᵢ wᵢ·Bᵢ[b,:]` for b = x, y, z (3 rows of K).
    pub(crate) fn row_sums(&self) -> &[Real] {
        &self.row_sums
    }

    /// The Gram blocks of the entries `used` marks (one flag per entry, as
    /// [`FrameObservations::active`]): all entries' blocks minus those of the unused ones.
    /// A clip's frames use few distinct sets (every point seen; the lips apart or meeting,
    /// which swaps the inner-lip pairs for their contact entries), so the sets met lately are
    /// kept and a frame's normal matrix costs six K×K multiply-adds whatever it leaves out,
    /// where subtracting each unused entry per frame and iteration cost 2K² apiece.
    pub(crate) fn used_grams(&self, used: &[bool]) -> Arc<GramBlocks> {
        if used.iter().all(|&u| u) {
            return Arc::clone(&self.gram);
        }
        if let Some(g) = self.used_grams.find(used) {
            return g;
        }
        let k = self.num_coefficients();
        let unused = (0..self.len()).filter(|&i| !used.get(i).copied().unwrap_or(false));
        let unused = GramBlocks::of_entries(&self.rows, &self.weights, k, unused);
        let g = Arc::new(GramBlocks(std::array::from_fn(|p| &self.gram.0[p] - &unused.0[p])));
        self.used_grams.keep(used, Arc::clone(&g));
        g
    }

    /// Mean position of landmark `i`'s vertex.
    pub fn mean(&self, i: usize) -> Vector3 {
        self.mean[i]
    }

    /// The expression offset `Eᵢ·β` of landmark `i` (β of length k_exp).
    #[inline]
    pub(crate) fn expression_offset(&self, i: usize, beta: &[Real]) -> Vector3 {
        let ke = self.k_exp;
        let mut o = [0.0; 4];
        for (&b, e) in beta.iter().zip(&self.expression_points[i * ke..(i + 1) * ke]) {
            for l in 0..4 {
                o[l] += e[l] * b;
            }
        }
        Vector3::new(o[0], o[1], o[2])
    }

    /// Landmark `i`'s vertex for coefficients `c` (length K; identity then expression).
    #[inline]
    pub fn point(&self, i: usize, c: &[Real]) -> Point3 {
        let mut p = self.mean[i];
        for j in 0..3 {
            p[j] += dot(self.row(i, j), c);
        }
        Point3::from(p)
    }

    /// Landmark points `mean + B·c` for the coefficients `c[cols]` only (the rest taken as 0).
    pub fn points_partial(&self, c: &[Real], cols: std::ops::Range<usize>) -> Vec<Vector3> {
        points_partial(self, c, cols)
    }

    #[inline(always)]
    fn points_partial_kernel(
        basis: &Self,
        c: &[Real],
        cols: std::ops::Range<usize>,
    ) -> Vec<Vector3> {
        // A plain loop: an iterator's `collect` would run in a function of its own, outside
        // the vectorised kernel.
        let mut out = Vec::with_capacity(basis.len());
        for (i, &mean) in basis.mean.iter().enumerate() {
            let mut p = mean;
            for j in 0..3 {
                p[j] += fused_dot(&basis.row(i, j)[cols.clone()], &c[cols.clone()]);
            }
            out.push(p);
        }
        out
    }
}

/// The six weighted Gram blocks `Mⱼₖ = Σᵢ wᵢ·Bᵢ[j,:]ᵀBᵢ[k,:]` of a set of basis entries, in
/// `GRAM_PAIRS` order (xx, yy, zz, xy+yx, xz+zx, yz+zy; K×K each, symmetric).
#[derive(Debug)]
pub(crate) struct GramBlocks([DMatrix; 6]);

impl GramBlocks {
    /// The blocks of `entries` of the row-major basis rows `rows` (K wide) with `weights`.
    fn of_entries(
        rows: &[Real],
        weights: &[Real],
        k: usize,
        entries: impl Iterator<Item = usize>,
    ) -> Self {
        let entries: Vec<usize> = entries.collect();
        // The rows of each axis as n×K matrices, plain and weighted, so that every block is
        // one matrix product: B_aᵀ·diag(w)·B_b.
        let axis = |a: usize, weighted: bool| {
            DMatrix::from_fn(entries.len(), k, |r, c| {
                let i = entries[r];
                rows[(3 * i + a) * k + c] * if weighted { weights[i] } else { 1.0 }
            })
        };
        let plain: [DMatrix; 3] = std::array::from_fn(|a| axis(a, false));
        let weighted: [DMatrix; 3] = std::array::from_fn(|a| axis(a, true));
        Self(GRAM_PAIRS.map(|(a, b)| {
            let m = weighted[a].tr_mul(&plain[b]);
            if a == b { m } else { &m + m.transpose() }
        }))
    }

    /// Column `j` of block `g` (the order of `GRAM_PAIRS`), which is also its row.
    pub(crate) fn column(&self, g: usize, j: usize) -> &[Real] {
        let k = self.0[g].nrows();
        &self.0[g].as_slice()[j * k..(j + 1) * k]
    }

    /// Adds `scale · Σⱼₖ Qⱼₖ·Mⱼₖ[rows, cols]` to `out` (shape rows × cols): the normal matrix
    /// of these entries seen through projector `Q`. One pass over `out`, a column at a time,
    /// the six blocks added in `GRAM_PAIRS` order.
    pub(crate) fn add(
        &self,
        q: &crate::math::Matrix3,
        scale: Real,
        rows: std::ops::Range<usize>,
        cols: std::ops::Range<usize>,
        out: &mut DMatrix,
    ) {
        let f = GRAM_PAIRS.map(|(a, b)| scale * q[(a, b)]);
        add_gram(self, f, rows, cols, false, out);
    }

    /// [`GramBlocks::add`] over the square block `0..n`, its lower triangle only (row ≥
    /// column; the rest of `out` is left as it was): what [`cholesky_in_place`] reads of a
    /// column-major symmetric matrix, at half the multiply-adds.
    pub(crate) fn add_lower(
        &self,
        q: &crate::math::Matrix3,
        scale: Real,
        n: usize,
        out: &mut DMatrix,
    ) {
        add_gram(self, GRAM_PAIRS.map(|(a, b)| scale * q[(a, b)]), 0..n, 0..n, true, out);
    }

    #[inline(always)]
    fn add_kernel(
        grams: &Self,
        f: [Real; 6],
        rows: std::ops::Range<usize>,
        cols: std::ops::Range<usize>,
        lower: bool,
        out: &mut DMatrix,
    ) {
        let (k, n) = (grams.0[0].nrows(), rows.len());
        for (oc, c) in cols.enumerate() {
            // Rows of this column: all, or those on and below the diagonal.
            let first = if lower { oc.min(n) } else { 0 };
            let o = &mut out.as_mut_slice()[oc * n + first..(oc + 1) * n];
            // Equal lengths the compiler can see, so that the loop has no bounds checks and
            // vectorises. Written out: an array's `map` here is a call per column.
            let len = o.len();
            let block = |i: usize| {
                &grams.0[i].as_slice()[c * k + rows.start + first..c * k + rows.end][..len]
            };
            let g = [block(0), block(1), block(2), block(3), block(4), block(5)];
            // One fused multiply-add per block, in block order.
            for r in 0..o.len() {
                o[r] = (0..6).fold(o[r], |acc, j| f[j].mul_add(g[j][r], acc));
            }
        }
    }
}

/// The entry sets whose [`GramBlocks`] were made last, newest at the end. A clone starts
/// empty: the cache belongs to one basis value and is only a shortcut.
#[derive(Default)]
struct UsedGramCache(Mutex<Vec<(Vec<bool>, Arc<GramBlocks>)>>);

/// Entry sets kept: a clip uses two or three; frames missing points at random use more, and
/// for those the oldest set is dropped.
const USED_GRAM_SETS: usize = 8;

impl UsedGramCache {
    fn sets(&self) -> std::sync::MutexGuard<'_, Vec<(Vec<bool>, Arc<GramBlocks>)>> {
        // A panic elsewhere while the lock was held leaves whole entries: still usable.
        self.0.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    fn find(&self, used: &[bool]) -> Option<Arc<GramBlocks>> {
        self.sets().iter().find(|(u, _)| u == used).map(|(_, g)| Arc::clone(g))
    }

    fn keep(&self, used: &[bool], grams: Arc<GramBlocks>) {
        let mut sets = self.sets();
        if sets.iter().any(|(u, _)| u == used) {
            return;
        }
        if sets.len() == USED_GRAM_SETS {
            sets.remove(0);
        }
        sets.push((used.to_vec(), grams));
    }
}

impl Clone for UsedGramCache {
    fn clone(&self) -> Self {
        Self::default()
    }
}

impl std::fmt::Debug for UsedGramCache {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "UsedGramCache({} sets)", self.sets().len())
    }
}

vectorised! {
    /// [`LandmarkBasis::points_partial`], vectorised.
    fn points_partial<'a>(basis: &'a LandmarkBasis, c: &'a [Real], cols: std::ops::Range<usize>)
        -> Vec<Vector3> = LandmarkBasis::points_partial_kernel
}

vectorised! {
    /// [`GramBlocks::add`] with the six factors made, vectorised.
    fn add_gram<'a>(
        grams: &'a GramBlocks,
        f: [Real; 6],
        rows: std::ops::Range<usize>,
        cols: std::ops::Range<usize>,
        lower: bool,
        out: &'a mut DMatrix,
    ) -> () = GramBlocks::add_kernel
}

/// Dot product with four independent partial sums: a single running sum is a serial chain
/// the compiler may not reorder (floating point), four lanes let it vectorise.
#[inline(always)]
pub(crate) fn dot(a: &[Real], b: &[Real]) -> Real {
    dot_by(a, b, |x, y, sum| sum + x * y)
}

/// [`dot`] with each term a fused multiply-add: for the vectorised kernels only, which are
/// compiled for FMA (elsewhere `mul_add` is a library call).
#[inline(always)]
fn fused_dot(a: &[Real], b: &[Real]) -> Real {
    dot_by(a, b, |x, y, sum| x.mul_add(y, sum))
}

/// The dot product of the shorter length, each term added to its lane's sum by `add`.
#[inline(always)]
fn dot_by(a: &[Real], b: &[Real], add: impl Fn(Real, Real, Real) -> Real) -> Real {
    let n = a.len().min(b.len());
    let (a, b) = (&a[..n], &b[..n]);
    let mut acc = [0.0; 4];
    let (ca, cb) = (a.chunks_exact(4), b.chunks_exact(4));
    let (ra, rb) = (ca.remainder(), cb.remainder());
    for (x, y) in ca.zip(cb) {
        for l in 0..4 {
            acc[l] = add(x[l], y[l], acc[l]);
        }
    }
    let tail = ra.iter().zip(rb).fold(0.0, |sum, (&x, &y)| add(x, y, sum));
    (acc[0] + acc[2]) + (acc[1] + acc[3]) + tail
}

/// `y += a·x` over the shorter of the two.
#[inline(always)]
pub(crate) fn axpy(a: Real, x: &[Real], y: &mut [Real]) {
    for (y, &x) in y.iter_mut().zip(x) {
        *y += a * x;
    }
}

/// `Q = r1r1ᵀ + r2r2ᵀ = I − r3r3ᵀ` (R₂ᵀR₂) of a pose.
pub(crate) fn projector(pose: &OrthoPose) -> crate::math::Matrix3 {
    let r3 = pose.r.row(2).transpose();
    crate::math::Matrix3::identity() - r3 * r3.transpose()
}

/// The per-landmark data of one frame as the solvers need it: image points for each basis
/// landmark and which of them are used (visible and finite; on a frame whose inner lips meet,
/// the basis's lip-contact entries instead of the pairs they stand for).
#[derive(Clone, Debug)]
pub struct FrameObservations {
    pub frame: usize,
    /// One per basis landmark; unusable ones hold (0, 0).
    pub points: Vec<Point2>,
    /// Whether each entry enters the fit.
    pub active: Vec<bool>,
    /// Whether a landmark entry's own point was seen (visible and finite), used or not: a
    /// pair replaced by its contact entries is still seen and its residual reported.
    pub seen: Vec<bool>,
    pub num_active: usize,
}

impl FrameObservations {
    /// Observations of `basis`'s landmarks from one frame; a point counts when it is visible
    /// and both coordinates are finite. When the frame's inner lips meet
    /// (`lip_contact_px`) and the basis has contact entries for a pair seen whole, the
    /// contact entries replace the pair.
    pub fn new(basis: &LandmarkBasis, lm: &crate::landmarks::FrameLandmarks) -> Self {
        let seen_point = |l: usize| {
            lm.points
                .get(l)
                .filter(|p| p.visible && p.x.is_finite() && p.y.is_finite())
                .map(|p| Point2::new(p.x, p.y))
        };
        let meet = lm.lip_contact_px.is_some();
        // The pairs whose contact entries this frame uses.
        let contact_pair = |upper: usize, lower: usize| {
            meet && seen_point(upper).is_some()
                && seen_point(lower).is_some()
                && basis.contact.iter().flatten().any(|c| c.upper == upper && c.lower == lower)
        };
        let replaced = |l: usize| {
            crate::landmarks::closure::INNER_LIP_PAIRS
                .iter()
                .any(|&(u, d)| (l == u || l == d) && contact_pair(u, d))
        };
        let n = basis.len();
        let (mut points, mut active, mut seen) =
            (Vec::with_capacity(n), Vec::with_capacity(n), Vec::with_capacity(n));
        for (&l, c) in basis.landmarks.iter().zip(&basis.contact) {
            let (point, used, own) = match c {
                None => match seen_point(l) {
                    Some(p) => (p, !replaced(l), true),
                    None => (Point2::origin(), false, false),
                },
                // Both sides at the pair's midpoint: the gap observed is 0. Observing the
                // tracked gap instead held a fitted head open by the mean length of the
                // tracker's noise (a length is never negative) wherever the tracker closes
                // the lips itself.
                Some(c) if contact_pair(c.upper, c.lower) => {
                    let (u, d) = (seen_point(c.upper).unwrap(), seen_point(c.lower).unwrap());
                    (nalgebra::center(&u, &d), true, false)
                }
                Some(_) => (Point2::origin(), false, false),
            };
            points.push(point);
            active.push(used);
            seen.push(own);
        }
        let num_active = active.iter().filter(|a| **a).count();
        Self { frame: lm.frame, points, active, seen, num_active }
    }
}

/// Builds `AᵀΩA` over `cols` (rows `rows`) for one frame, visible landmarks only.
pub(crate) fn normal_matrix(
    basis: &LandmarkBasis,
    obs: &FrameObservations,
    pose: &OrthoPose,
    sigma2: Real,
    rows: std::ops::Range<usize>,
    cols: std::ops::Range<usize>,
) -> DMatrix {
    let scale = pose.s * pose.s / sigma2;
    let mut n = DMatrix::zeros(rows.len(), cols.len());
    basis.used_grams(&obs.active).add(&projector(pose), scale, rows, cols, &mut n);
    n
}

/// Per-landmark "forces" `hᵢ = wᵢ/σ²·s·R₂ᵀ·bᵢ` (3-vectors, zero for unused points) of the
/// residuals `bᵢ` of the landmark points `base`: `−AᵀΩb = −Σᵢ Bᵢᵀhᵢ`. Splitting the gradient
/// this way lets a clip sum the forces of all frames first and apply the rows once.
pub(crate) fn landmark_forces(
    basis: &LandmarkBasis,
    obs: &FrameObservations,
    pose: &OrthoPose,
    image_height: Real,
    sigma2: Real,
    base: &[Vector3],
) -> Vec<Vector3> {
    let (r1, r2) = (pose.r.row(0).transpose(), pose.r.row(1).transpose());
    base.iter()
        .enumerate()
        .map(|(i, x)| {
            if !obs.active[i] {
                return Vector3::zeros();
            }
            let b = PoseResidual::new(pose, x, &obs.points[i], image_height);
            (r1 * b.u + r2 * b.v) * (pose.s * basis.weights[i] / sigma2)
        })
        .collect()
}

vectorised! {
    /// `−Σᵢ Bᵢ[:, cols]ᵀ·hᵢ` for per-landmark forces `h`.
    pub(crate) fn apply_forces<'a>(
        basis: &'a LandmarkBasis,
        forces: &'a [Vector3],
        cols: std::ops::Range<usize>,
    ) -> DVector = apply_forces_kernel
}

/// [`apply_forces`]: a plain loop, so that it runs in the vectorised kernel.
#[inline(always)]
fn apply_forces_kernel(
    basis: &LandmarkBasis,
    forces: &[Vector3],
    cols: std::ops::Range<usize>,
) -> DVector {
    let mut g = DVector::zeros(cols.len());
    let gs = g.as_mut_slice();
    if cols == (basis.k_id..basis.num_coefficients()) {
        // The expression columns alone: their contiguous copy, three rows at once (taken
        // one by one, not with `array::map`: see `splat4`).
        for (i, h) in forces.iter().enumerate() {
            let row = |j: usize| basis.expression_row(i, j);
            let (x, y, z) = (row(0), row(1), row(2));
            for (((g, &x), &y), &z) in gs.iter_mut().zip(x).zip(y).zip(z) {
                *g -= h.x * x + h.y * y + h.z * z;
            }
        }
        return g;
    }
    for (i, h) in forces.iter().enumerate() {
        for j in 0..3 {
            if h[j] != 0.0 {
                axpy(-h[j], &basis.row(i, j)[cols.clone()], gs);
            }
        }
    }
    g
}

/// `−AᵀΩb` over coefficient range `cols`, where `b` is the residual of the landmark points
/// `base` (one per basis landmark: the shape with the solved-for coefficients at 0).
pub(crate) fn gradient_rhs(
    basis: &LandmarkBasis,
    obs: &FrameObservations,
    pose: &OrthoPose,
    image_height: Real,
    sigma2: Real,
    base: &[Vector3],
    cols: std::ops::Range<usize>,
) -> DVector {
    apply_forces(basis, &landmark_forces(basis, obs, pose, image_height, sigma2, base), cols)
}

/// eos's `fit_shape_to_landmarks_linear`: coefficients `cols` that minimise
/// `Σᵢ wᵢ/σ²·|x̂ᵢ − xᵢ|² + λ·|c|²` with the pose fixed and the other coefficients held at `c`
/// (entries of `c` inside `cols` are ignored). `None` if the system is not positive definite.
#[allow(clippy::too_many_arguments)] // mirrors eos's function, one argument per input
pub fn fit_coefficients_linear(
    basis: &LandmarkBasis,
    obs: &FrameObservations,
    pose: &OrthoPose,
    image_height: Real,
    c: &[Real],
    cols: std::ops::Range<usize>,
    lambda: Real,
    sigma2: Real,
) -> Option<DVector> {
    let mut c0 = c.to_vec();
    for v in &mut c0[cols.clone()] {
        *v = 0.0;
    }
    let mut n = normal_matrix(basis, obs, pose, sigma2, cols.clone(), cols.clone());
    for d in 0..cols.len() {
        n[(d, d)] += lambda;
    }
    let base: Vec<Vector3> = (0..basis.len()).map(|i| basis.point(i, &c0).coords).collect();
    let g = gradient_rhs(basis, obs, pose, image_height, sigma2, &base, cols);
    let x = n.cholesky()?.solve(&g);
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Solves `A·x = b` in place for a symmetric positive definite `A` (n×n; the triangle
/// [`cholesky_in_place`] reads is overwritten by the Cholesky factor). Returns false when a
/// pivot is not positive. Written out because the fit's 63–69-wide systems are solved many
/// times per frame (see [`cholesky_in_place`] for the loop order).
pub(crate) fn cholesky_solve_in_place(a: &mut [Real], n: usize, b: &mut [Real]) -> bool {
    cholesky_in_place(a, n) && cholesky_substitute(a, n, b)
}

/// Columns of L factored before their update of the columns after them (see
/// [`cholesky_in_place`]).
const PANEL: usize = 4;

/// The Cholesky factor L (A = LLᵀ) of a symmetric positive definite n×n `a`, read from the
/// entries `a[c·n + i]` with i ≥ c (the lower triangle of a column-major matrix such as
/// nalgebra's `DMatrix`, the upper one of a row-major matrix) and written over them: column
/// c of L is the contiguous run `a[c·n + c..c·n + n]`, which the substitutions read
/// ([`forward_substitute`], [`back_substitute`]); the other triangle is left as it was.
/// False when a pivot is not positive or not finite.
///
/// The outer-product form (Golub & Van Loan, *Matrix Computations*, 4th ed., §4.2): column k
/// of L is scaled by its pivot and subtracted as a rank-1 update from every later column.
/// Columns are contiguous, so scaling a column, the updates inside a panel and the updates of
/// the later columns are all contiguous multiply-adds, which vectorise. The columns are taken
/// [`PANEL`] at a time: a panel is factored, then each later column gets the panel's
/// [`PANEL`] updates in one pass (two columns per pass, sharing the panel's loads), in the
/// same order as one at a time, each a fused multiply-add, so every entry sees the same
/// operations in the same order as in the plain column-by-column form and the factor is the
/// same to the bit. Fused multiply-adds are exact before their one rounding, so the factor
/// is the same on a CPU without FMA (where they run in software, slowly).
pub(crate) fn cholesky_in_place(a: &mut [Real], n: usize) -> bool {
    debug_assert!(a.len() >= n * n);
    cholesky_vectorised(a, n)
}

vectorised! {
    fn cholesky_vectorised<'a>(a: &'a mut [Real], n: usize) -> bool = simd cholesky_panels
}

#[inline(always)]
fn cholesky_panels<S: pulp::Simd>(simd: S, a: &mut [Real], n: usize) -> bool {
    let mut k = 0;
    while k < n {
        let end = (k + PANEL).min(n);
        // The panel: each column scaled by its pivot, then subtracted from the panel's later
        // columns.
        for c in k..end {
            let (done, rest) = a.split_at_mut((c + 1) * n);
            let col = &mut done[c * n..];
            let d = col[c];
            if !d.is_finite() || d <= 0.0 {
                return false;
            }
            let d = d.sqrt();
            col[c] = d;
            let inv = 1.0 / d;
            for v in &mut col[c + 1..n] {
                *v *= inv;
            }
            for m in c + 1..end {
                let lmc = col[m];
                let cm = &mut rest[(m - c - 1) * n..(m - c) * n];
                for (x, &l) in cm[m..n].iter_mut().zip(&col[m..n]) {
                    *x = (-l).mul_add(lmc, *x);
                }
            }
        }
        let (panel, later) = a.split_at_mut(end * n);
        let panel = &panel[k * n..];
        if end - k == PANEL {
            update_later_columns(simd, panel, later, n, end);
        } else {
            for (j, col) in (end..n).zip(later.chunks_exact_mut(n)) {
                for pc in panel.chunks_exact(n) {
                    let l = pc[j];
                    for (x, &y) in col[j..].iter_mut().zip(&pc[j..]) {
                        *x = (-y).mul_add(l, *x);
                    }
                }
            }
        }
        k = end;
    }
    true
}

/// Column j ≥ `first` of `later` (n-long columns from column `first` on) less the four
/// panel columns' rank-1 terms, `col_j[i] −= Σ_c L[i][c]·L[j][c]` for i ≥ j, c in panel
/// order; four columns per pass ([`minus_panel_terms_of_four`]), the last few two at a time
/// ([`minus_panel_terms_of_two`]).
#[inline(always)]
fn update_later_columns<S: pulp::Simd>(
    simd: S,
    panel: &[Real],
    later: &mut [Real],
    n: usize,
    first: usize,
) {
    let (p0, rest) = panel.split_at(n);
    let (p1, rest) = rest.split_at(n);
    let (p2, p3) = rest.split_at(n);
    let factors = |r: usize| [p0[r], p1[r], p2[r], p3[r]];
    let mut j = first;
    let mut quads = later.chunks_exact_mut(4 * n);
    for quad in quads.by_ref() {
        let (ca, rest) = quad.split_at_mut(n);
        let (cb, rest) = rest.split_at_mut(n);
        let (cc, cd) = rest.split_at_mut(n);
        let (la, lb, lc, ld) = (factors(j), factors(j + 1), factors(j + 2), factors(j + 3));
        // The triangle above row j + 3, entry by entry.
        ca[j] = minus_panel_terms(ca[j], la, la);
        ca[j + 1] = minus_panel_terms(ca[j + 1], lb, la);
        ca[j + 2] = minus_panel_terms(ca[j + 2], lc, la);
        cb[j + 1] = minus_panel_terms(cb[j + 1], lb, lb);
        cb[j + 2] = minus_panel_terms(cb[j + 2], lc, lb);
        cc[j + 2] = minus_panel_terms(cc[j + 2], lc, lc);
        let s = j + 3;
        let x = [&p0[s..], &p1[s..], &p2[s..], &p3[s..]];
        let cols = [&mut ca[s..], &mut cb[s..], &mut cc[s..], &mut cd[s..]];
        minus_panel_terms_of_four(simd, cols, x, [la, lb, lc, ld]);
        j += 4;
    }
    let mut cols = quads.into_remainder().chunks_exact_mut(n);
    while let Some(ca) = cols.next() {
        let la = factors(j);
        ca[j] = minus_panel_terms(ca[j], la, la);
        let s = j + 1;
        let x = [&p0[s..], &p1[s..], &p2[s..], &p3[s..]];
        match cols.next() {
            Some(cb) => {
                let lb = factors(s);
                minus_panel_terms_of_two(simd, [&mut ca[s..], &mut cb[s..]], x, [la, lb]);
                j += 2;
            }
            None => {
                for (i, v) in ca[s..].iter_mut().enumerate() {
                    *v = minus_panel_terms(*v, [x[0][i], x[1][i], x[2][i], x[3][i]], la);
                }
                j += 1;
            }
        }
    }
}

/// [`minus_panel_terms_of_two`] for four columns, which share the loads of the panel rows.
#[inline(always)]
fn minus_panel_terms_of_four<S: pulp::Simd>(
    simd: S,
    cols: [&mut [Real]; 4],
    x: [&[Real]; 4],
    l: [[Real; 4]; 4],
) {
    let [ca, cb, cc, cd] = cols;
    let (va, ta) = S::as_mut_simd_f64s(ca);
    let (vb, tb) = S::as_mut_simd_f64s(cb);
    let (vc, tc) = S::as_mut_simd_f64s(cc);
    let (vd, td) = S::as_mut_simd_f64s(cd);
    let (x0, x1) = (S::as_simd_f64s(x[0]), S::as_simd_f64s(x[1]));
    let (x2, x3) = (S::as_simd_f64s(x[2]), S::as_simd_f64s(x[3]));
    let f = [splat4(simd, l[0]), splat4(simd, l[1]), splat4(simd, l[2]), splat4(simd, l[3])];
    let ys = va.iter_mut().zip(vb.iter_mut()).zip(vc.iter_mut().zip(vd.iter_mut()));
    let rows = ys.zip(x0.0.iter().zip(x1.0)).zip(x2.0.iter().zip(x3.0));
    for ((((ya, yb), (yc, yd)), (&a0, &a1)), (&a2, &a3)) in rows {
        let a = [a0, a1, a2, a3];
        let (mut u, mut v, mut w, mut z) = (*ya, *yb, *yc, *yd);
        for c in 0..4 {
            u = simd.negate_mul_add_f64s(a[c], f[0][c], u);
            v = simd.negate_mul_add_f64s(a[c], f[1][c], v);
            w = simd.negate_mul_add_f64s(a[c], f[2][c], w);
            z = simd.negate_mul_add_f64s(a[c], f[3][c], z);
        }
        (*ya, *yb, *yc, *yd) = (u, v, w, z);
    }
    let tails = [x0.1, x1.1, x2.1, x3.1];
    let ends = ta.iter_mut().zip(tb.iter_mut()).zip(tc.iter_mut().zip(td.iter_mut()));
    for (i, ((u, v), (w, z))) in ends.enumerate() {
        let a = [tails[0][i], tails[1][i], tails[2][i], tails[3][i]];
        *u = minus_panel_terms(*u, a, l[0]);
        *v = minus_panel_terms(*v, a, l[1]);
        *w = minus_panel_terms(*w, a, l[2]);
        *z = minus_panel_terms(*z, a, l[3]);
    }
}

/// [`minus_panel_terms`] on every row of two columns that share the panel rows `x`, with
/// their own factors `l`: four rows per vector, in pulp's types so that each row sees the
/// scalar form's fused multiply-adds in its order (the same bits), the last rows scalar.
#[inline(always)]
fn minus_panel_terms_of_two<S: pulp::Simd>(
    simd: S,
    cols: [&mut [Real]; 2],
    x: [&[Real]; 4],
    l: [[Real; 4]; 2],
) {
    let [ca, cb] = cols;
    let (va, ta) = S::as_mut_simd_f64s(ca);
    let (vb, tb) = S::as_mut_simd_f64s(cb);
    let (x0, x1) = (S::as_simd_f64s(x[0]), S::as_simd_f64s(x[1]));
    let (x2, x3) = (S::as_simd_f64s(x[2]), S::as_simd_f64s(x[3]));
    let [la, lb] = [splat4(simd, l[0]), splat4(simd, l[1])];
    let rows =
        va.iter_mut().zip(vb.iter_mut()).zip(x0.0.iter().zip(x1.0)).zip(x2.0.iter().zip(x3.0));
    for (((ya, yb), (&a0, &a1)), (&a2, &a3)) in rows {
        let (mut u, mut w) = (*ya, *yb);
        for (c, a) in [a0, a1, a2, a3].into_iter().enumerate() {
            u = simd.negate_mul_add_f64s(a, la[c], u);
            w = simd.negate_mul_add_f64s(a, lb[c], w);
        }
        (*ya, *yb) = (u, w);
    }
    let tails = [x0.1, x1.1, x2.1, x3.1];
    for (i, (u, w)) in ta.iter_mut().zip(tb.iter_mut()).enumerate() {
        let a = [tails[0][i], tails[1][i], tails[2][i], tails[3][i]];
        (*u, *w) = (minus_panel_terms(*u, a, l[0]), minus_panel_terms(*w, a, l[1]));
    }
}

/// Four factors as vectors, each the factor in every lane. Written out element by element
/// rather than with `array::map`: the compiler does not always inline `map` into the
/// kernels, and a kernel that calls it pays a call for every column.
#[inline(always)]
pub(crate) fn splat4<S: pulp::Simd>(simd: S, f: [Real; 4]) -> [S::f64s; 4] {
    [simd.splat_f64s(f[0]), simd.splat_f64s(f[1]), simd.splat_f64s(f[2]), simd.splat_f64s(f[3])]
}

/// `x − Σ_c a_c·l_c`, the panel's columns in order, each term a fused multiply-add (one
/// rounding per term, one instruction inside the kernels, which are compiled for FMA).
#[inline(always)]
fn minus_panel_terms(x: Real, a: [Real; 4], l: [Real; 4]) -> Real {
    (-a[3]).mul_add(l[3], (-a[2]).mul_add(l[2], (-a[1]).mul_add(l[1], (-a[0]).mul_add(l[0], x))))
}

vectorised! {
    /// Solves `LLᵀx = b` in place for the factor [`cholesky_in_place`] wrote; false when the
    /// answer is not finite.
    pub(crate) fn cholesky_substitute<'a>(l: &'a [Real], n: usize, b: &'a mut [Real]) -> bool
        = substitute_both
}

#[inline(always)]
fn substitute_both(l: &[Real], n: usize, b: &mut [Real]) -> bool {
    forward_substitute(l, n, b);
    back_substitute(l, n, b);
    b[..n].iter().all(|v| v.is_finite())
}

/// `b ← L⁻¹b` for the factor of [`cholesky_in_place`], read by columns: once `b[j]` is
/// solved, column j's part is taken off the entries below it (a contiguous multiply-add).
#[inline(always)]
pub(crate) fn forward_substitute(l: &[Real], n: usize, b: &mut [Real]) {
    for j in 0..n {
        let col = &l[j * n + j..j * n + n];
        let (done, rest) = b[j..n].split_at_mut(1);
        done[0] /= col[0];
        axpy(-done[0], &col[1..], rest);
    }
}

/// `b ← L⁻ᵀb` for the factor of [`cholesky_in_place`], read by columns: row j of Lᵀ is
/// column j of L, so each entry is one contiguous dot product with the entries solved.
#[inline(always)]
pub(crate) fn back_substitute(l: &[Real], n: usize, b: &mut [Real]) {
    for j in (0..n).rev() {
        let col = &l[j * n + j..j * n + n];
        b[j] = (b[j] - dot(&col[1..], &b[j + 1..n])) / col[0];
    }
}

/// Minimises `½xᵀNx − gᵀx` subject to `x ≥ 0` (N symmetric positive definite, small):
/// Lawson–Hanson's active set method on the normal equations, as eos's NNLS for blendshapes
/// but with the regulariser inside N. `free[j]` tells the caller which components ended up
/// unconstrained. Returns None on a numerical failure.
pub fn nonnegative_quadratic(n: &DMatrix, g: &DVector, free: &mut [bool]) -> Option<DVector> {
    let k = g.len();
    free.iter_mut().for_each(|f| *f = false);
    if !(n.iter().all(|v| v.is_finite()) && g.iter().all(|v| v.is_finite())) {
        return None;
    }
    let mut x = DVector::zeros(k);
    // The free set's system, solved in place: one buffer each, reused by every inner step.
    let mut idx: Vec<usize> = Vec::with_capacity(k);
    let mut sub = vec![0.0; k * k];
    let mut z = vec![0.0; k];
    let threshold = 1e-12 * (1.0 + g.amax());
    for _ in 0..(3 * k + 3) {
        // Gradient of the objective is Nx − g; w = g − Nx is the descent direction. N is
        // symmetric, so row j is column j (contiguous).
        let mut best: Option<(usize, Real)> = None;
        for j in (0..k).filter(|&j| !free[j]) {
            let wj = g[j] - dot(n.column(j).as_slice(), x.as_slice());
            if best.is_none_or(|(_, b)| wj >= b) {
                best = Some((j, wj));
            }
        }
        let Some((j, wj)) = best else { break };
        if wj <= threshold {
            break;
        }
        free[j] = true;
        // Inner loop: solve on the free set, step back to feasibility if needed.
        loop {
            idx.clear();
            idx.extend((0..k).filter(|&j| free[j]));
            let m = idx.len();
            for (a, &ia) in idx.iter().enumerate() {
                for (b, &ib) in idx.iter().enumerate() {
                    sub[a * m + b] = n[(ia, ib)];
                }
                z[a] = g[ia];
            }
            if !cholesky_solve_in_place(&mut sub[..m * m], m, &mut z[..m]) {
                return None;
            }
            let z = &z[..m];
            if z.iter().all(|&v| v > 0.0) {
                for (a, &j) in idx.iter().enumerate() {
                    x[j] = z[a];
                }
                break;
            }
            // Largest step toward z keeping x ≥ 0.
            let mut alpha = 1.0;
            for (a, &j) in idx.iter().enumerate() {
                if z[a] <= 0.0 {
                    let d = x[j] - z[a];
                    if d > 0.0 {
                        alpha = Real::min(alpha, x[j] / d);
                    }
                }
            }
            for (a, &j) in idx.iter().enumerate() {
                x[j] += alpha * (z[a] - x[j]);
                if x[j] <= 1e-14 {
                    x[j] = 0.0;
                    free[j] = false;
                }
            }
            if idx.iter().all(|&j| !free[j]) {
                break;
            }
        }
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn in_place_cholesky_matches_nalgebra() {
        // Sizes below, at and across the panel width, and the fit's identity size.
        for n in [1, 3, 4, 5, 11, 63] {
            let m = DMatrix::from_fn(n, n, |i, j| {
                1.0 / (1.0 + i as Real + j as Real) + if i == j { 2.0 } else { 0.0 }
            });
            let b = DVector::from_fn(n, |i, _| i as Real - 1.5);
            let chol = m.clone().cholesky().unwrap();
            let want = chol.solve(&b);
            let (mut a, mut x) = (m.as_slice().to_vec(), b.as_slice().to_vec());
            assert!(cholesky_solve_in_place(&mut a, n, &mut x), "n = {n}");
            assert!((DVector::from_vec(x) - want).amax() < 1e-12, "n = {n}");
            let l = chol.l();
            // L's column j is the run from a[j·n + j].
            for i in 0..n {
                for j in 0..=i {
                    assert!((a[j * n + i] - l[(i, j)]).abs() < 1e-12, "n = {n}, L[{i}][{j}]");
                }
            }
        }
        let mut singular = vec![1.0, 1.0, 1.0, 1.0];
        assert!(!cholesky_solve_in_place(&mut singular, 2, &mut [1.0, 2.0]));
    }

    #[test]
    fn nnls_matches_unconstrained_when_interior_and_clamps_otherwise() {
        let n = DMatrix::from_row_slice(2, 2, &[2.0, 0.5, 0.5, 1.0]);
        let g = DVector::from_vec(vec![1.0, 1.0]);
        let mut free = [false; 2];
        let x = nonnegative_quadratic(&n, &g, &mut free).unwrap();
        let exact = n.clone().cholesky().unwrap().solve(&g);
        assert!((x - &exact).amax() < 1e-12 && exact.iter().all(|v| *v > 0.0));
        let g = DVector::from_vec(vec![-1.0, 1.0]);
        let x = nonnegative_quadratic(&n, &g, &mut free).unwrap();
        assert_eq!(x[0], 0.0);
        assert!((x[1] - 1.0).abs() < 1e-12 && free == [false, true]);
    }
}
