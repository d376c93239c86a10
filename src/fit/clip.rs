//! The solver for a group of frames that share one identity (a clip), with pose and expression
//! per frame; a single frame is the one-frame case of the same solver.
//!
//! Default (`pose_refinement_steps` > 0): start from eos's linear camera on the mean shape and
//! NNLS expressions, then joint Levenberg–Marquardt steps over all poses, free expressions and
//! the identity (`joint.rs`), each followed by an NNLS pass on β (updates which expressions
//! are clamped at 0); in groups with enough residual degrees of freedom the priors follow the
//! landmark noise estimated from the residuals. With `pose_refinement_steps` = 0 (eos's
//! linear camera only) the older alternation runs: pose per frame; identity jointly with the
//! free expressions (Schur complement, prior once per clip); expressions per frame (NNLS,
//! optional temporal smoothness). A final pose step matches the reported pose to the shape.

use super::camera::{self, OrthoPose};
use super::joint;
use super::shape::{
    FrameObservations, LandmarkBasis, apply_forces, cholesky_solve_in_place, dot, gradient_rhs,
    landmark_forces, nonnegative_quadratic, normal_matrix, projector,
};
use crate::math::{DMatrix, DVector, Matrix3, Point3, Real, Vector3};
use rayon::prelude::*;

/// Levenberg–Marquardt damping (fraction of the diagonal) at the start, its floor, and how
/// many times a rejected step is retried with 10× more damping.
const INITIAL_DAMPING: Real = 1e-4;
const MIN_DAMPING: Real = 1e-9;
const MAX_DAMPING_TRIES: usize = 8;

/// Solver parameters in the units of the equations (see `FitSettings` for their meaning).
#[derive(Clone, Copy, Debug)]
pub struct SolverParams {
    pub lambda_identity: Real,
    pub lambda_expression: Real,
    pub iterations: usize,
    pub temporal_smoothness: Real,
    pub nonnegative_expressions: bool,
    pub pose_refinement_steps: usize,
    pub sigma2: Real,
    pub min_points: usize,
    /// Stop iterating when the objective falls by less than this fraction.
    pub tolerance: Real,
    /// Scale the priors by the landmark noise estimated from the residuals (groups with
    /// enough residual degrees of freedom only; see [`noise_factor`]).
    pub estimate_noise: bool,
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

/// The state of one frame during and after a fit.
#[derive(Clone, Debug)]
pub struct FrameState {
    pub pose: OrthoPose,
    /// Expression coefficients β (length k_exp).
    pub beta: DVector,
    /// Which β are unconstrained (not clamped at 0).
    pub(crate) free: Vec<bool>,
    /// Why the frame cannot be fitted, if it cannot.
    pub failed: Option<String>,
}

/// The result of fitting a group of frames.
#[derive(Clone, Debug)]
pub struct GroupFit {
    /// Identity α (length k_id), shared by the group.
    pub alpha: DVector,
    pub frames: Vec<FrameState>,
}

/// Landmark points of a frame: the identity part (shared) plus the frame's expression offsets.
fn frame_points(basis: &LandmarkBasis, id_pts: &[Vector3], beta: &DVector) -> Vec<Vector3> {
    let kid = basis.k_id;
    id_pts
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let mut q = *p;
            for j in 0..3 {
                q[j] += dot(&basis.row(i, j)[kid..], beta.as_slice());
            }
            q
        })
        .collect()
}

/// Identity part `mean + B_id·α` of every landmark point.
fn identity_points(basis: &LandmarkBasis, alpha: &DVector) -> Vec<Vector3> {
    let mut c = vec![0.0; basis.num_coefficients()];
    c[..basis.k_id].copy_from_slice(alpha.as_slice());
    basis.points_partial(&c, 0..basis.k_id)
}

/// Pose of one frame for the landmark points `pts`: eos's linear estimate, then Gauss–Newton
/// refinement; with a `previous` pose (and refinement on) Gauss–Newton starts from it instead,
/// since the shape moves little between iterations.
fn estimate_pose(
    basis: &LandmarkBasis,
    obs: &FrameObservations,
    pts: &[Vector3],
    image_height: Real,
    params: &SolverParams,
    previous: Option<&OrthoPose>,
) -> Result<OrthoPose, String> {
    let mut p2 = Vec::with_capacity(obs.num_active);
    let mut p3 = Vec::with_capacity(obs.num_active);
    let mut w = Vec::with_capacity(obs.num_active);
    for (i, p) in pts.iter().enumerate() {
        if obs.active[i] {
            p2.push(obs.points[i]);
            p3.push(Point3::from(*p));
            w.push(basis.weights[i]);
        }
    }
    let pose = match previous {
        Some(p) if params.pose_refinement_steps > 0 => *p,
        _ => {
            camera::estimate_orthographic_pose(&p2, &p3, image_height).map_err(|e| e.to_string())?
        }
    };
    Ok(if params.pose_refinement_steps > 0 {
        camera::refine_orthographic_pose(
            &pose,
            &p2,
            &p3,
            Some(&w),
            image_height,
            params.pose_refinement_steps,
        )
    } else {
        pose
    })
}

/// Expressions of one frame with identity fixed (`id_pts` = identity part of the points):
/// minimises the data term plus `λ_e|β|² + μ·Σ_nbr |β − β_nbr|²`, with β ≥ 0 when asked.
fn solve_expressions(
    basis: &LandmarkBasis,
    obs: &FrameObservations,
    state: &mut FrameState,
    id_pts: &[Vector3],
    neighbours: &[&DVector],
    image_height: Real,
    params: &SolverParams,
) {
    let (kid, k) = (basis.k_id, basis.num_coefficients());
    if basis.k_exp == 0 {
        return;
    }
    let mut n = normal_matrix(basis, obs, &state.pose, params.sigma2, kid..k, kid..k);
    let mut g = gradient_rhs(basis, obs, &state.pose, image_height, params.sigma2, id_pts, kid..k);
    let mu = params.temporal_smoothness;
    for d in 0..basis.k_exp {
        n[(d, d)] += params.lambda_expression + mu * neighbours.len() as Real;
    }
    for nb in neighbours {
        g.axpy(mu, nb, 1.0);
    }
    let beta = if params.nonnegative_expressions {
        nonnegative_quadratic(&n, &g, &mut state.free)
    } else {
        state.free.iter_mut().for_each(|f| *f = true);
        n.cholesky().map(|ch| ch.solve(&g))
    };
    match beta {
        Some(b) if b.iter().all(|v| v.is_finite()) => state.beta = b,
        _ => state.failed = Some("expression fit is singular".into()),
    }
}

/// Identity shared by the frames, jointly with each frame's free expressions (eliminated by a
/// Schur complement); clamped expressions stay at 0. The prior λ_id·|α|² enters once.
/// The identity block of all frames is one Gram combination with the frames' projectors
/// summed (`Σ_f s_f²·Q_f`), corrected only for points a frame does not see.
fn solve_identity(
    basis: &LandmarkBasis,
    observations: &[FrameObservations],
    states: &[FrameState],
    mean_pts: &[Vector3],
    image_height: Real,
    params: &SolverParams,
) -> Option<DVector> {
    let (kid, k) = (basis.k_id, basis.num_coefficients());
    let mut q_sum = Matrix3::zeros();
    for st in states.iter().filter(|s| s.failed.is_none()) {
        q_sum += projector(&st.pose) * (st.pose.s * st.pose.s / params.sigma2);
    }
    let mut s = DMatrix::identity(kid, kid) * params.lambda_identity;
    basis.add_gram_block(&q_sum, 1.0, 0..kid, 0..kid, &mut s);
    let per_frame =
        |(obs, st): (&FrameObservations, &FrameState)| -> (Option<DMatrix>, DVector, Vec<Vector3>) {
            let pose = &st.pose;
            let scale = pose.s * pose.s / params.sigma2;
            let mut corr: Option<DMatrix> = None;
            for (i, &a) in obs.active.iter().enumerate() {
                if !a {
                    let c = corr.get_or_insert_with(|| DMatrix::zeros(kid, kid));
                    basis.sub_point_block(i, pose, scale, 0..kid, 0..kid, c);
                }
            }
            let forces = landmark_forces(basis, obs, pose, image_height, params.sigma2, mean_pts);
            // The identity part of the gradient is applied once for the clip (summed forces);
            // here only the Schur correction of r.
            let g = apply_forces(basis, &forces, kid..k);
            let mut r = DVector::zeros(kid);
            let free: Vec<usize> = (0..basis.k_exp).filter(|&j| st.free[j]).collect();
            if !free.is_empty() {
                // Columns of the expression block against everything: rows 0..K, cols kid..K.
                let nx = normal_matrix(basis, obs, pose, params.sigma2, 0..k, kid..k);
                let m = free.len();
                let mut nff = DMatrix::from_fn(m, m, |a, b| nx[(kid + free[a], free[b])]);
                for d in 0..m {
                    nff[(d, d)] += params.lambda_expression;
                }
                let naf = DMatrix::from_fn(kid, m, |a, b| nx[(a, free[b])]);
                let gf = DVector::from_fn(m, |a, _| g[free[a]]);
                if let Some(ch) = nff.cholesky() {
                    // S −= N_aF·N_FF⁻¹·N_Fa ; r −= N_aF·N_FF⁻¹·g_F
                    let x = ch.solve(&naf.transpose()); // m × kid
                    let c = corr.get_or_insert_with(|| DMatrix::zeros(kid, kid));
                    c.gemm(-1.0, &naf, &x, 1.0);
                    let y = ch.solve(&gf);
                    r.gemv(-1.0, &naf, &y, 1.0);
                }
            }
            (corr, r, forces)
        };
    let pairs = observations.iter().zip(states).filter(|(_, s)| s.failed.is_none());
    let parts: Vec<(Option<DMatrix>, DVector, Vec<Vector3>)> = if observations.len() > 1 {
        pairs.collect::<Vec<_>>().into_par_iter().map(per_frame).collect()
    } else {
        pairs.map(per_frame).collect()
    };
    let mut r = DVector::zeros(kid);
    let mut forces = vec![Vector3::zeros(); basis.len()];
    for (c, rp, fp) in &parts {
        if let Some(c) = c {
            s += c;
        }
        r += rp;
        for (a, b) in forces.iter_mut().zip(fp) {
            *a += b;
        }
    }
    r += apply_forces(basis, &forces, 0..kid);
    cholesky_solve_in_place(s.as_mut_slice(), kid, r.as_mut_slice()).then_some(r)
}

/// The objective: weighted squared reprojection error over σ², plus the priors.
fn objective(
    basis: &LandmarkBasis,
    observations: &[FrameObservations],
    states: &[FrameState],
    id_pts: &[Vector3],
    alpha: &DVector,
    image_height: Real,
    params: &SolverParams,
) -> Real {
    let mut cost = params.lambda_identity * alpha.norm_squared();
    for (obs, st) in observations.iter().zip(states).filter(|(_, s)| s.failed.is_none()) {
        let pts = frame_points(basis, id_pts, &st.beta);
        for (i, p) in pts.iter().enumerate() {
            if obs.active[i] {
                let d = st.pose.project(&Point3::from(*p), image_height) - obs.points[i];
                cost += basis.weights[i] * d.norm_squared() / params.sigma2;
            }
        }
        cost += params.lambda_expression * st.beta.norm_squared();
    }
    cost
}

/// Runs `f` over frames, in parallel when there is more than one.
fn for_each_frame<F>(states: &mut [FrameState], f: F)
where
    F: Fn(usize, &mut FrameState) + Sync + Send,
{
    if states.len() > 1 {
        states.par_iter_mut().enumerate().for_each(|(i, st)| f(i, st));
    } else {
        states.iter_mut().enumerate().for_each(|(i, st)| f(i, st));
    }
}

/// Fits a group of frames that share one identity. Frames with too few usable points or a
/// degenerate camera are marked failed and left out of the identity. With `alpha_fixed` the
/// identity is not solved (pose and expressions only).
pub fn fit_group(
    basis: &LandmarkBasis,
    observations: &[FrameObservations],
    image_height: Real,
    params: &SolverParams,
    alpha_fixed: Option<&DVector>,
) -> GroupFit {
    let (kid, kexp) = (basis.k_id, basis.k_exp);
    let mut alpha = alpha_fixed.cloned().unwrap_or_else(|| DVector::zeros(kid));
    let mut states: Vec<FrameState> = observations
        .iter()
        .map(|obs| {
            let failed = if obs.num_active < params.min_points.max(4) {
                Some(format!("too few usable landmarks ({} of {})", obs.num_active, basis.len()))
            } else {
                None
            };
            FrameState {
                pose: OrthoPose { r: Matrix3::identity(), s: 1.0, tx: 0.0, ty: 0.0 },
                beta: DVector::zeros(kexp),
                free: vec![false; kexp],
                failed,
            }
        })
        .collect();
    let mean_pts = basis.points_partial(&vec![0.0; basis.num_coefficients()], 0..0);

    let pose_step = |states: &mut [FrameState], id_pts: &[Vector3], warm: bool| {
        for_each_frame(states, |f, st| {
            if st.failed.is_some() {
                return;
            }
            let pts = frame_points(basis, id_pts, &st.beta);
            let prev = warm.then_some(&st.pose);
            match estimate_pose(basis, &observations[f], &pts, image_height, params, prev) {
                Ok(p) => st.pose = p,
                Err(e) => st.failed = Some(e),
            }
        });
    };
    let frame_no: Vec<usize> = observations.iter().map(|o| o.frame).collect();
    let expression_step = |states: &mut [FrameState], id_pts: &[Vector3]| {
        let old: Vec<DVector> = if params.temporal_smoothness > 0.0 {
            states.iter().map(|s| s.beta.clone()).collect()
        } else {
            Vec::new()
        };
        for_each_frame(states, |f, st| {
            if st.failed.is_some() {
                return;
            }
            let mut nb: Vec<&DVector> = Vec::new();
            if !old.is_empty() {
                if f > 0 && frame_no[f - 1] + 1 == frame_no[f] {
                    nb.push(&old[f - 1]);
                }
                if f + 1 < old.len() && frame_no[f] + 1 == frame_no[f + 1] {
                    nb.push(&old[f + 1]);
                }
            }
            solve_expressions(basis, &observations[f], st, id_pts, &nb, image_height, params);
        });
    };

    // Start: pose from the mean shape, expressions from that pose (as eos does).
    let mut id_pts = identity_points(basis, &alpha);
    pose_step(&mut states, &id_pts, false);
    expression_step(&mut states, &id_pts);
    if params.pose_refinement_steps > 0 {
        // Refine the start pose on the mean shape, then joint Levenberg–Marquardt steps.
        pose_step(&mut states, &id_pts, true);
        let solve_id = alpha_fixed.is_none() && kid > 0;
        let base = *params;
        let mut params = *params;
        let params = &mut params;
        let mut cost =
            objective(basis, observations, &states, &id_pts, &alpha, image_height, params);
        let mut mu = INITIAL_DAMPING;
        for it in 0..params.iterations {
            // Empirical Bayes: once the fit has reached the noise floor, the priors' weight
            // follows the landmark noise estimated from the residuals (λ ∝ σ̂²).
            let mut lambda_moved = false;
            if it > 0
                && base.estimate_noise
                && let Some(f) = noise_factor(basis, observations, &states, &id_pts, image_height)
            {
                let old = params.lambda_identity;
                params.lambda_identity = base.lambda_identity * f;
                params.lambda_expression = base.lambda_expression * f;
                lambda_moved = (params.lambda_identity / old - 1.0).abs() > 0.1;
                cost =
                    objective(basis, observations, &states, &id_pts, &alpha, image_height, params);
            }
            let lin = joint::linearise(
                basis,
                observations,
                &states,
                &alpha,
                &id_pts,
                image_height,
                params,
            );
            let mut accepted = false;
            for _ in 0..MAX_DAMPING_TRIES {
                if let Some((a, st)) = joint::step(&lin, &states, &alpha, mu, solve_id, params) {
                    let ids = identity_points(basis, &a);
                    let c = objective(basis, observations, &st, &ids, &a, image_height, params);
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
            // NNLS on β with pose and identity fixed: updates which expressions are clamped.
            expression_step(&mut states, &id_pts);
            let c = objective(basis, observations, &states, &id_pts, &alpha, image_height, params);
            let done = c.is_nan() || (c >= cost * (1.0 - params.tolerance) && !lambda_moved);
            cost = c.min(cost);
            if done {
                break;
            }
        }
        pose_step(&mut states, &id_pts, true);
        return GroupFit { alpha, frames: states };
    }
    let mut last = Real::INFINITY;
    for _ in 0..params.iterations {
        pose_step(&mut states, &id_pts, true);
        if alpha_fixed.is_none() && kid > 0 {
            match solve_identity(basis, observations, &states, &mean_pts, image_height, params) {
                Some(a) => alpha = a,
                None => break,
            }
            id_pts = identity_points(basis, &alpha);
        }
        expression_step(&mut states, &id_pts);
        // Stop once the objective stops falling (DESIGN §5.3).
        let cost = objective(basis, observations, &states, &id_pts, &alpha, image_height, params);
        if cost.is_nan() || cost >= last * (1.0 - params.tolerance) {
            break;
        }
        last = cost;
    }
    pose_step(&mut states, &id_pts, true);
    GroupFit { alpha, frames: states }
}
