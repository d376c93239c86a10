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
//! Clamped expressions (β = 0, NNLS active set) are held during a step.
//!
//! Start with [`solve`]; `clip.rs` runs it between eos's start and the final pose step.

use super::camera::{OrthoPose, PoseResidual};
use super::clip::{FrameState, Group, SolverParams, frame_points, identity_points, in_parallel};
use super::shape::{
    FrameObservations, LandmarkBasis, cholesky_solve_in_place, normal_matrix, projector,
};
use crate::math::{DMatrix, DVector, Matrix3, Point3, Real, Vector3};
use nalgebra::{Matrix6, Rotation3, Vector6};
use rayon::prelude::*;

/// Levenberg–Marquardt damping (fraction of the diagonal) at the start, its floor, and how
/// many times a rejected step is retried with 10× more damping.
const INITIAL_DAMPING: Real = 1e-4;
const MIN_DAMPING: Real = 1e-9;
const MAX_DAMPING_TRIES: usize = 8;

/// Refines the started states' poses on the mean shape, then takes damped joint steps (the
/// identity too when `solve_identity`) until the objective falls by less than the tolerance
/// or the iterations run out; returns the identity, the states and the identity part of the
/// landmark points. With `estimate_noise` the priors follow [`noise_factor`] from the second
/// iteration on.
pub(crate) fn solve(
    group: &Group<'_>,
    mut states: Vec<FrameState>,
    mut alpha: DVector,
    mut id_pts: Vec<Vector3>,
    solve_identity: bool,
    estimate_noise: bool,
) -> (DVector, Vec<FrameState>, Vec<Vector3>) {
    let (basis, observations, image_height) = (group.basis, group.observations, group.image_height);
    group.pose_step(&mut states, &id_pts, true);
    let base = *group.params;
    let mut params = base;
    let mut cost = group.objective(&states, &id_pts, &alpha, &params);
    let mut mu = INITIAL_DAMPING;
    for it in 0..params.iterations {
        // Empirical Bayes: once the fit has reached the noise floor, the priors' weight
        // follows the landmark noise estimated from the residuals (λ ∝ σ̂²).
        let mut lambda_moved = false;
        if it > 0
            && estimate_noise
            && let Some(f) = noise_factor(basis, observations, &states, &id_pts, image_height)
        {
            let old = params.lambda_identity;
            params.lambda_identity = base.lambda_identity * f;
            params.lambda_expression = base.lambda_expression * f;
            lambda_moved = (params.lambda_identity / old - 1.0).abs() > 0.1;
            cost = group.objective(&states, &id_pts, &alpha, &params);
        }
        let lin = linearise(basis, observations, &states, &alpha, &id_pts, image_height, &params);
        let mut accepted = false;
        for _ in 0..MAX_DAMPING_TRIES {
            if let Some((a, st)) = step(&lin, &states, &alpha, mu, solve_identity, &params) {
                let ids = identity_points(basis, &a);
                let c = group.objective(&st, &ids, &a, &params);
                if c < cost {
                    (alpha, states, id_pts) = (a, st, ids);
                    mu = (mu * 0.1).max(MIN_DAMPING);
                    accepted = true;
                    break;
                }
            }
            mu *= 10.0;
        }
        if !accepted {
            break;
        }
        // NNLS on β with pose and identity fixed (at the settings' own λ): updates which
        // expressions are clamped.
        group.expression_step(&mut states, &id_pts);
        let c = group.objective(&states, &id_pts, &alpha, &params);
        let done = c.is_nan() || (c >= cost * (1.0 - params.tolerance) && !lambda_moved);
        cost = c.min(cost);
        if done {
            break;
        }
    }
    (alpha, states, id_pts)
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
fn noise_factor(
    basis: &LandmarkBasis,
    observations: &[FrameObservations],
    states: &[FrameState],
    id_pts: &[Vector3],
    image_height: Real,
) -> Option<Real> {
    let mut n = 0.0;
    let mut p = basis.k_id as Real;
    let mut sse = 0.0;
    for (obs, st) in observations.iter().zip(states).filter(|(_, s)| s.failed.is_none()) {
        let pts = frame_points(basis, id_pts, &st.beta);
        for (i, x) in pts.iter().enumerate() {
            if obs.active[i] {
                let d = st.pose.project(&Point3::from(*x), image_height) - obs.points[i];
                sse += basis.weights[i] * d.norm_squared();
                n += 2.0 * basis.weights[i];
            }
        }
        p += 6.0 + st.free.iter().filter(|f| **f).count() as Real;
    }
    if n - p < p {
        return None;
    }
    let variance = (sse / (n - p)).max(MIN_NOISE_VARIANCE);
    Some(variance / (ASSUMED_NOISE_PX * ASSUMED_NOISE_PX))
}

/// One frame's part of the linearised normal equations (undamped).
struct FrameBlocks {
    /// Expression indices that are unknowns (after the 6 pose parameters).
    free: Vec<usize>,
    /// `A_f` (n×n, n = 6 + free.len()).
    a: DMatrix,
    /// Coupling with the identity `C_f` (n × k_id).
    c: DMatrix,
    /// Gradient of the frame's unknowns `b_f`.
    b: DVector,
    /// This frame's identity gradient.
    g_alpha: DVector,
    /// Identity-block correction for the landmarks the frame does not see.
    corr: Option<DMatrix>,
}

/// A frame's block after elimination: Cholesky factor L of A, W = L⁻¹C, z = L⁻¹b, WᵀW.
struct Eliminated {
    l: DMatrix,
    w: DMatrix,
    z: DVector,
    wtw: Option<DMatrix>,
}

/// The linearised problem at the current state.
pub(crate) struct Linearisation {
    frames: Vec<Option<FrameBlocks>>,
    /// Identity block `λ_id·I + Σ_f H_αα,f` (undamped).
    s: DMatrix,
    /// Identity gradient `λ_id·α + Σ_f g_α,f`.
    g: DVector,
}

/// Builds frame f's blocks: pose Jacobians per landmark, the pose–coefficient coupling as one
/// matrix product over all landmarks, the coefficient blocks from the precomputed Gram blocks.
fn frame_blocks(
    basis: &LandmarkBasis,
    obs: &FrameObservations,
    st: &FrameState,
    id_pts: &[Vector3],
    image_height: Real,
    params: &SolverParams,
) -> FrameBlocks {
    let (kid, k, l) = (basis.k_id, basis.num_coefficients(), basis.len());
    let pose = &st.pose;
    let s = pose.s;
    let (r1, r2) = (pose.r.row(0).transpose(), pose.r.row(1).transpose());
    let mut hpp = Matrix6::<Real>::zeros();
    let mut gp = Vector6::<Real>::zeros();
    // Per landmark: Gᵢ = ωᵢ·s·J_pᵢᵀ·R₂ (6×3, stored as 3L×6 rows) and the force
    // hᵢ = ωᵢ·s·R₂ᵀ·rᵢ (3L), so that H_pc = Σ Gᵢ·Bᵢ and g_c = Σ Bᵢᵀhᵢ are matrix products.
    let mut g_all = DMatrix::zeros(3 * l, 6);
    let mut h_all = DVector::zeros(3 * l);
    let beta = st.beta.as_slice();
    for i in 0..l {
        if !obs.active[i] {
            continue;
        }
        let mut x = id_pts[i];
        for j in 0..3 {
            x[j] += super::shape::dot(&basis.row(i, j)[kid..], beta);
        }
        let res = PoseResidual::new(pose, &x, &obs.points[i], image_height);
        let (ru, rv) = (res.u, res.v);
        let om = basis.weights[i] / params.sigma2;
        let (ju, jv) = res.jacobian(pose);
        hpp += (ju * ju.transpose() + jv * jv.transpose()) * om;
        gp += (ju * ru + jv * rv) * om;
        let h = (r1 * ru + r2 * rv) * (om * s);
        for j in 0..3 {
            h_all[3 * i + j] = h[j];
            for p in 0..6 {
                g_all[(3 * i + j, p)] = om * s * (ju[p] * r1[j] + jv[p] * r2[j]);
            }
        }
    }
    let bt = basis.rows_transposed(); // K × 3L
    let hpc_t = bt * &g_all; // K × 6 = H_pcᵀ
    let g_c = bt * &h_all; // K
    let nx = normal_matrix(basis, obs, pose, params.sigma2, 0..k, kid..k); // K × k_exp
    let free: Vec<usize> = (0..basis.k_exp).filter(|&j| st.free[j]).collect();
    let n = 6 + free.len();
    let mut a = DMatrix::zeros(n, n);
    let mut b = DVector::zeros(n);
    for p in 0..6 {
        for q in 0..6 {
            a[(p, q)] = hpp[(p, q)];
        }
        b[p] = gp[p];
    }
    for (e, &fe) in free.iter().enumerate() {
        for p in 0..6 {
            let v = hpc_t[(kid + fe, p)];
            a[(p, 6 + e)] = v;
            a[(6 + e, p)] = v;
        }
        for (e2, &fe2) in free.iter().enumerate() {
            a[(6 + e, 6 + e2)] = nx[(kid + fe, fe2)];
        }
        a[(6 + e, 6 + e)] += params.lambda_expression;
        b[6 + e] = g_c[kid + fe] + params.lambda_expression * st.beta[fe];
    }
    let mut c = DMatrix::zeros(n, kid);
    for q in 0..kid {
        for p in 0..6 {
            c[(p, q)] = hpc_t[(q, p)];
        }
        for (e, &fe) in free.iter().enumerate() {
            c[(6 + e, q)] = nx[(q, fe)];
        }
    }
    let scale = s * s / params.sigma2;
    let mut corr: Option<DMatrix> = None;
    for (i, &act) in obs.active.iter().enumerate() {
        if !act {
            let m = corr.get_or_insert_with(|| DMatrix::zeros(kid, kid));
            basis.sub_point_block(i, pose, scale, 0..kid, 0..kid, m);
        }
    }
    FrameBlocks { free, a, c, b, g_alpha: g_c.rows(0, kid).into_owned(), corr }
}

/// Linearises the objective at the current state (failed frames are left out).
pub(crate) fn linearise(
    basis: &LandmarkBasis,
    observations: &[FrameObservations],
    states: &[FrameState],
    alpha: &DVector,
    id_pts: &[Vector3],
    image_height: Real,
    params: &SolverParams,
) -> Linearisation {
    let kid = basis.k_id;
    let one = |(obs, st): (&FrameObservations, &FrameState)| {
        st.failed.is_none().then(|| frame_blocks(basis, obs, st, id_pts, image_height, params))
    };
    let frames: Vec<Option<FrameBlocks>> = if in_parallel(observations.len()) {
        observations.par_iter().zip(states.par_iter()).map(one).collect()
    } else {
        observations.iter().zip(states).map(one).collect()
    };
    let mut q_sum = Matrix3::zeros();
    for st in states.iter().filter(|s| s.failed.is_none()) {
        q_sum += projector(&st.pose) * (st.pose.s * st.pose.s / params.sigma2);
    }
    let mut s = DMatrix::identity(kid, kid) * params.lambda_identity;
    basis.add_gram_block(&q_sum, 1.0, 0..kid, 0..kid, &mut s);
    let mut g = alpha * params.lambda_identity;
    for fb in frames.iter().flatten() {
        if let Some(c) = &fb.corr {
            s += c;
        }
        g += &fb.g_alpha;
    }
    Linearisation { frames, s, g }
}

/// Adds `μ·diag(m)` to `m` (Marquardt's scale-invariant damping).
fn damp(m: &mut DMatrix, mu: Real) {
    for d in 0..m.nrows() {
        m[(d, d)] *= 1.0 + mu;
    }
}

/// `L⁻¹·B` in place for a lower-triangular n×n `l` and the columns of `b` (column-major,
/// n rows): nalgebra's `solve_lower_triangular` operation for operation (so the same bits),
/// without the per-column views and strided updates that made it a tenth of a clip fit's
/// time. False on a zero pivot, as nalgebra's.
fn forward_substitute(l: &DMatrix, b: &mut [Real]) -> bool {
    let n = l.nrows();
    let ls = l.as_slice();
    for col in b.chunks_exact_mut(n.max(1)) {
        for i in 0..n {
            let diag = ls[i * n + i];
            if diag == 0.0 {
                return false;
            }
            let coeff = col[i] / diag;
            col[i] = coeff;
            for (y, &x) in col[i + 1..].iter_mut().zip(&ls[i * n + i + 1..(i + 1) * n]) {
                *y += -coeff * x;
            }
        }
    }
    true
}

/// Solves the damped system and applies the step: returns the new identity and frame states,
/// or None when a block is not positive definite. With `solve_identity` false the identity
/// stays (δα = 0). Expressions are projected onto β ≥ 0 when the settings ask for it.
pub(crate) fn step(
    lin: &Linearisation,
    states: &[FrameState],
    alpha: &DVector,
    mu: Real,
    solve_identity: bool,
    params: &SolverParams,
) -> Option<(DVector, Vec<FrameState>)> {
    let kid = alpha.len();
    // Per frame, with A = LLᵀ (damped): W = L⁻¹C and z = L⁻¹b, so that the Schur terms are
    // CᵀA⁻¹C = WᵀW (a symmetric product run by the matrix-multiply kernel) and CᵀA⁻¹b = Wᵀz.
    // In parallel each frame keeps its WᵀW for the ordered sum below; on one thread it is made
    // there, into one buffer, instead of holding a k_id² matrix per frame (32 MB per 1,000).
    let parallel = in_parallel(lin.frames.len());
    let need_wtw = solve_identity && kid > 0;
    let eliminate = |fb: &Option<FrameBlocks>| -> Option<Option<Eliminated>> {
        let Some(fb) = fb else { return Some(None) };
        let mut a = fb.a.clone();
        damp(&mut a, mu);
        let l = a.cholesky()?.unpack();
        let mut w = fb.c.clone();
        let mut z = fb.b.clone();
        if !(forward_substitute(&l, w.as_mut_slice()) && forward_substitute(&l, z.as_mut_slice())) {
            return None;
        }
        let wtw = (need_wtw && parallel).then(|| w.transpose() * &w);
        Some(Some(Eliminated { l, w, z, wtw }))
    };
    let solved: Vec<Option<Eliminated>> = if parallel {
        lin.frames.par_iter().map(eliminate).collect::<Option<Vec<_>>>()?
    } else {
        lin.frames.iter().map(eliminate).collect::<Option<Vec<_>>>()?
    };
    let mut dalpha = DVector::zeros(kid);
    if need_wtw {
        let mut s = lin.s.clone();
        damp(&mut s, mu);
        let mut r = lin.g.clone();
        let mut buffer = DMatrix::zeros(kid, kid);
        for e in solved.iter().flatten() {
            match &e.wtw {
                Some(wtw) => s -= wtw,
                None => {
                    // The same kernel call as `Wᵀ * W`, so the same bits.
                    buffer.gemm(1.0, &e.w.transpose(), &e.w, 0.0);
                    s -= &buffer;
                }
            }
            r.gemv_tr(-1.0, &e.w, &e.z, 1.0);
        }
        if !cholesky_solve_in_place(s.as_mut_slice(), kid, r.as_mut_slice()) {
            return None;
        }
        dalpha = -r;
    }
    let mut out = states.to_vec();
    for ((st, fb), xy) in out.iter_mut().zip(&lin.frames).zip(&solved) {
        let (Some(fb), Some(e)) = (fb, xy) else { continue };
        // δy = −A⁻¹(b + C·δα) = −L⁻ᵀ(z + W·δα)
        let mut v = e.z.clone();
        v.gemv(1.0, &e.w, &dalpha, 1.0);
        let dy = -e.l.tr_solve_lower_triangular(&v)?;
        if !dy.iter().all(|v| v.is_finite()) {
            return None;
        }
        let rot = Rotation3::new(Vector3::new(dy[0], dy[1], dy[2]));
        let pose = OrthoPose {
            r: rot.into_inner() * st.pose.r,
            s: st.pose.s + dy[3],
            tx: st.pose.tx + dy[4],
            ty: st.pose.ty + dy[5],
        };
        if !pose.is_valid() {
            return None;
        }
        st.pose = pose;
        for (e, &fe) in fb.free.iter().enumerate() {
            let v = st.beta[fe] + dy[6 + e];
            st.beta[fe] = if params.nonnegative_expressions { v.max(0.0) } else { v };
        }
    }
    let new_alpha = alpha + dalpha;
    new_alpha.iter().all(|v| v.is_finite()).then_some((new_alpha, out))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn forward_substitution_matches_nalgebra_bit_for_bit() {
        let m = DMatrix::from_fn(7, 7, |i, j| {
            1.0 / (1.0 + i as Real + j as Real) + if i == j { 3.0 } else { 0.0 }
        });
        let l = m.cholesky().unwrap().unpack();
        let c = DMatrix::from_fn(7, 5, |i, j| ((i * 5 + j) as Real * 0.73).sin());
        let want = l.solve_lower_triangular(&c).unwrap();
        let mut got = c.clone();
        assert!(forward_substitute(&l, got.as_mut_slice()));
        assert!(got.iter().zip(want.iter()).all(|(a, b)| a.to_bits() == b.to_bits()));
        let mut singular = DMatrix::identity(3, 3);
        singular[(1, 1)] = 0.0;
        assert!(!forward_substitute(&singular, &mut [1.0, 2.0, 3.0]));
    }
}
