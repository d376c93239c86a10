//! The alternating camera/shape solver for a group of frames that share one identity (a clip),
//! with pose and expression per frame; a single frame is the one-frame case of the same solver.
//!
//! Each iteration: (1) per frame, the pose from the current shape (linear affine camera, then
//! Gauss–Newton on the reprojection error); (2) the identity α jointly with every frame's free
//! expression coefficients, by eliminating the expressions frame by frame (Schur complement)
//! and solving the stacked identity system once, with the identity prior counted once per clip;
//! (3) per frame, the expressions β ≥ 0 with the identity fixed (active-set NNLS), optionally
//! pulled toward the neighbouring frames' β (temporal smoothness, one Jacobi sweep per
//! iteration). A final pose step makes the reported pose match the final shape.

use super::camera::{self, OrthoPose};
use super::shape::{
    FrameObservations, LandmarkBasis, gradient_rhs, nonnegative_quadratic, normal_matrix,
};
use crate::math::{DMatrix, DVector, Point2, Point3, Real};
use rayon::prelude::*;

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
}

/// The state of one frame during and after a fit.
#[derive(Clone, Debug)]
pub struct FrameState {
    pub pose: OrthoPose,
    /// Expression coefficients β (length k_exp).
    pub beta: DVector,
    /// Which β are unconstrained (not clamped at 0).
    free: Vec<bool>,
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

fn coefficients(alpha: &DVector, beta: &DVector) -> Vec<Real> {
    alpha.iter().chain(beta.iter()).copied().collect()
}

/// Active landmark points of a frame and their current 3D positions.
fn correspondences(
    basis: &LandmarkBasis,
    obs: &FrameObservations,
    c: &[Real],
) -> (Vec<Point2>, Vec<Point3>, Vec<Real>) {
    let mut p2 = Vec::with_capacity(obs.num_active);
    let mut p3 = Vec::with_capacity(obs.num_active);
    let mut w = Vec::with_capacity(obs.num_active);
    for i in 0..basis.len() {
        if obs.active[i] {
            p2.push(obs.points[i]);
            p3.push(basis.point(i, c));
            w.push(basis.weights[i]);
        }
    }
    (p2, p3, w)
}

/// Pose of one frame for the shape with coefficients `c`: eos's linear estimate, then
/// Gauss–Newton refinement.
fn estimate_pose(
    basis: &LandmarkBasis,
    obs: &FrameObservations,
    c: &[Real],
    image_height: Real,
    params: &SolverParams,
) -> Result<OrthoPose, String> {
    let (p2, p3, w) = correspondences(basis, obs, c);
    let pose = camera::estimate_orthographic_pose(&p2, &p3, image_height).map_err(|e| e.to_string())?;
    Ok(if params.pose_refinement_steps > 0 {
        camera::refine_orthographic_pose(&pose, &p2, &p3, Some(&w), image_height, params.pose_refinement_steps)
    } else {
        pose
    })
}

/// Expressions of one frame with identity fixed: minimises the data term plus
/// `λ_e|β|² + μ·Σ_nbr |β − β_nbr|²`, with β ≥ 0 when asked.
fn solve_expressions(
    basis: &LandmarkBasis,
    obs: &FrameObservations,
    state: &mut FrameState,
    alpha: &DVector,
    neighbours: &[&DVector],
    image_height: Real,
    params: &SolverParams,
) {
    let (kid, k) = (basis.k_id, basis.num_coefficients());
    if basis.k_exp == 0 {
        return;
    }
    let mut n = normal_matrix(basis, obs, &state.pose, params.sigma2, kid..k, kid..k);
    let c = coefficients(alpha, &DVector::zeros(basis.k_exp));
    let mut g = gradient_rhs(basis, obs, &state.pose, image_height, params.sigma2, &c, kid..k);
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
fn solve_identity(
    basis: &LandmarkBasis,
    observations: &[FrameObservations],
    states: &[FrameState],
    image_height: Real,
    params: &SolverParams,
) -> Option<DVector> {
    let (kid, k) = (basis.k_id, basis.num_coefficients());
    let zeros = vec![0.0; k];
    let parts: Vec<(DMatrix, DVector)> = observations
        .par_iter()
        .zip(states.par_iter())
        .filter(|(_, s)| s.failed.is_none())
        .map(|(obs, st)| {
            let pose = &st.pose;
            let mut s = normal_matrix(basis, obs, pose, params.sigma2, 0..kid, 0..kid);
            let g = gradient_rhs(basis, obs, pose, image_height, params.sigma2, &zeros, 0..k);
            let mut r = g.rows(0, kid).into_owned();
            let free: Vec<usize> = (0..basis.k_exp).filter(|&j| st.free[j]).collect();
            if !free.is_empty() {
                let nab = normal_matrix(basis, obs, pose, params.sigma2, 0..kid, kid..k);
                let nbb = normal_matrix(basis, obs, pose, params.sigma2, kid..k, kid..k);
                let m = free.len();
                let mut nff = DMatrix::from_fn(m, m, |a, b| nbb[(free[a], free[b])]);
                for d in 0..m {
                    nff[(d, d)] += params.lambda_expression;
                }
                let naf = DMatrix::from_fn(kid, m, |a, b| nab[(a, free[b])]);
                let gf = DVector::from_fn(m, |a, _| g[kid + free[a]]);
                if let Some(ch) = nff.cholesky() {
                    // S −= N_aF·N_FF⁻¹·N_Fa ; r −= N_aF·N_FF⁻¹·g_F
                    let x = ch.solve(&naf.transpose()); // m × kid
                    s.gemm(-1.0, &naf, &x, 1.0);
                    let y = ch.solve(&gf);
                    r.gemv(-1.0, &naf, &y, 1.0);
                }
            }
            (s, r)
        })
        .collect();
    let mut s = DMatrix::identity(kid, kid) * params.lambda_identity;
    let mut r = DVector::zeros(kid);
    for (sp, rp) in &parts {
        s += sp;
        r += rp;
    }
    let a = s.cholesky()?.solve(&r);
    a.iter().all(|v| v.is_finite()).then_some(a)
}

/// Fits a group of frames that share one identity. Frames with too few usable points or a
/// degenerate camera are marked failed and left out of the identity.
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
                pose: OrthoPose { r: crate::math::Matrix3::identity(), s: 1.0, tx: 0.0, ty: 0.0 },
                beta: DVector::zeros(kexp),
                free: vec![false; kexp],
                failed,
            }
        })
        .collect();

    let pose_step = |states: &mut [FrameState], alpha: &DVector| {
        states.par_iter_mut().zip(observations.par_iter()).for_each(|(st, obs)| {
            if st.failed.is_some() {
                return;
            }
            match estimate_pose(basis, obs, &coefficients(alpha, &st.beta), image_height, params) {
                Ok(p) => st.pose = p,
                Err(e) => st.failed = Some(e),
            }
        });
    };
    let expression_step = |states: &mut Vec<FrameState>, alpha: &DVector| {
        let old: Vec<DVector> = states.iter().map(|s| s.beta.clone()).collect();
        let frame_no: Vec<usize> = observations.iter().map(|o| o.frame).collect();
        states.par_iter_mut().enumerate().for_each(|(f, st)| {
            if st.failed.is_some() {
                return;
            }
            let mut nb: Vec<&DVector> = Vec::new();
            if params.temporal_smoothness > 0.0 {
                if f > 0 && frame_no[f - 1] + 1 == frame_no[f] {
                    nb.push(&old[f - 1]);
                }
                if f + 1 < old.len() && frame_no[f] + 1 == frame_no[f + 1] {
                    nb.push(&old[f + 1]);
                }
            }
            solve_expressions(basis, &observations[f], st, alpha, &nb, image_height, params);
        });
    };

    // Start: pose from the mean shape, expressions from that pose (as eos does).
    pose_step(&mut states, &alpha);
    expression_step(&mut states, &alpha);
    for _ in 0..params.iterations {
        pose_step(&mut states, &alpha);
        if alpha_fixed.is_none() && kid > 0 {
            match solve_identity(basis, observations, &states, image_height, params) {
                Some(a) => alpha = a,
                None => break,
            }
        }
        expression_step(&mut states, &alpha);
    }
    pose_step(&mut states, &alpha);
    GroupFit { alpha, frames: states }
}
