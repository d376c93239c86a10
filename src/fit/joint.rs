//! The joint solver (`Solver::Joint`, the default): from eos's start, Levenberg–Marquardt
//! steps over every frame's pose and free expressions and the group's shared identity, each
//! followed by an NNLS pass on the expressions (which updates the set clamped at 0); in
//! groups with enough residual degrees of freedom the priors follow the landmark noise
//! estimated from the residuals.
//!
//! Alternating camera and shape fits crawl along the valley where a rotation and an identity
//! change explain the landmarks equally well; one Gauss–Newton step over all unknowns moves
//! along it at once. Unknowns per frame f: `y_f = [δω (so(3), R ← exp(δω)·R), δs, δtx, δty,
//! δβ_free]`; shared: `δα`. The normal equations have the arrow shape
//! `[A_f C_f; C_fᵀ S]`, so each frame's block is eliminated (Schur complement) and only the
//! identity system `(S − Σ C_fᵀA_f⁻¹C_f)·δα = −(g_α − Σ C_fᵀA_f⁻¹b_f)` is solved jointly.
//! Clamped expressions (β = 0, NNLS active set) are held during a step; free ones that a
//! step takes below 0 are clamped, or held at 0 when the clamped step was rejected ([`step`]).
//!
//! Start with [`solve`]; `clip.rs` runs it between eos's start and the final pose step.

use super::camera::{OrthoPose, PoseResidual, PoseSums};
use super::clip::{
    FrameState, Group, ResidualSums, SolverParams, frame_points, identity_normal_matrix_into,
    identity_points, in_parallel, landmark_point, map_frames,
};
use super::shape::{
    FrameObservations, GRAM_PAIRS, GramBlocks, LandmarkBasis, apply_forces, axpy, back_substitute,
    cholesky_in_place, cholesky_solve_in_place, dot, forward_substitute, landmark_forces,
    projector, splat4, vectorised,
};
use crate::math::{DMatrix, DVector, Real, Vector3};
use nalgebra::{DMatrixView, Rotation3};
use rayon::prelude::*;
use std::sync::Arc;

/// Levenberg–Marquardt damping (fraction of the diagonal) at the start, its floor, and how
/// many tries an iteration makes before it gives up.
const INITIAL_DAMPING: Real = 1e-4;
const MIN_DAMPING: Real = 1e-9;
const MAX_DAMPING_TRIES: usize = 8;
/// What a rejected step multiplies the damping by, doubled at each rejection in a row
/// (Nielsen's ν; Madsen, Nielsen & Tingleff 2004, Algorithm 3.16).
const DAMPING_GROWTH: Real = 2.0;

/// The factor an accepted step with gain ratio `rho` (the objective's actual fall over the
/// fall its model predicted) multiplies the damping by: `max(1/3, 1 − (2ρ − 1)³)` (Madsen,
/// Nielsen & Tingleff 2004, eq. 3.16). A step the model predicted well (ρ near 1) lowers the
/// damping by 3, a poor one (ρ near 0) raises it up to 2×. With a fixed ÷10 after every
/// accepted step, the step after the first long, well-predicted one from eos's start was
/// often rejected (`docs/performance.md`).
fn damping_factor(rho: Real) -> Real {
    (1.0 / 3.0 as Real).max(1.0 - (2.0 * rho - 1.0).powi(3))
}

/// Refines the started states' poses on the mean shape, then takes damped joint steps (the
/// identity too when `solve_identity`) until the objective falls by less than the tolerance
/// or the iterations run out; returns the identity, the states and the identity part of the
/// landmark points. With `estimate_noise` the priors follow [`noise_factor`] from the second
/// iteration on.
///
/// The tolerance test is also applied to the Gauss–Newton model's predicted decrease, where
/// the model is at hand, so that an iteration the test would end on is not taken: a step
/// whose predicted decrease (more damping predicts less) is below it ends the solve before
/// its objective is evaluated, and after an iteration the model of the step just factored,
/// evaluated at the new point ([`predicted_decrease`]), ends it before the next
/// linearisation (Madsen, Nielsen & Tingleff, *Methods for Non-Linear Least Squares
/// Problems*, 2004, §3.2, the gain ratio's denominator; `docs/fitting.md`).
pub(crate) fn solve(
    group: &Group<'_>,
    mut states: Vec<FrameState>,
    mut alpha: DVector,
    mut id_pts: Vec<Vector3>,
    solve_identity: bool,
    estimate_noise: bool,
    scratch: &mut Scratch,
) -> (DVector, Vec<FrameState>, Vec<Vector3>) {
    let (basis, observations, image_height) = (group.basis, group.observations, group.image_height);
    group.pose_step(&mut states, &id_pts, true);
    let base = *group.params;
    let mut params = base;
    // The observations' part of the coefficient gradient does not change during the solve.
    let moments = observation_moments(basis, observations, image_height);
    let mut sums = group.residual_sums(&states, &id_pts);
    let mut cost = sums.objective(&alpha, &params);
    let mut mu = INITIAL_DAMPING;
    let mut nu = DAMPING_GROWTH;
    let Scratch { lin, buffers } = scratch;
    let mut candidate = states.clone();
    let mut lambda_moved = false;
    for it in 0..params.iterations {
        lin.update(group, &moments, &states, &alpha, &id_pts, &params);
        let (mut accepted, mut hold) = (false, false);
        for _ in 0..MAX_DAMPING_TRIES {
            copy_states(&mut candidate, &states);
            let how = StepTry { mu, hold };
            let tried = step(lin, &mut candidate, &alpha, how, solve_identity, &params, buffers);
            if let Some((a, predicted)) = tried {
                // The model's decrease bounds what this iteration can pass the test with
                // (more damping predicts less): below the tolerance it is the last one.
                if !lambda_moved && predicted < params.tolerance * cost {
                    break;
                }
                let ids = identity_points(basis, &a);
                let c = group.residual_sums(&candidate, &ids).objective(&a, &params);
                if c < cost {
                    (alpha, id_pts) = (a, ids);
                    std::mem::swap(&mut states, &mut candidate);
                    mu = (mu * damping_factor((cost - c) / predicted)).max(MIN_DAMPING);
                    nu = DAMPING_GROWTH;
                    accepted = true;
                    break;
                }
            }
            // A step that clamped expressions left the path its model described: the same
            // damping, with those expressions held at 0, before more damping.
            if buffers.clamped && !hold {
                hold = true;
                continue;
            }
            mu *= nu;
            nu *= DAMPING_GROWTH;
        }
        if !accepted {
            break;
        }
        // NNLS on β with pose and identity fixed (at the settings' own λ): updates which
        // expressions are clamped.
        group.expression_step(&mut states, &id_pts);
        sums = group.residual_sums(&states, &id_pts);
        let c = sums.objective(&alpha, &params);
        let done = c.is_nan() || (c >= cost * (1.0 - params.tolerance) && !lambda_moved);
        cost = c.min(cost);
        if done || it + 1 == params.iterations {
            break;
        }
        // Empirical Bayes: once the fit has reached the noise floor, the priors' weight
        // follows the landmark noise estimated from the residuals (λ ∝ σ̂²), from the second
        // iteration on.
        lambda_moved = false;
        if estimate_noise && let Some(f) = noise_factor(basis, &sums) {
            let old = params.lambda_identity;
            params.lambda_identity = base.lambda_identity * f;
            params.lambda_expression = base.lambda_expression * f;
            lambda_moved = (params.lambda_identity / old - 1.0).abs() > 0.1;
            cost = sums.objective(&alpha, &params);
        }
        // The next iteration would stop on the tolerance when the model of this one, at the
        // new point, predicts less: skip it when the NNLS pass kept the same unknowns.
        if !lambda_moved
            && lin.holds_structure_of(&states)
            && !buffers.held.contains(&true)
            && predicted_decrease(group, lin, buffers, &states, &alpha, &id_pts, &params)
                < params.tolerance * cost
        {
            break;
        }
    }
    (alpha, states, id_pts)
}

/// `dst` made equal to `src` frame by frame, reusing `dst`'s buffers (a step's candidate
/// states are rewritten for every try).
fn copy_states(dst: &mut [FrameState], src: &[FrameState]) {
    for (d, s) in dst.iter_mut().zip(src) {
        d.pose = s.pose;
        d.beta.copy_from(&s.beta);
        d.free.copy_from_slice(&s.free);
        d.failed.clone_from(&s.failed);
    }
}

/// What [`solve`] keeps from one solve to the next: its linearisation and step buffers,
/// which are sized and overwritten by every solve, so that fitting frame after frame on one
/// thread allocates and zeroes them once.
#[derive(Default)]
pub struct Scratch {
    lin: Linearisation,
    buffers: StepBuffers,
}

/// Per-coordinate landmark error (px) the settings' λ assumes: λ = 3 is the exact MAP weight
/// of a unit-variance prior for this error in eos's σ² = 3 convention (λ = σ²/3).
pub const ASSUMED_NOISE_PX: Real = 3.0;

/// The floor of the estimated per-coordinate noise variance (px²): rounding landmark
/// coordinates to whole pixels alone leaves 1/12 px².
const MIN_NOISE_VARIANCE: Real = 1.0 / 12.0;

/// The factor `σ̂²/σ_a²` by which the noise estimated from the group's residuals differs
/// from the assumed [`ASSUMED_NOISE_PX`]: `σ̂² = SSE/(n − p)` with n the weighted coordinate
/// count and p the unknowns (6 per frame, the free expressions, the identity). None when the
/// residual degrees of freedom are fewer than the unknowns (a single frame: too few to tell
/// noise from shape), so the fixed λ applies.
fn noise_factor(basis: &LandmarkBasis, sums: &ResidualSums) -> Option<Real> {
    let n = sums.coordinates;
    let p = basis.k_id as Real + sums.frame_unknowns;
    if n - p < p {
        return None;
    }
    let variance = (sums.sse / (n - p)).max(MIN_NOISE_VARIANCE);
    Some(variance / (ASSUMED_NOISE_PX * ASSUMED_NOISE_PX))
}

/// Per frame (a column of 6K), `Σᵢ wᵢ·uᵢ·Bᵢ[b,:]` (rows bK..) and `Σᵢ wᵢ·ṽᵢ·Bᵢ[b,:]`
/// (rows (3 + b)K..) over its used landmarks (ṽ = H − v): with them the observations' part
/// of the coefficient gradient is a combination of six rows instead of a sum over the
/// landmarks, in every iteration. Made for all frames at once, one matrix product per row
/// block: `B_bᵀ·[wᵢ·uᵢ,f]`.
fn observation_moments(
    basis: &LandmarkBasis,
    observations: &[FrameObservations],
    image_height: Real,
) -> DMatrix {
    let (k, l, frames) = (basis.num_coefficients(), basis.len(), observations.len());
    let mut m = DMatrix::zeros(6 * k, frames);
    let mut factors = Vec::with_capacity(l);
    for (obs, mut column) in observations.iter().zip(m.column_iter_mut()) {
        factors.clear();
        factors.extend((0..l).map(|i| {
            let (w, p) = (basis.weights[i], &obs.points[i]);
            if obs.active[i] { [w * p.x, w * (image_height - p.y)] } else { [0.0; 2] }
        }));
        observed_moments(basis, &factors, column.as_mut_slice());
    }
    m
}

vectorised! {
    /// [`basis_moments`] for the observations' two factors (u, v).
    fn observed_moments<'a>(basis: &'a LandmarkBasis, factors: &'a [[Real; 2]], out: &'a mut [Real])
        -> () = basis_moments::<2>
}

vectorised! {
    /// `Σᵢ wᵢ·Xᵢ[a]·Bᵢ[b,:]` (row 3a + b) over all landmarks for the points `pts`, written
    /// over `m` (9K): the part of the pose–coefficient coupling that the frames share (their
    /// identity part).
    fn point_moments<'a>(basis: &'a LandmarkBasis, pts: &'a [Vector3], m: &'a mut Vec<Real>)
        -> () = point_moments_kernel
}

/// [`point_moments`]: [`basis_moments`] with the factors `wᵢ·Xᵢ[a]`.
#[inline(always)]
fn point_moments_kernel(basis: &LandmarkBasis, pts: &[Vector3], m: &mut Vec<Real>) {
    m.clear();
    m.resize(9 * basis.num_coefficients(), 0.0);
    let factors: Vec<[Real; 3]> =
        pts.iter().zip(&basis.weights).map(|(p, &w)| [w * p.x, w * p.y, w * p.z]).collect();
    basis_moments(basis, &factors, m);
}

/// `out[(3a + b)·K..][..K] = Σᵢ fᵢ[a]·Bᵢ[b,:]` over the landmarks (a < A, b = x, y, z):
/// four columns at a time ([`LandmarkBasis::column_block`]) with the 3A sums held in
/// registers across the landmarks, so each basis entry is loaded once, not A times, and the
/// sums are not stored and reloaded per landmark. Each entry is the same sum as landmark by
/// landmark `out += fᵢ[a]·Bᵢ[b,:]` (multiply, then add, landmarks in order), the form it
/// replaced, so the moments are the same to the bit.
#[inline(always)]
fn basis_moments<const A: usize>(basis: &LandmarkBasis, factors: &[[Real; A]], out: &mut [Real]) {
    let k = basis.num_coefficients();
    const { assert!(A <= 3) };
    for c in 0..k.div_ceil(4) {
        // One flat array of sums (the first 3A used), each updated with its own row and
        // factor: in this form the sums stay in vector registers (nested arrays and plain
        // indices kept them in memory).
        let mut sums = [[0.0; 4]; 9];
        for (x, f) in basis.column_block(c).chunks_exact(3).zip(factors) {
            for (ab, sum) in sums.iter_mut().take(3 * A).enumerate() {
                let (fa, xb) = (f[ab / 3], &x[ab % 3]);
                for l in 0..4 {
                    sum[l] += fa * xb[l];
                }
            }
        }
        let cols = 4 * c..(4 * c + 4).min(k);
        for (row, sum) in out.chunks_exact_mut(k).zip(&sums[..3 * A]) {
            row[cols.clone()].copy_from_slice(&sum[..cols.len()]);
        }
    }
}

/// `out = c₀·x₀ + c₁·x₁ + c₂·x₂` (rows of equal length).
#[inline(always)]
fn combine3(out: &mut [Real], c: [Real; 3], x: [&[Real]; 3]) {
    for (((o, &a), &b), &d) in out.iter_mut().zip(x[0]).zip(x[1]).zip(x[2]) {
        *o = c[0] * a + c[1] * b + c[2] * d;
    }
}

/// Row `j` (of length k) of `m`.
#[inline(always)]
fn row(m: &[Real], j: usize, k: usize) -> &[Real] {
    &m[j * k..(j + 1) * k]
}

/// The linearised problem at the current state. Frame f's unknowns (6 pose parameters, then
/// its free expressions) are rows `rows[f]..rows[f + 1]` of the stacked `c` and `b`; its
/// block of A is `a[blocks[f]..blocks[f + 1]]` (row-major). Failed frames have no rows.
#[derive(Default)]
pub(crate) struct Linearisation {
    rows: Vec<usize>,
    blocks: Vec<usize>,
    /// `A_f`, undamped.
    a: Vec<Real>,
    /// Coupling with the identity `C_f` (row-major, k_id per row).
    c: Vec<Real>,
    /// Gradient of the frames' unknowns `b_f`.
    b: Vec<Real>,
    /// Identity block `λ_id·I + Σ_f H_αα,f` (undamped).
    s: DMatrix,
    /// Identity gradient `λ_id·α + Σ_f g_α,f`.
    g: DVector,
    /// Each frame's `g_α,f`, summed into `g` in frame order.
    g_frames: Vec<Real>,
    /// Kept from one linearisation to the next: the identity points' moments, the Gram blocks
    /// of each frame's entries, and the rows [`frame_blocks`] works in when frames are
    /// linearised one after the other.
    id_moments: Vec<Real>,
    grams: Vec<Arc<GramBlocks>>,
    scratch: Option<BlockScratch>,
    /// Each frame's free expressions when linearised, k_exp per frame.
    free: Vec<bool>,
}

/// `m` made n×n if it is not (new entries 0); a reused matrix of that size is left as it is
/// (nalgebra's `resize_mut` copies the matrix even when the size does not change).
fn square(m: &mut DMatrix, n: usize) {
    if m.shape() != (n, n) {
        *m = DMatrix::zeros(n, n);
    }
}

/// Frame offsets for unknown counts `n_f`: rows (Σ n) and blocks (Σ n²).
fn offsets(counts: &[usize]) -> (Vec<usize>, Vec<usize>) {
    let mut rows = Vec::with_capacity(counts.len() + 1);
    let mut blocks = Vec::with_capacity(counts.len() + 1);
    let (mut r, mut b) = (0, 0);
    for &n in counts {
        rows.push(r);
        blocks.push(b);
        r += n;
        b += n * n;
    }
    rows.push(r);
    blocks.push(b);
    (rows, blocks)
}

/// `buf` cut into consecutive pieces of `offsets[f + 1] − offsets[f]` values each
/// (`per` values per unit).
fn split_at_offsets<'a>(
    mut buf: &'a mut [Real],
    offsets: &[usize],
    per: usize,
) -> Vec<&'a mut [Real]> {
    offsets
        .windows(2)
        .map(|w| {
            let (head, tail) = std::mem::take(&mut buf).split_at_mut((w[1] - w[0]) * per);
            buf = tail;
            head
        })
        .collect()
}

/// Runs `f` on every frame's item with a scratch buffer, in parallel (one scratch per worker,
/// made by `scratch`) when [`in_parallel`], else in order with `local`, which the caller
/// keeps from one call to the next; results in order.
fn each_frame_with<I, R, S, F>(
    items: Vec<I>,
    local: &mut S,
    scratch: impl Fn() -> S + Sync + Send,
    f: F,
) -> Vec<R>
where
    I: Send,
    R: Send,
    F: Fn(&mut S, I) -> R + Sync + Send,
{
    if in_parallel(items.len()) {
        items.into_par_iter().map_init(scratch, f).collect()
    } else {
        items.into_iter().map(|i| f(local, i)).collect()
    }
}

/// One frame's share of the linearisation, written into its slices of the stacked buffers.
struct FrameOut<'a> {
    a: &'a mut [Real],
    c: &'a mut [Real],
    b: &'a mut [Real],
    g_alpha: &'a mut [Real],
}

/// What [`frame_blocks`] reads besides the frame.
struct Shared<'a> {
    basis: &'a LandmarkBasis,
    id_pts: &'a [Vector3],
    /// [`point_moments`] of `id_pts`.
    id_moments: &'a [Real],
    image_height: Real,
    params: &'a SolverParams,
}

/// Rows of K a worker reuses frame after frame.
struct BlockScratch {
    /// `Σᵢ wᵢ·xᵢ[a]·Bᵢ[b,:]` of the frame's points (9 rows), then rotated on the left (9 rows).
    x: Vec<Real>,
    t: Vec<Real>,
    /// `Σᵢ wᵢ·cᵢ[a]·(R·Bᵢ)[b,:]` for a = x, y, z and b = x, y (row 2a + b).
    cam: Vec<Real>,
    /// `Σᵢ wᵢ·Bᵢ[b,:]` over the frame's used landmarks (3 rows).
    y: Vec<Real>,
    /// Rotated: `(R·Σᵢ wᵢ·Bᵢ)[b,:]` for b = x, y; the observation rows `(R·U)₀`, `(R·V)₁`.
    ry: Vec<Real>,
    obs: Vec<Real>,
    /// `H_pc` (6 rows) and `g_c`.
    hpc: Vec<Real>,
    gc: Vec<Real>,
    /// Rows of the coefficient block for the free expressions.
    hb: Vec<Real>,
    free: Vec<usize>,
}

impl BlockScratch {
    fn new(k: usize, k_exp: usize) -> Self {
        Self {
            x: vec![0.0; 9 * k],
            t: vec![0.0; 9 * k],
            cam: vec![0.0; 6 * k],
            y: vec![0.0; 3 * k],
            ry: vec![0.0; 2 * k],
            obs: vec![0.0; 2 * k],
            hpc: vec![0.0; 6 * k],
            gc: vec![0.0; k],
            hb: vec![0.0; k_exp * k],
            free: Vec::with_capacity(k_exp),
        }
    }
}

vectorised! {
    /// Builds frame f's blocks. The pose block is summed landmark by landmark; the
    /// pose–coefficient coupling and the coefficient gradient come from moments: with camera
    /// points `cᵢ = R·xᵢ` and rotated rows `Pᵢ = R·Bᵢ`, every row of `H_pc` is a combination
    /// of `Σᵢ wᵢ·cᵢ[a]·Pᵢ[b,:] = R·(Σᵢ wᵢ·xᵢ[a]·Bᵢ[b,:])·Rᵀ` and `R·Σᵢ wᵢ·Bᵢ`, and
    /// `Σᵢ wᵢ·xᵢ[a]·Bᵢ[b,:]` is the identity part (shared by the frames) plus `Σ_e β_e` times
    /// the precomputed expression moments, minus the landmarks the frame does not use; the
    /// coefficient blocks come from the Gram blocks of the entries it uses (`grams`).
    fn frame_blocks<'a>(
        sh: &'a Shared<'a>,
        obs: &'a FrameObservations,
        st: &'a FrameState,
        grams: &'a GramBlocks,
        moments: &'a [Real],
        scr: &'a mut BlockScratch,
        out: FrameOut<'a>,
    ) -> () = frame_blocks_kernel
}

#[inline(always)]
fn frame_blocks_kernel(
    sh: &Shared<'_>,
    obs: &FrameObservations,
    st: &FrameState,
    grams: &GramBlocks,
    moments: &[Real],
    scr: &mut BlockScratch,
    out: FrameOut<'_>,
) {
    let (basis, params) = (sh.basis, sh.params);
    let (kid, k) = (basis.k_id, basis.num_coefficients());
    let pose = &st.pose;
    let (s, r) = (pose.s, &pose.r);
    let beta = st.beta.as_slice();
    let inv = 1.0 / params.sigma2;
    // Pose block and gradient.
    let mut sums = PoseSums::default();
    for i in (0..basis.len()).filter(|&i| obs.active[i]) {
        let x = landmark_point(basis, sh.id_pts, beta, i);
        let res = PoseResidual::new(pose, &x, &obs.points[i], sh.image_height);
        sums.add(&res, basis.weights[i] * inv);
    }
    let (hpp, gp) = sums.normal_equations(pose);
    // Moments of this frame's points: the shared identity part, plus the expressions, minus
    // the landmarks it does not use.
    let x = &mut scr.x;
    x.copy_from_slice(sh.id_moments);
    for (e, &b) in beta.iter().enumerate() {
        if b != 0.0 {
            axpy(b, basis.expression_moments(e), x);
        }
    }
    scr.y.copy_from_slice(basis.row_sums());
    for i in (0..basis.len()).filter(|&i| !obs.active[i]) {
        let p = landmark_point(basis, sh.id_pts, beta, i);
        let w = basis.weights[i];
        for (ab, row) in x.chunks_exact_mut(k.max(1)).enumerate() {
            axpy(-w * p[ab / 3], basis.row(i, ab % 3), row);
        }
        for (b, row) in scr.y.chunks_exact_mut(k.max(1)).enumerate() {
            axpy(-w, basis.row(i, b), row);
        }
    }
    // t = R·X over the first index, cam = t·Rᵀ over the second (b = x, y only). The row
    // triples are written out, not made with `array::map`, for the reason `splat4` gives.
    let rr = |a: usize| [r[(a, 0)], r[(a, 1)], r[(a, 2)]];
    for a in 0..3 {
        for (b, t) in scr.t[3 * a * k..3 * (a + 1) * k].chunks_exact_mut(k.max(1)).enumerate() {
            combine3(t, rr(a), [row(x, b, k), row(x, 3 + b, k), row(x, 6 + b, k)]);
        }
        for (b, cam) in scr.cam[2 * a * k..2 * (a + 1) * k].chunks_exact_mut(k.max(1)).enumerate() {
            let t = &scr.t;
            combine3(cam, rr(b), [row(t, 3 * a, k), row(t, 3 * a + 1, k), row(t, 3 * a + 2, k)]);
        }
    }
    let ys = [row(&scr.y, 0, k), row(&scr.y, 1, k), row(&scr.y, 2, k)];
    let (ry0, ry1) = scr.ry.split_at_mut(k);
    combine3(ry0, rr(0), ys);
    combine3(ry1, rr(1), ys);
    // (R·U)₀ + (R·V)₁: the observations' part of the gradient.
    let (obs_u, obs_v) = scr.obs.split_at_mut(k);
    let m = |b: usize| row(moments, b, k);
    combine3(obs_u, rr(0), [m(0), m(1), m(2)]);
    combine3(obs_v, rr(1), [m(3), m(4), m(5)]);
    // H_pc rows from the Jacobian's entries (see `PoseResidual::jacobian`):
    // ∂ω: (0, s·c_z, −s·c_y | −s·c_z, 0, s·c_x), ∂s: (c_x + t_x | c_y + t_y), ∂t: s.
    let cam = |a: usize, b: usize| row(&scr.cam, 2 * a + b, k);
    let (c00, c01, c10, c11, c20, c21) =
        (cam(0, 0), cam(0, 1), cam(1, 0), cam(1, 1), cam(2, 0), cam(2, 1));
    let (y0, y1) = scr.ry.split_at(k);
    let (u, v) = scr.obs.split_at(k);
    let (s2, s1) = (s * s * inv, s * inv);
    let (tx, ty) = (pose.tx, pose.ty);
    let [h0, h1, h2, h3, h4, h5]: [&mut [Real]; 6] = {
        let mut it = scr.hpc.chunks_exact_mut(k.max(1));
        std::array::from_fn(|_| it.next().unwrap_or_default())
    };
    let gc = &mut scr.gc[..k];
    for j in 0..k {
        let d = s1 * (c00[j] + c11[j] + tx * y0[j] + ty * y1[j]);
        h0[j] = -s2 * c21[j];
        h1[j] = s2 * c20[j];
        h2[j] = s2 * (c01[j] - c10[j]);
        h3[j] = d;
        h4[j] = s2 * y0[j];
        h5[j] = s2 * y1[j];
        gc[j] = s * d - s1 * (u[j] + v[j]);
    }
    let hpc = &scr.hpc;
    let gc = &scr.gc;
    // Coefficient rows of the free expressions, from the Gram blocks.
    scr.free.clear();
    scr.free.extend((0..basis.k_exp).filter(|&e| st.free[e]));
    let q = projector(pose);
    for (e, &fe) in scr.free.iter().enumerate() {
        let hb = &mut scr.hb[e * k..(e + 1) * k];
        hb.fill(0.0);
        for (g, &(a, b)) in GRAM_PAIRS.iter().enumerate() {
            axpy(s2 * q[(a, b)], grams.column(g, kid + fe), hb);
        }
    }
    // Assemble A (row-major, n = 6 + free), C and b.
    let n = 6 + scr.free.len();
    let (a, c, b) = (out.a, out.c, out.b);
    for p in 0..6 {
        for q in 0..6 {
            a[p * n + q] = hpp[(p, q)];
        }
        b[p] = gp[p];
        c[p * kid..(p + 1) * kid].copy_from_slice(&hpc[p * k..p * k + kid]);
    }
    for (e, &fe) in scr.free.iter().enumerate() {
        let row = 6 + e;
        for p in 0..6 {
            let v = hpc[p * k + kid + fe];
            a[p * n + row] = v;
            a[row * n + p] = v;
        }
        let hb = &scr.hb[e * k..(e + 1) * k];
        for (e2, &fe2) in scr.free.iter().enumerate() {
            a[row * n + 6 + e2] = hb[kid + fe2];
        }
        a[row * n + row] += params.lambda_expression;
        b[row] = gc[kid + fe] + params.lambda_expression * beta[fe];
        c[row * kid..(row + 1) * kid].copy_from_slice(&hb[..kid]);
    }
    out.g_alpha.copy_from_slice(&gc[..kid]);
}

impl Linearisation {
    /// Linearises the objective at the current state (failed frames are left out) into this
    /// linearisation's buffers, which are reused from one iteration to the next.
    fn update(
        &mut self,
        group: &Group<'_>,
        moments: &DMatrix,
        states: &[FrameState],
        alpha: &DVector,
        id_pts: &[Vector3],
        params: &SolverParams,
    ) {
        let basis = group.basis;
        let (kid, k, k_exp) = (basis.k_id, basis.num_coefficients(), basis.k_exp);
        let counts: Vec<usize> =
            states
                .iter()
                .map(|st| {
                    if st.failed.is_some() { 0 } else { 6 + st.free.iter().filter(|f| **f).count() }
                })
                .collect();
        (self.rows, self.blocks) = offsets(&counts);
        self.free.clear();
        states.iter().for_each(|st| self.free.extend_from_slice(&st.free));
        let total_rows = self.rows[counts.len()];
        self.a.resize(self.blocks[counts.len()], 0.0);
        self.c.resize(total_rows * kid, 0.0);
        self.b.resize(total_rows, 0.0);
        let g_frames = &mut self.g_frames;
        g_frames.resize(states.len() * kid, 0.0);
        point_moments(basis, id_pts, &mut self.id_moments);
        let sh = Shared {
            basis,
            id_pts,
            id_moments: &self.id_moments,
            image_height: group.image_height,
            params,
        };
        let items: Vec<(usize, FrameOut<'_>)> = split_at_offsets(&mut self.a, &self.blocks, 1)
            .into_iter()
            .zip(split_at_offsets(&mut self.c, &self.rows, kid))
            .zip(split_at_offsets(&mut self.b, &self.rows, 1))
            .zip(g_frames.chunks_mut(kid.max(1)))
            .map(|(((a, c), b), g_alpha)| FrameOut { a, c, b, g_alpha })
            .enumerate()
            .filter(|(f, _)| states[*f].failed.is_none())
            .collect();
        let grams = &mut self.grams;
        grams.clear();
        grams.extend(group.observations.iter().map(|o| basis.used_grams(&o.active)));
        let local = self.scratch.get_or_insert_with(|| BlockScratch::new(k, k_exp));
        each_frame_with(
            items,
            local,
            || BlockScratch::new(k, k_exp),
            |scr, (f, out)| {
                let m = moments.column(f);
                let obs = &group.observations[f];
                frame_blocks(&sh, obs, &states[f], &grams[f], m.as_slice(), scr, out)
            },
        );
        square(&mut self.s, kid);
        identity_normal_matrix_into(&mut self.s, grams, states, params);
        self.g = alpha * params.lambda_identity;
        for g_alpha in g_frames.chunks(kid.max(1)) {
            axpy(1.0, g_alpha, self.g.as_mut_slice());
        }
    }

    /// Whether `states` have the unknowns this linearisation was made for: the same frames
    /// failed and the same expressions free.
    fn holds_structure_of(&self, states: &[FrameState]) -> bool {
        let k_exp = states.first().map_or(0, |st| st.free.len());
        states.len() + 1 == self.rows.len()
            && states.iter().enumerate().all(|(f, st)| {
                let fitted = self.rows[f + 1] > self.rows[f];
                fitted == st.failed.is_none()
                    && (!fitted || self.free[f * k_exp..(f + 1) * k_exp] == st.free[..])
            })
    }
}

/// The buffers of a step's elimination, reused by every try: per frame the Cholesky factor
/// L of the damped `A_f` and `z_f = L⁻¹b_f`, stacked as in [`Linearisation`], and the
/// back-substitution's `−δy`; each chunk's Schur terms and the stacked `W` of a chunk when
/// chunks run one after the other; the damped identity system and its right-hand side.
#[derive(Default)]
pub(crate) struct StepBuffers {
    l: Vec<Real>,
    z: Vec<Real>,
    v: Vec<Real>,
    parts: Vec<(DMatrix, DVector)>,
    w: Vec<Real>,
    s: DMatrix,
    r: DVector,
    /// The identity's gradient less the held rows' coupling (`g − Σ C_pᵀ·v_p`).
    g: DVector,
    /// The rows (stacked as `v`) held at their bound in the last solve ([`step`]).
    held: Vec<bool>,
    /// Whether the last step clamped expressions that crossed 0 (it held none of them).
    clamped: bool,
    /// Whether the last step solved the identity (`s` holds its system's factor).
    identity: bool,
}

/// Frames whose Schur terms are made in one product: their `W` (6 + free rows of k_id per
/// frame, ~190 KB for 32 SFM frames) stays in cache, and the chunks' partial sums, added in
/// chunk order, give the same total whatever the number of threads.
const SCHUR_CHUNK: usize = 32;

vectorised! {
    /// Frame f's elimination: `l = chol(A·(1 + μ on the diagonal))` (as [`cholesky_in_place`]
    /// stores it), `w = L⁻¹C`, `z = L⁻¹b` (row-major, n rows). False when the damped block is
    /// not positive definite.
    fn eliminate<'a>(
        a: &'a [Real],
        c: &'a [Real],
        b: &'a [Real],
        mu: Real,
        l: &'a mut [Real],
        w: &'a mut [Real],
        z: &'a mut [Real],
    ) -> bool = eliminate_kernel
}

#[inline(always)]
fn eliminate_kernel(
    a: &[Real],
    c: &[Real],
    b: &[Real],
    mu: Real,
    l: &mut [Real],
    w: &mut [Real],
    z: &mut [Real],
) -> bool {
    let n = b.len();
    if n == 0 {
        return true;
    }
    let kid = c.len() / n;
    l.copy_from_slice(a);
    for d in 0..n {
        l[d * n + d] *= 1.0 + mu;
    }
    if !cholesky_in_place(l, n) {
        return false;
    }
    // Row p of W: (C[p] − Σ_{q<p} L[p][q]·W[q]) / L[p][p], L[p][q] read from column q.
    for p in 0..n {
        let (done, rest) = w.split_at_mut(p * kid);
        let wp = &mut rest[..kid];
        wp.copy_from_slice(&c[p * kid..(p + 1) * kid]);
        for q in 0..p {
            axpy(-l[q * n + p], &done[q * kid..(q + 1) * kid], wp);
        }
        let inv = 1.0 / l[p * n + p];
        wp.iter_mut().for_each(|v| *v *= inv);
    }
    z.copy_from_slice(b);
    forward_substitute(l, n, z);
    z.iter().all(|v| v.is_finite())
}

/// Rows of a chunk's stacked W up to which its Schur terms are summed row by row
/// ([`gram_lower`]) rather than by the matrix-multiply kernel: the kernel copies ("packs") its
/// operands first, which for one frame's dozen rows costs more than the product.
const SMALL_SCHUR_ROWS: usize = 32;

/// A chunk's Schur terms `(WᵀW, Wᵀz)` for its stacked row-major W (k_id per row), written
/// over `(s, r)` (resized to k_id). The identity solve reads one triangle of S (the lower
/// one, S being column-major), so only that triangle is made: row by row for a few rows, else
/// as the blocks on and below the diagonal of a 2×2 split, ¾ of the product; the rest is
/// left as it was.
fn schur_terms(w: &[Real], z: &[Real], kid: usize, (s, r): &mut (DMatrix, DVector)) {
    let nrows = z.len();
    square(s, kid);
    if r.len() != kid {
        *r = DVector::zeros(kid);
    }
    r.fill(0.0);
    if nrows == 0 {
        s.fill(0.0);
        return;
    }
    if nrows <= SMALL_SCHUR_ROWS {
        let sv = s.as_mut_slice();
        for c in 0..kid {
            sv[c * kid + c..(c + 1) * kid].fill(0.0);
        }
        gram_lower(w, kid, sv);
    } else {
        // Wᵀ is W read column-major; W itself has row stride k_id.
        let wt = DMatrixView::from_slice(w, kid, nrows);
        let wv = DMatrixView::from_slice_with_strides(w, nrows, kid, kid, 1);
        let h = kid / 2;
        for (r0, c0, nr, nc) in [(0, 0, h, h), (h, 0, kid - h, h), (h, h, kid - h, kid - h)] {
            s.view_mut((r0, c0), (nr, nc)).gemm(1.0, &wt.rows(r0, nr), &wv.columns(c0, nc), 0.0);
        }
    }
    for (wr, &zr) in w.chunks_exact(kid).zip(z) {
        axpy(zr, wr, r.as_mut_slice());
    }
}

vectorised! {
    /// Adds `WᵀW` to the lower triangle of the k×k column-major `out` (column c's part is the
    /// run from `out[c·k + c]`) for the row-major W (`w`, k per row).
    fn gram_lower<'a>(w: &'a [Real], k: usize, out: &'a mut [Real]) -> () = simd gram_lower_kernel
}

/// [`gram_lower`]: four rows of W per pass over the triangle, so that each column's entries
/// are loaded and stored once for four rank-1 terms, each a fused multiply-add, in pulp's
/// vector types (four entries a vector, the last few scalar, the same operations in the
/// same order either way).
#[inline(always)]
fn gram_lower_kernel<S: pulp::Simd>(simd: S, w: &[Real], k: usize, out: &mut [Real]) {
    if k == 0 {
        return;
    }
    let plus_terms = |x: Real, a: [Real; 4], f: [Real; 4]| {
        a[3].mul_add(f[3], a[2].mul_add(f[2], a[1].mul_add(f[1], a[0].mul_add(f[0], x))))
    };
    let mut quads = w.chunks_exact(4 * k);
    for quad in quads.by_ref() {
        let (p0, rest) = quad.split_at(k);
        let (p1, rest) = rest.split_at(k);
        let (p2, p3) = rest.split_at(k);
        for c in 0..k {
            let f = [p0[c], p1[c], p2[c], p3[c]];
            let fv = splat4(simd, f);
            let (col, col_tail) = S::as_mut_simd_f64s(&mut out[c * k + c..(c + 1) * k]);
            let (x0, x1) = (S::as_simd_f64s(&p0[c..]), S::as_simd_f64s(&p1[c..]));
            let (x2, x3) = (S::as_simd_f64s(&p2[c..]), S::as_simd_f64s(&p3[c..]));
            let rows = col.iter_mut().zip(x0.0.iter().zip(x1.0)).zip(x2.0.iter().zip(x3.0));
            for ((o, (&a0, &a1)), (&a2, &a3)) in rows {
                let mut v = *o;
                for (a, f) in [a0, a1, a2, a3].into_iter().zip(fv) {
                    v = simd.mul_add_f64s(a, f, v);
                }
                *o = v;
            }
            let tails = [x0.1, x1.1, x2.1, x3.1];
            for (i, o) in col_tail.iter_mut().enumerate() {
                *o = plus_terms(*o, [tails[0][i], tails[1][i], tails[2][i], tails[3][i]], f);
            }
        }
    }
    for p in quads.remainder().chunks_exact(k) {
        for c in 0..k {
            axpy(p[c], &p[c..], &mut out[c * k + c..(c + 1) * k]);
        }
    }
}

/// How [`step`] tries a step: its damping μ (a fraction of the diagonal), and whether
/// expressions that cross 0 are held there.
#[derive(Clone, Copy, Debug)]
pub(crate) struct StepTry {
    pub mu: Real,
    pub hold: bool,
}

/// Solves the damped system and applies the step to `out` (the current states on entry):
/// returns the new identity and the decrease the step's model predicts, or None when a
/// block is not positive definite. With `solve_identity` false the identity stays (δα = 0).
///
/// With β ≥ 0 (the settings' `nonnegative_expressions`), free expressions the step would
/// take below 0 are clamped at 0 and `buf.clamped` says so. Clamping moves the point off the
/// step the model describes, and the objective then often rises where the model promised a
/// fall. With `hold` the step is an active-set step instead: a crossing expression is held
/// at 0 (its δβ fixed to −β) and the rest of the system solved again, until none crosses;
/// its predicted decrease is then that of the step taken. Holding costs a solve per round,
/// so [`solve`] holds only after a clamped step was rejected (`docs/fitting.md`).
pub(crate) fn step(
    lin: &Linearisation,
    out: &mut [FrameState],
    alpha: &DVector,
    StepTry { mu, hold }: StepTry,
    solve_identity: bool,
    params: &SolverParams,
    buf: &mut StepBuffers,
) -> Option<(DVector, Real)> {
    let (kid, rows) = (alpha.len(), &lin.rows);
    buf.held.clear();
    buf.held.resize(*rows.last().unwrap_or(&0), false);
    let dalpha = loop {
        let dalpha = solve_damped(lin, out, mu, solve_identity, buf)?;
        let crossing =
            if params.nonnegative_expressions { crossing_rows(lin, out, buf) } else { Vec::new() };
        buf.clamped = !crossing.is_empty();
        if crossing.is_empty() || !hold {
            break dalpha;
        }
        crossing.into_iter().for_each(|p| buf.held[p] = true);
    };
    let (v, held) = (&buf.v, &buf.held);
    // Each frame's part of the model's decrease, and the step applied.
    let apply = |(f, st): (usize, &mut FrameState)| -> Option<Real> {
        let (r0, r1) = (rows[f], rows[f + 1]);
        if r1 == r0 {
            return Some(0.0);
        }
        let (v, held) = (&v[r0..r1], &held[r0..r1]);
        let (a, b) = (&lin.a[lin.blocks[f]..lin.blocks[f + 1]], &lin.b[r0..r1]);
        let decrease = frame_model_decrease(a, b, held, v, mu);
        let rot = Rotation3::new(-Vector3::new(v[0], v[1], v[2]));
        let pose = OrthoPose {
            r: rot.into_inner() * st.pose.r,
            s: st.pose.s - v[3],
            tx: st.pose.tx - v[4],
            ty: st.pose.ty - v[5],
        };
        if !pose.is_valid() {
            return None;
        }
        st.pose = pose;
        let free = (0..st.free.len()).filter(|&e| st.free[e]);
        for ((e, dv), &h) in free.zip(&v[6..]).zip(&held[6..]) {
            // A held expression lands on 0 exactly, not on a rounding of it.
            let b = if h { 0.0 } else { st.beta[e] - dv };
            st.beta[e] = if params.nonnegative_expressions { b.max(0.0) } else { b };
        }
        Some(decrease)
    };
    let frames: Option<Vec<Real>> = if in_parallel(out.len()) {
        out.par_iter_mut().enumerate().map(apply).collect()
    } else {
        out.iter_mut().enumerate().map(apply).collect()
    };
    // The identity's part, with the gradient the held rows leave it ([`solve_damped`]).
    let s = lin.s.as_slice();
    let identity = -dot(buf.g.as_slice(), dalpha.as_slice())
        + mu * dalpha.iter().enumerate().map(|(c, d)| s[c * kid + c] * d * d).sum::<Real>();
    let decrease = frames?.iter().sum::<Real>() + identity;
    let new_alpha = alpha + dalpha;
    new_alpha.iter().all(|v| v.is_finite()).then_some((new_alpha, decrease))
}

/// The damped system solved with the rows in `buf.held` fixed: their `−δy` is the frame's β
/// (the expression lands on 0). Leaves every frame's `−δy` in `buf.v` and returns δα (0
/// without `solve_identity`), or None when a block is not positive definite or the solution
/// is not finite. A held row is taken out of its frame's block, its coupling moved to the
/// right-hand sides (`b_q − A_qp·v_p`, and `g − C_pᵀ·v_p` for the identity), and the row
/// left as `A_pp·(1 + μ)·v_p = b'_p`, so the blocks keep their sizes.
fn solve_damped(
    lin: &Linearisation,
    states: &[FrameState],
    mu: Real,
    solve_identity: bool,
    buf: &mut StepBuffers,
) -> Option<DVector> {
    let kid = lin.g.len();
    let frames = lin.rows.len().saturating_sub(1);
    let nrows = *lin.rows.last().unwrap_or(&0);
    buf.l.resize(lin.a.len(), 0.0);
    buf.z.resize(nrows, 0.0);
    let (blocks, rows, held) = (&lin.blocks, &lin.rows, &buf.held);
    let need_identity = solve_identity && kid > 0;
    buf.identity = need_identity;
    // The value each row is held at (its −δy), read from the frame's β.
    let held_value = |f: usize, p: usize| -> Real {
        let st = &states[f];
        let e = (0..st.free.len()).filter(|&e| st.free[e]).nth(p - 6);
        e.map_or(0.0, |e| st.beta[e])
    };
    // The identity's gradient with the held rows' part moved over: `g − Σ C_pᵀ·v_p`.
    buf.g.clone_from(&lin.g);
    for f in 0..frames {
        for p in (rows[f]..rows[f + 1]).filter(|&p| held[p]) {
            let v = held_value(f, p - rows[f]);
            axpy(-v, &lin.c[p * kid..(p + 1) * kid], buf.g.as_mut_slice());
        }
    }
    // Per frame, with A = LLᵀ (damped): W = L⁻¹C and z = L⁻¹b, so that the Schur terms are
    // CᵀA⁻¹C = WᵀW and CᵀA⁻¹b = Wᵀz, summed a chunk of frames at a time as products of
    // their stacked W.
    let bounds: Vec<usize> = (0..frames).step_by(SCHUR_CHUNK).chain([frames]).collect();
    let at = |offsets: &[usize]| bounds.iter().map(|&f| offsets[f]).collect::<Vec<_>>();
    let n_chunks = bounds.len() - 1;
    if buf.parts.len() < n_chunks {
        buf.parts.resize_with(n_chunks, || (DMatrix::zeros(0, 0), DVector::zeros(0)));
    }
    let chunks: Vec<_> = split_at_offsets(&mut buf.l, &at(blocks), 1)
        .into_iter()
        .zip(split_at_offsets(&mut buf.z, &at(rows), 1))
        .zip(bounds.windows(2).map(|w| (w[0], w[1])))
        .zip(buf.parts.iter_mut())
        .collect();
    let fine = each_frame_with(
        chunks,
        &mut buf.w,
        Vec::new,
        |w: &mut Vec<Real>, (((l, z), (f0, f1)), part)| {
            let (b0, r0) = (blocks[f0], rows[f0]);
            w.resize((rows[f1] - r0) * kid, 0.0);
            for f in f0..f1 {
                let (a, b) = (&lin.a[blocks[f]..blocks[f + 1]], &lin.b[rows[f]..rows[f + 1]]);
                let c = &lin.c[rows[f] * kid..rows[f + 1] * kid];
                let wf = &mut w[(rows[f] - r0) * kid..(rows[f + 1] - r0) * kid];
                let lf = &mut l[blocks[f] - b0..blocks[f + 1] - b0];
                let zf = &mut z[rows[f] - r0..rows[f + 1] - r0];
                let hf = &held[rows[f]..rows[f + 1]];
                let ok = if hf.iter().any(|&h| h) {
                    let values: Vec<Real> =
                        (0..hf.len()).map(|p| if hf[p] { held_value(f, p) } else { 0.0 }).collect();
                    let (a, c, b) = held_blocks(a, c, b, hf, &values, mu);
                    eliminate(&a, &c, &b, mu, lf, wf, zf)
                } else {
                    eliminate(a, c, b, mu, lf, wf, zf)
                };
                if !ok {
                    return false;
                }
            }
            if need_identity {
                schur_terms(w, z, kid, part);
            }
            true
        },
    );
    if !fine.iter().all(|&ok| ok) {
        return None;
    }
    let mut dalpha = DVector::zeros(kid);
    if need_identity {
        // The lower triangle of S·(1 + μ on the diagonal) − Σ WᵀW (the part the Cholesky
        // factorisation reads), the chunks subtracted in chunk order.
        let (s, r) = (&mut buf.s, &mut buf.r);
        square(s, kid);
        let (sv, lv) = (s.as_mut_slice(), lin.s.as_slice());
        for c in 0..kid {
            let col = c * kid + c..(c + 1) * kid;
            sv[col.clone()].copy_from_slice(&lv[col]);
            sv[c * kid + c] *= 1.0 + mu;
        }
        r.clone_from(&buf.g);
        for (ps, pr) in &buf.parts[..n_chunks] {
            let pv = ps.as_slice();
            for c in 0..kid {
                let col = c * kid + c..(c + 1) * kid;
                for (o, &v) in sv[col.clone()].iter_mut().zip(&pv[col]) {
                    *o -= v;
                }
            }
            *r -= pr;
        }
        if !cholesky_solve_in_place(s.as_mut_slice(), kid, r.as_mut_slice()) {
            return None;
        }
        dalpha.copy_from(r);
        dalpha.neg_mut();
    }
    let (l, z) = (&buf.l, &buf.z);
    buf.v.resize(nrows, 0.0);
    // δy = −A⁻¹(b + C·δα) = −L⁻ᵀ(z + L⁻¹·C·δα); v holds −δy (a held row's C is 0).
    let back = |(f, v): (usize, &mut [Real])| -> bool {
        let n = v.len();
        let (r0, lf) = (rows[f], &l[blocks[f]..blocks[f + 1]]);
        for (p, vp) in v.iter_mut().enumerate() {
            *vp = if held[r0 + p] {
                0.0
            } else {
                dot(&lin.c[(r0 + p) * kid..(r0 + p + 1) * kid], dalpha.as_slice())
            };
        }
        forward_substitute(lf, n, v);
        for (vp, &zp) in v.iter_mut().zip(&z[r0..r0 + n]) {
            *vp += zp;
        }
        back_substitute(lf, n, v);
        for p in (0..n).filter(|&p| held[r0 + p]) {
            v[p] = held_value(f, p);
        }
        v.iter().all(|x| x.is_finite())
    };
    let vs = split_at_offsets(&mut buf.v, rows, 1);
    let fine = if in_parallel(frames) {
        vs.into_par_iter().enumerate().all(back)
    } else {
        vs.into_iter().enumerate().all(back)
    };
    fine.then_some(dalpha)
}

/// The rows of the free expressions, not yet held, that the step in `buf.v` takes below 0.
fn crossing_rows(lin: &Linearisation, states: &[FrameState], buf: &StepBuffers) -> Vec<usize> {
    let mut rows = Vec::new();
    for (f, st) in states.iter().enumerate() {
        let r0 = lin.rows[f];
        if lin.rows[f + 1] == r0 {
            continue;
        }
        let free = (0..st.free.len()).filter(|&e| st.free[e]);
        for (p, e) in (r0 + 6..).zip(free) {
            if !buf.held[p] && st.beta[e] - buf.v[p] < 0.0 {
                rows.push(p);
            }
        }
    }
    rows
}

/// Frame f's blocks with the `held` rows taken out (see [`solve_damped`]): `values` holds
/// those rows' −δy.
fn held_blocks(
    a: &[Real],
    c: &[Real],
    b: &[Real],
    held: &[bool],
    values: &[Real],
    mu: Real,
) -> (Vec<Real>, Vec<Real>, Vec<Real>) {
    let n = b.len();
    let kid = c.len() / n.max(1);
    let (mut a2, mut c2, mut b2) = (a.to_vec(), c.to_vec(), b.to_vec());
    for p in (0..n).filter(|&p| held[p]) {
        for q in (0..n).filter(|&q| q != p) {
            if !held[q] {
                b2[q] -= a[q * n + p] * values[p];
            }
            a2[q * n + p] = 0.0;
            a2[p * n + q] = 0.0;
        }
        b2[p] = a[p * n + p] * (1.0 + mu) * values[p];
        c2[p * kid..(p + 1) * kid].fill(0.0);
    }
    (a2, c2, b2)
}

/// One frame's part of the decrease the damped step's model predicts (twice the fall of the
/// Gauss–Newton model, the objective's scale), for `v` = −δy. For the rows the step solved
/// it is `b'·v + μ·Σ A_pp·v_p²` with b' the right-hand side [`held_blocks`] leaves them
/// (Madsen, Nielsen & Tingleff 2004, eq. 3.14, on the system without the held rows); the
/// held rows add their own fall, `2·b_F·v_F − v_Fᵀ·A_FF·v_F`.
fn frame_model_decrease(a: &[Real], b: &[Real], held: &[bool], v: &[Real], mu: Real) -> Real {
    let n = b.len();
    let damping = |p: usize| a[p * n + p] * v[p] * v[p];
    if !held.iter().any(|&h| h) {
        return dot(b, v) + mu * (0..n).map(damping).sum::<Real>();
    }
    let (solved, fixed): (Vec<usize>, Vec<usize>) = (0..n).partition(|&p| !held[p]);
    let coupling = |q: usize| fixed.iter().map(|&p| a[q * n + p] * v[p]).sum::<Real>();
    let free_part: Real =
        solved.iter().map(|&q| (b[q] - coupling(q)) * v[q] + mu * damping(q)).sum();
    let held_part: Real = fixed.iter().map(|&p| 2.0 * b[p] * v[p] - v[p] * coupling(p)).sum();
    free_part + held_part
}

/// The decrease the Gauss–Newton model of the last accepted step predicts for one more step
/// from `states` (which hold that step's unknowns, [`Linearisation::holds_structure_of`]):
/// `gᵀH⁻¹g`, with g the gradient at `states` and H the damped normal matrix that step
/// factored (`buf`). In the arrow's block factorisation that is, per frame, `|L_f⁻¹b_f|²`,
/// plus for the identity `|L_S⁻¹r|²` with `r = g_α − Σ C_fᵀA_f⁻¹b_f` the Schur system's
/// right-hand side. The gradient costs one pass over the landmarks; no new linearisation.
fn predicted_decrease(
    group: &Group<'_>,
    lin: &Linearisation,
    buf: &StepBuffers,
    states: &[FrameState],
    alpha: &DVector,
    id_pts: &[Vector3],
    params: &SolverParams,
) -> Real {
    let basis = group.basis;
    let (kid, k) = (basis.k_id, basis.num_coefficients());
    let need_identity = buf.identity;
    let inv = 1.0 / params.sigma2;
    let per_frame = map_frames(states.len(), |f| {
        let (r0, n) = (lin.rows[f], lin.rows[f + 1] - lin.rows[f]);
        if n == 0 {
            return (0.0, Vec::new());
        }
        let (st, obs) = (&states[f], &group.observations[f]);
        let pts = frame_points(basis, id_pts, &st.beta);
        let mut sums = PoseSums::default();
        for i in (0..basis.len()).filter(|&i| obs.active[i]) {
            let res = PoseResidual::new(&st.pose, &pts[i], &obs.points[i], group.image_height);
            sums.add(&res, basis.weights[i] * inv);
        }
        let (_, gp) = sums.normal_equations(&st.pose);
        // −(the coefficients' gradient of the data term).
        let forces = landmark_forces(basis, obs, &st.pose, group.image_height, params.sigma2, &pts);
        let minus_gc = apply_forces(basis, &forces, 0..k);
        let mut b: Vec<Real> = gp.iter().copied().collect();
        let free = (0..basis.k_exp).filter(|&e| st.free[e]);
        b.extend(free.map(|e| params.lambda_expression * st.beta[e] - minus_gc[kid + e]));
        let lf = &buf.l[lin.blocks[f]..lin.blocks[f + 1]];
        forward_substitute(lf, n, &mut b);
        let part = dot(&b, &b);
        let mut g_alpha: Vec<Real> = minus_gc.as_slice()[..kid].iter().map(|v| -v).collect();
        if need_identity {
            back_substitute(lf, n, &mut b);
            for (p, &y) in b.iter().enumerate() {
                axpy(-y, &lin.c[(r0 + p) * kid..(r0 + p + 1) * kid], &mut g_alpha);
            }
        }
        (part, g_alpha)
    });
    let mut total = 0.0;
    let mut r = alpha * params.lambda_identity;
    for (part, g_alpha) in &per_frame {
        total += part;
        if need_identity && !g_alpha.is_empty() {
            axpy(1.0, g_alpha, r.as_mut_slice());
        }
    }
    if need_identity {
        forward_substitute(buf.s.as_slice(), kid, r.as_mut_slice());
        total += r.norm_squared();
    }
    total
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::camera::rotation_from_yaw_pitch_roll_deg;
    use crate::fit::result::Solver;
    use crate::landmarks::{FrameLandmarks, LandmarkPoint, LandmarkSet, N_LANDMARKS};
    use crate::math::Point3;
    use crate::model::{Expressions, LandmarkMap, MorphableModel, PcaModel};
    use nalgebra::Vector6;

    /// 68 vertices on a curved sheet, 5 identity modes, 3 expressions; landmark i ↦ vertex i,
    /// weights that differ between landmarks.
    fn basis() -> LandmarkBasis {
        basis_of(5)
    }

    /// [`basis`] with `k_id` identity components (the first five are `basis`'s).
    fn basis_of(k_id: usize) -> LandmarkBasis {
        let n = N_LANDMARKS;
        let mean = DVector::from_fn(3 * n, |r, _| {
            let (i, axis) = (r / 3, r % 3);
            let (x, y) = (((i % 9) as Real - 4.0) * 15.0, ((i / 9) as Real - 3.5) * 18.0);
            [x, y, 50.0 - 0.005 * (x * x + y * y) + (i * 7 % 5) as Real][axis]
        });
        let model = MorphableModel {
            shape: PcaModel {
                mean,
                basis: DMatrix::from_fn(3 * n, k_id, |r, c| ((r * (c + 3)) as Real * 0.37).sin()),
                eigenvalues: DVector::from_fn(k_id, |c, _| {
                    [9.0, 4.0, 2.0, 1.0].get(c).copied().unwrap_or(0.5_f64.powi(c as i32 - 4))
                }),
            },
            expressions: Some(Expressions {
                names: vec!["a".into(), "b".into(), "c".into()],
                deltas: DMatrix::from_fn(3 * n, 3, |r, c| ((r + 7 * c) as Real * 0.11).cos() * 3.0),
            }),
            triangles: vec![],
        };
        let map = LandmarkMap { to_vertex: (0..n).map(|i| (i, i)).collect() };
        let weights: Vec<Real> = (0..n).map(|i| 1.0 + (i % 3) as Real * 0.5).collect();
        LandmarkBasis::new(&model, &map, LandmarkSet::F5, &weights)
    }

    /// Three frames with different poses and expressions (some clamped), noisy observations,
    /// and landmarks 5 and 30 unused in frame 1.
    fn frames(basis: &LandmarkBasis, alpha: &DVector) -> (Vec<FrameObservations>, Vec<FrameState>) {
        frames_with(basis, alpha, |f| vec![0.3 + 0.1 * f as Real, 0.0, 0.7])
    }

    /// [`frames`] with frame f's landmarks drawn (and its state started) at `betas(f)`.
    fn frames_with(
        basis: &LandmarkBasis,
        alpha: &DVector,
        betas: impl Fn(usize) -> Vec<Real>,
    ) -> (Vec<FrameObservations>, Vec<FrameState>) {
        let id_pts = identity_points(basis, alpha);
        let mut observations = Vec::new();
        let mut states = Vec::new();
        for f in 0..3 {
            let fr = f as Real;
            let pose = OrthoPose {
                r: rotation_from_yaw_pitch_roll_deg(10.0 - 8.0 * fr, 4.0 * fr - 3.0, 2.0 - fr),
                s: 1.5 + 0.2 * fr,
                tx: 200.0 + 10.0 * fr,
                ty: 150.0 - 5.0 * fr,
            };
            let beta = DVector::from_vec(betas(f));
            let points = (0..N_LANDMARKS)
                .map(|i| {
                    let x = landmark_point(basis, &id_pts, beta.as_slice(), i);
                    let p = pose.project(&Point3::from(x), 720.0);
                    let noise = ((i * 13 + f * 7) % 11) as Real * 0.3 - 1.5;
                    let mut lp = LandmarkPoint::tracked(p.x + noise, p.y - 0.5 * noise);
                    lp.visible = !(f == 1 && (i == 5 || i == 30));
                    lp
                })
                .collect();
            observations.push(FrameObservations::new(basis, &FrameLandmarks::new(f, points)));
            states.push(FrameState { pose, beta, free: vec![true, false, f != 2], failed: None });
        }
        (observations, states)
    }

    fn params() -> SolverParams {
        SolverParams {
            lambda_identity: 0.7,
            lambda_expression: 0.4,
            iterations: 10,
            temporal_smoothness: 0.0,
            nonnegative_expressions: false,
            solver: Solver::default(),
            sigma2: 3.0,
            min_points: 4,
            tolerance: 1e-3,
        }
    }

    /// A frame's Gauss–Newton Hessian and gradient over [pose (6) | coefficients (K)], summed
    /// landmark by landmark from the full Jacobian rows.
    fn dense_frame(
        basis: &LandmarkBasis,
        obs: &FrameObservations,
        st: &FrameState,
        id_pts: &[Vector3],
        p: &SolverParams,
    ) -> (DMatrix, DVector) {
        let k = basis.num_coefficients();
        let mut h = DMatrix::zeros(6 + k, 6 + k);
        let mut g = DVector::zeros(6 + k);
        for i in (0..basis.len()).filter(|&i| obs.active[i]) {
            let x = landmark_point(basis, id_pts, st.beta.as_slice(), i);
            let res = PoseResidual::new(&st.pose, &x, &obs.points[i], 720.0);
            let (ju, jv) = res.jacobian(&st.pose);
            let mut jrow = |jp: &Vector6<Real>, d: usize, r: Real| {
                let mut j = DVector::zeros(6 + k);
                j.rows_mut(0, 6).copy_from(jp);
                for axis in 0..3 {
                    let c = st.pose.s * st.pose.r[(d, axis)];
                    for (q, b) in basis.row(i, axis).iter().enumerate() {
                        j[6 + q] += c * b;
                    }
                }
                let om = basis.weights[i] / p.sigma2;
                h.ger(om, &j, &j, 1.0);
                g.axpy(om * r, &j, 1.0);
            };
            jrow(&ju, 0, res.u);
            jrow(&jv, 1, res.v);
        }
        (h, g)
    }

    /// The whole damped system over every frame's unknowns and α, built densely.
    fn dense_system(
        basis: &LandmarkBasis,
        observations: &[FrameObservations],
        states: &[FrameState],
        alpha: &DVector,
        p: &SolverParams,
        mu: Real,
    ) -> (DMatrix, DVector, Vec<Vec<usize>>) {
        let kid = basis.k_id;
        let id_pts = identity_points(basis, alpha);
        let unknowns: Vec<Vec<usize>> = states
            .iter()
            .map(|st| {
                let free = (0..basis.k_exp).filter(|&e| st.free[e]).map(|e| 6 + kid + e);
                (0..6).chain(free).collect()
            })
            .collect();
        let total: usize = unknowns.iter().map(Vec::len).sum::<usize>() + kid;
        let mut m = DMatrix::zeros(total, total);
        let mut rhs = DVector::zeros(total);
        let a0 = total - kid;
        for d in 0..kid {
            m[(a0 + d, a0 + d)] = p.lambda_identity;
            rhs[a0 + d] = p.lambda_identity * alpha[d];
        }
        let mut off = 0;
        for ((obs, st), u) in observations.iter().zip(states).zip(&unknowns) {
            let (h, g) = dense_frame(basis, obs, st, &id_pts, p);
            for (a, &ua) in u.iter().enumerate() {
                for (b, &ub) in u.iter().enumerate() {
                    m[(off + a, off + b)] = h[(ua, ub)];
                }
                for q in 0..kid {
                    m[(off + a, a0 + q)] = h[(ua, 6 + q)];
                    m[(a0 + q, off + a)] = h[(ua, 6 + q)];
                }
                rhs[off + a] = g[ua];
                if a >= 6 {
                    let e = ua - 6 - kid;
                    m[(off + a, off + a)] += p.lambda_expression;
                    rhs[off + a] += p.lambda_expression * st.beta[e];
                }
            }
            for q in 0..kid {
                for r in 0..kid {
                    m[(a0 + q, a0 + r)] += h[(6 + q, 6 + r)];
                }
                rhs[a0 + q] += g[6 + q];
            }
            off += u.len();
        }
        for d in 0..total {
            m[(d, d)] *= 1.0 + mu;
        }
        (m, rhs, unknowns)
    }

    fn relative(a: &[Real], b: &[Real]) -> Real {
        let d: Real = a.iter().zip(b).map(|(x, y)| (x - y) * (x - y)).sum();
        let n: Real = b.iter().map(|y| y * y).sum();
        (d / n.max(1e-300)).sqrt()
    }

    #[test]
    fn moments_of_the_basis_are_the_landmark_sums_to_the_bit() {
        // K = 8 and 9: whole blocks of four columns, and a last block padded with zeros.
        for k_id in [5, 6] {
            let basis = basis_of(k_id);
            let k = basis.num_coefficients();
            let alpha = DVector::from_fn(k_id, |c, _| 0.3 - 0.2 * c as Real);
            let id_pts = identity_points(&basis, &alpha);
            // Landmark by landmark, as the sums are defined: multiply, then add.
            let sums = |factors: &dyn Fn(usize) -> Vec<Real>| {
                let mut want = vec![0.0; 3 * factors(0).len() * k];
                for i in 0..basis.len() {
                    for (a, f) in factors(i).into_iter().enumerate() {
                        for b in 0..3 {
                            axpy(f, basis.row(i, b), &mut want[(3 * a + b) * k..][..k]);
                        }
                    }
                }
                want
            };
            let bits = |v: &[Real]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            let mut got = Vec::new();
            point_moments(&basis, &id_pts, &mut got);
            let w = &basis.weights;
            let want = sums(&|i| (0..3).map(|a| w[i] * id_pts[i][a]).collect());
            assert_eq!(bits(&got), bits(&want), "points, K = {k}");
            let (observations, _) = frames(&basis, &alpha);
            let got = observation_moments(&basis, &observations, 480.0);
            for (f, obs) in observations.iter().enumerate() {
                let want = sums(&|i| {
                    let p = &obs.points[i];
                    let on = if obs.active[i] { w[i] } else { 0.0 };
                    vec![on * p.x, on * (480.0 - p.y)]
                });
                assert_eq!(bits(got.column(f).as_slice()), bits(&want), "frame {f}, K = {k}");
            }
        }
    }

    #[test]
    fn expression_offsets_are_the_sums_over_the_expression_rows_to_the_bit() {
        let basis = basis();
        let beta = [0.7, 0.0, -1.3];
        for i in 0..basis.len() {
            let got = basis.expression_offset(i, &beta);
            for axis in 0..3 {
                let row = basis.expression_row(i, axis);
                let want = row.iter().zip(&beta).fold(0.0, |o: Real, (e, b)| o + e * b);
                assert_eq!(got[axis].to_bits(), want.to_bits(), "landmark {i}, axis {axis}");
            }
        }
    }

    #[test]
    fn schur_terms_add_w_transposed_w_to_the_lower_triangle_only() {
        // Nine rows (two passes of four and one row alone), seven columns (vectors and tails).
        let (rows, k) = (9, 7);
        let w: Vec<Real> = (0..rows * k).map(|x| ((x * 13 % 17) as Real - 8.0) * 0.25).collect();
        let mut out: Vec<Real> = (0..k * k).map(|x| x as Real).collect();
        gram_lower(&w, k, &mut out);
        for c in 0..k {
            for r in 0..k {
                let wtw: Real = (0..rows).map(|p| w[p * k + r] * w[p * k + c]).sum();
                let before = (c * k + r) as Real;
                let want = if r >= c { before + wtw } else { before };
                assert!((out[c * k + r] - want).abs() < 1e-12, "row {r}, column {c}");
            }
        }
    }

    #[test]
    fn gram_blocks_of_a_frames_entries_are_the_sums_over_those_entries_and_kept() {
        let basis = basis();
        let k = basis.num_coefficients();
        let mut used = vec![true; basis.len()];
        (used[5], used[30], used[67]) = (false, false, false);
        let grams = basis.used_grams(&used);
        for (g, &(a, b)) in GRAM_PAIRS.iter().enumerate() {
            for j in 0..k {
                let mut want = vec![0.0; k];
                for i in (0..basis.len()).filter(|&i| used[i]) {
                    let w = basis.weights[i];
                    axpy(w * basis.row(i, a)[j], basis.row(i, b), &mut want);
                    if a != b {
                        axpy(w * basis.row(i, b)[j], basis.row(i, a), &mut want);
                    }
                }
                let scale = want.iter().fold(1.0, |m: Real, v| m.max(v.abs()));
                for (got, want) in grams.column(g, j).iter().zip(&want) {
                    assert!((got - want).abs() < 1e-12 * scale, "block {g}, column {j}");
                }
            }
        }
        // The same set again is the kept blocks; every entry used is the basis's own.
        assert!(Arc::ptr_eq(&grams, &basis.used_grams(&used)));
        let all = vec![true; basis.len()];
        assert!(Arc::ptr_eq(&basis.used_grams(&all), &basis.used_grams(&all)));
        assert!(!Arc::ptr_eq(&grams, &basis.used_grams(&all)));
    }

    /// The test frames linearised at their states, where the step tests start.
    struct Linearised {
        basis: LandmarkBasis,
        alpha: DVector,
        observations: Vec<FrameObservations>,
        states: Vec<FrameState>,
        p: SolverParams,
        id_pts: Vec<Vector3>,
        lin: Linearisation,
    }

    impl Linearised {
        fn new() -> Self {
            let basis = basis();
            let alpha = DVector::from_vec(vec![0.4, -0.3, 0.2, 0.1, -0.5]);
            let (observations, states) = frames(&basis, &alpha);
            let p = params();
            let id_pts = identity_points(&basis, &alpha);
            let group = Group::new(&basis, &observations, 720.0, &p);
            let moments = observation_moments(&basis, &observations, 720.0);
            let mut lin = Linearisation::default();
            lin.update(&group, &moments, &states, &alpha, &id_pts, &p);
            Self { basis, alpha, observations, states, p, id_pts, lin }
        }
    }

    #[test]
    fn linearisation_from_moments_equals_the_landmark_sums() {
        let Linearised { basis, alpha, observations, states, p, lin, .. } = &Linearised::new();
        let (m, rhs, unknowns) = dense_system(basis, observations, states, alpha, p, 0.0);
        let kid = basis.k_id;
        let a0 = m.nrows() - kid;
        let mut off = 0;
        for (f, u) in unknowns.iter().enumerate() {
            let n = u.len();
            let a = &lin.a[lin.blocks[f]..lin.blocks[f + 1]];
            let want_a: Vec<Real> = (0..n * n).map(|x| m[(off + x / n, off + x % n)]).collect();
            assert!(relative(a, &want_a) < 1e-10, "frame {f} A");
            let c = &lin.c[lin.rows[f] * kid..lin.rows[f + 1] * kid];
            let want_c: Vec<Real> =
                (0..n * kid).map(|x| m[(off + x / kid, a0 + x % kid)]).collect();
            assert!(relative(c, &want_c) < 1e-10, "frame {f} C");
            let b = &lin.b[lin.rows[f]..lin.rows[f + 1]];
            assert!(relative(b, &rhs.as_slice()[off..off + n]) < 1e-10, "frame {f} b");
            off += n;
        }
        // S is kept as its lower triangle (what the Cholesky factorisation reads).
        let lower = |s: &dyn Fn(usize, usize) -> Real| -> Vec<Real> {
            (0..kid).flat_map(|c| (c..kid).map(move |r| (r, c))).map(|(r, c)| s(r, c)).collect()
        };
        let (got_s, want_s) = (lower(&|r, c| lin.s[(r, c)]), lower(&|r, c| m[(a0 + r, a0 + c)]));
        assert!(relative(&got_s, &want_s) < 1e-10, "S");
        assert!(relative(lin.g.as_slice(), &rhs.as_slice()[a0..]) < 1e-10, "g");
    }

    #[test]
    fn predicted_decrease_at_the_linearisation_point_is_the_steps_own() {
        let Linearised { basis, alpha, observations, states, p, id_pts, lin } = &Linearised::new();
        let group = Group::new(basis, observations, 720.0, p);
        let mut buf = StepBuffers::default();
        let mut out = states.clone();
        // Undamped, the step's own prediction is gᵀH⁻¹g with g from the moments; the
        // prediction from the landmarks' gradient and the factors kept must agree.
        let (_, stepped) =
            step(lin, &mut out, alpha, StepTry { mu: 0.0, hold: false }, true, p, &mut buf)
                .unwrap();
        assert!(lin.holds_structure_of(states));
        let predicted = predicted_decrease(&group, lin, &buf, states, alpha, id_pts, p);
        assert!(stepped > 0.0);
        assert!((predicted - stepped).abs() < 1e-8 * stepped, "{predicted} vs {stepped}");
        // The objective falls by about that much (the landmarks' noise keeps it from 0).
        let before = group.objective(states, id_pts, alpha, p);
        let mut out = states.clone();
        let (a, _) =
            step(lin, &mut out, alpha, StepTry { mu: 0.0, hold: false }, true, p, &mut buf)
                .unwrap();
        let after = group.objective(&out, &identity_points(basis, &a), &a, p);
        assert!(((before - after) / stepped - 1.0).abs() < 0.2, "{} vs {stepped}", before - after);
        // Another set of free expressions is another set of unknowns.
        let mut other = states.clone();
        other[2].free[0] = false;
        assert!(!lin.holds_structure_of(&other));
    }

    #[test]
    fn a_held_step_solves_the_system_with_the_crossing_expressions_at_zero() {
        // Frame 0's landmarks are drawn with expression 0 below its bound and its state
        // starts just above it, so that the free step takes it across.
        let basis = basis();
        let alpha = DVector::from_vec(vec![0.4, -0.3, 0.2, 0.1, -0.5]);
        let betas = |f: usize| if f == 0 { vec![-0.6, 0.0, 0.7] } else { vec![0.4, 0.0, 0.7] };
        let (observations, mut states) = frames_with(&basis, &alpha, betas);
        states[0].beta[0] = 0.05;
        let p = SolverParams { nonnegative_expressions: true, ..params() };
        let id_pts = identity_points(&basis, &alpha);
        let group = Group::new(&basis, &observations, 720.0, &p);
        let mut lin = Linearisation::default();
        let moments = observation_moments(&basis, &observations, 720.0);
        lin.update(&group, &moments, &states, &alpha, &id_pts, &p);
        let mu = 1e-3;
        let mut buf = StepBuffers::default();
        // Clamped: the step reports it, and the held row is frame 0's expression 0 alone.
        let mut clamped = states.clone();
        step(&lin, &mut clamped, &alpha, StepTry { mu, hold: false }, true, &p, &mut buf).unwrap();
        assert!(buf.clamped && clamped[0].beta[0] == 0.0);
        let mut out = states.clone();
        let (new_alpha, decrease) =
            step(&lin, &mut out, &alpha, StepTry { mu, hold: true }, true, &p, &mut buf).unwrap();
        assert!(!buf.clamped);
        let held: Vec<usize> = (0..buf.held.len()).filter(|&r| buf.held[r]).collect();
        assert_eq!(held, vec![lin.rows[0] + 6]);
        assert_eq!(out[0].beta[0], 0.0);
        assert!(out.iter().all(|st| st.beta.iter().all(|&b| b >= 0.0)));
        // The dense damped system with that unknown fixed at −β and the rest solved.
        let (m, rhs, unknowns) = dense_system(&basis, &observations, &states, &alpha, &p, mu);
        let fixed = 6;
        let d = -states[0].beta[0];
        let keep: Vec<usize> = (0..m.nrows()).filter(|&r| r != fixed).collect();
        let reduced = m.select_rows(&keep).select_columns(&keep);
        let moved =
            DVector::from_iterator(keep.len(), keep.iter().map(|&r| rhs[r] + m[(r, fixed)] * d));
        let solved = -reduced.lu().solve(&moved).unwrap();
        let mut want = DVector::zeros(m.nrows());
        keep.iter().zip(solved.iter()).for_each(|(&r, &v)| want[r] = v);
        want[fixed] = d;
        let a0 = m.nrows() - basis.k_id;
        assert!(relative((&new_alpha - &alpha).as_slice(), &want.as_slice()[a0..]) < 1e-8);
        let mut off = 0;
        for ((before, after), u) in states.iter().zip(&out).zip(&unknowns) {
            let dy = &want.as_slice()[off..off + u.len()];
            assert!((after.pose.s - before.pose.s - dy[3]).abs() < 1e-10);
            for (e, &ue) in u.iter().enumerate().skip(6) {
                let fe = ue - 6 - basis.k_id;
                assert!((after.beta[fe] - before.beta[fe] - dy[e]).abs() < 1e-8);
            }
            off += u.len();
        }
        // Its predicted decrease is the Gauss–Newton model's fall along that step, twice
        // (the objective's scale): −2·gᵀδ − δᵀHδ, H undamped.
        let mut h = m.clone();
        (0..h.nrows()).for_each(|r| h[(r, r)] /= 1.0 + mu);
        let model = -2.0 * rhs.dot(&want) - want.dot(&(&h * &want));
        assert!((decrease - model).abs() < 1e-8 * model.abs(), "{decrease} vs {model}");
        assert!(decrease > 0.0);
    }

    #[test]
    fn damping_falls_after_well_predicted_steps_and_rises_after_poor_ones() {
        assert_eq!(damping_factor(1.0), 1.0 / 3.0);
        assert_eq!(damping_factor(0.5), 1.0);
        assert_eq!(damping_factor(0.0), 2.0);
        assert!(damping_factor(0.9) < damping_factor(0.6));
    }

    #[test]
    fn step_solves_the_whole_damped_system() {
        let Linearised { basis, alpha, observations, states, p, lin, .. } = &Linearised::new();
        let mu = 1e-3;
        let mut out = states.clone();
        let new_alpha = step(
            lin,
            &mut out,
            alpha,
            StepTry { mu, hold: false },
            true,
            p,
            &mut StepBuffers::default(),
        )
        .unwrap()
        .0;
        let (m, rhs, unknowns) = dense_system(basis, observations, states, alpha, p, mu);
        let want = -m.lu().solve(&rhs).unwrap();
        let a0 = want.len() - basis.k_id;
        assert!(relative((&new_alpha - alpha).as_slice(), &want.as_slice()[a0..]) < 1e-8);
        let mut off = 0;
        for ((before, after), u) in states.iter().zip(&out).zip(&unknowns) {
            let dy = &want.as_slice()[off..off + u.len()];
            let rot = Rotation3::new(Vector3::new(dy[0], dy[1], dy[2])).into_inner();
            assert!((after.pose.r - rot * before.pose.r).amax() < 1e-10);
            assert!((after.pose.s - before.pose.s - dy[3]).abs() < 1e-10);
            assert!((after.pose.tx - before.pose.tx - dy[4]).abs() < 1e-8);
            assert!((after.pose.ty - before.pose.ty - dy[5]).abs() < 1e-8);
            for (e, &ue) in u.iter().enumerate().skip(6) {
                let fe = ue - 6 - basis.k_id;
                assert!((after.beta[fe] - before.beta[fe] - dy[e]).abs() < 1e-8);
            }
            off += u.len();
        }
    }
}
