//! Fitting a group of frames that share one identity (a clip), with pose and expression per
//! frame; a single frame is the one-frame case. This file holds what both solvers share:
//! the frame state, eos's start (linear camera on the mean shape, NNLS expressions), the pose
//! and expression steps, the objective, and [`fit_group`], which runs the solver the settings
//! name (`FitSettings::solver`) between that start and a final pose step that matches the
//! reported pose to the shape.
//!
//! The solvers: `alternating.rs` (eos's alternation) and `joint.rs` (joint Levenberg–Marquardt
//! over all unknowns).

use super::camera::{self, OrthoPose};
use super::joint::Scratch;
use super::result::Solver;
use super::shape::{
    FrameObservations, GramBlocks, LandmarkBasis, gradient_rhs, nonnegative_quadratic,
    normal_matrix, projector,
};
use super::{alternating, joint};
use crate::math::{DMatrix, DVector, Matrix3, Point3, Real, Vector3};
use rayon::prelude::*;
use std::sync::Arc;

/// Solver parameters in the units of the equations (see `FitSettings` for their meaning).
#[derive(Clone, Copy, Debug)]
pub struct SolverParams {
    pub lambda_identity: Real,
    pub lambda_expression: Real,
    pub iterations: usize,
    pub temporal_smoothness: Real,
    pub nonnegative_expressions: bool,
    pub solver: Solver,
    pub sigma2: Real,
    pub min_points: usize,
    /// Stop iterating when the objective falls by less than this fraction.
    pub tolerance: Real,
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
pub(crate) fn frame_points(
    basis: &LandmarkBasis,
    id_pts: &[Vector3],
    beta: &DVector,
) -> Vec<Vector3> {
    (0..id_pts.len()).map(|i| landmark_point(basis, id_pts, beta.as_slice(), i)).collect()
}

/// The identity block of a group's normal equations at its frames' poses,
/// `λ_id·I + Σ_f s_f²/σ²·Σⱼₖ Q_f,jk·Mⱼₖ(f)` with `Mⱼₖ(f)` = `grams[f]`, the Gram blocks of
/// the entries frame f uses ([`LandmarkBasis::used_grams`]): frames using the same entries
/// share one combination, their projectors summed first, so the cost is per entry set, not
/// per frame. Failed frames are left out. Only the lower triangle (row ≥ column) is made,
/// the part [`super::shape::cholesky_solve_in_place`] reads of the symmetric matrix; the
/// rest is zero.
pub(crate) fn identity_normal_matrix(
    kid: usize,
    grams: &[Arc<GramBlocks>],
    states: &[FrameState],
    params: &SolverParams,
) -> DMatrix {
    let mut s = DMatrix::zeros(kid, kid);
    identity_normal_matrix_into(&mut s, grams, states, params);
    s
}

/// [`identity_normal_matrix`] written over the lower triangle of `s` (k_id × k_id, reused
/// from one linearisation to the next); its strictly upper part is left as it was.
pub(crate) fn identity_normal_matrix_into(
    s: &mut DMatrix,
    grams: &[Arc<GramBlocks>],
    states: &[FrameState],
    params: &SolverParams,
) {
    let kid = s.nrows();
    let mut sets: Vec<(&Arc<GramBlocks>, Matrix3)> = Vec::new();
    for (g, st) in grams.iter().zip(states).filter(|(_, s)| s.failed.is_none()) {
        let q = projector(&st.pose) * (st.pose.s * st.pose.s / params.sigma2);
        match sets.iter_mut().find(|(h, _)| Arc::ptr_eq(h, g)) {
            Some((_, sum)) => *sum += q,
            None => sets.push((g, q)),
        }
    }
    // Column c's part on and below the diagonal is the contiguous run from s[c·k_id + c].
    let sv = s.as_mut_slice();
    for c in 0..kid {
        let col = &mut sv[c * kid + c..(c + 1) * kid];
        col.fill(0.0);
        col[0] = params.lambda_identity;
    }
    for (g, q) in &sets {
        g.add_lower(q, 1.0, kid, s);
    }
}

/// Identity part `mean + B_id·α` of every landmark point.
pub(crate) fn identity_points(basis: &LandmarkBasis, alpha: &DVector) -> Vec<Vector3> {
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
    let steps = params.solver.pose_refinement_steps();
    let pose = match previous {
        Some(p) if steps > 0 => *p,
        _ => {
            camera::estimate_orthographic_pose(&p2, &p3, image_height).map_err(|e| e.to_string())?
        }
    };
    Ok(if steps > 0 {
        camera::refine_orthographic_pose(&pose, &p2, &p3, Some(&w), image_height, steps)
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

/// Landmark `i`'s point of a frame: its identity part `id_pts[i]` plus the frame's
/// expression offsets.
#[inline]
pub(crate) fn landmark_point(
    basis: &LandmarkBasis,
    id_pts: &[Vector3],
    beta: &[Real],
    i: usize,
) -> Vector3 {
    id_pts[i] + basis.expression_offset(i, beta)
}

/// What the objective and the noise estimate are made of, summed over the unfailed frames.
#[derive(Clone, Copy, Debug, Default)]
pub(crate) struct ResidualSums {
    /// `Σ wᵢ·|x̂ᵢ − xᵢ|²` (px²) over the used landmarks.
    pub sse: Real,
    /// The weighted coordinate count `Σ 2wᵢ`.
    pub coordinates: Real,
    /// `Σ_f |β_f|²`.
    pub beta_squared: Real,
    /// 6 per frame plus its free expressions (the identity not counted).
    pub frame_unknowns: Real,
}

impl ResidualSums {
    /// The objective: weighted squared reprojection error over σ², plus the priors.
    pub fn objective(&self, alpha: &DVector, params: &SolverParams) -> Real {
        self.sse / params.sigma2
            + params.lambda_identity * alpha.norm_squared()
            + params.lambda_expression * self.beta_squared
    }

    /// One frame's sums (zero for a failed frame).
    fn of_frame(
        basis: &LandmarkBasis,
        obs: &FrameObservations,
        st: &FrameState,
        id_pts: &[Vector3],
        image_height: Real,
    ) -> Self {
        let mut out = Self::default();
        if st.failed.is_some() {
            return out;
        }
        for i in (0..basis.len()).filter(|&i| obs.active[i]) {
            let x = landmark_point(basis, id_pts, st.beta.as_slice(), i);
            let d = st.pose.project(&Point3::from(x), image_height) - obs.points[i];
            out.sse += basis.weights[i] * d.norm_squared();
            out.coordinates += 2.0 * basis.weights[i];
        }
        out.beta_squared = st.beta.norm_squared();
        out.frame_unknowns = 6.0 + st.free.iter().filter(|f| **f).count() as Real;
        out
    }

    /// The sums over a group's frames (in frame order, so the total does not depend on the
    /// number of threads).
    pub fn of_group(
        basis: &LandmarkBasis,
        observations: &[FrameObservations],
        states: &[FrameState],
        id_pts: &[Vector3],
        image_height: Real,
    ) -> Self {
        let per_frame = map_frames(states.len(), |f| {
            Self::of_frame(basis, &observations[f], &states[f], id_pts, image_height)
        });
        per_frame.iter().fold(Self::default(), |a, b| Self {
            sse: a.sse + b.sse,
            coordinates: a.coordinates + b.coordinates,
            beta_squared: a.beta_squared + b.beta_squared,
            frame_unknowns: a.frame_unknowns + b.frame_unknowns,
        })
    }
}

/// Whether work over `n` frames is worth handing to rayon: more than one frame and more than
/// one thread (on one thread the hand-off is pure overhead).
pub(crate) fn in_parallel(n: usize) -> bool {
    n > 1 && rayon::current_num_threads() > 1
}

/// `f(i)` for every frame i in 0..n, in order, computed in parallel when [`in_parallel`].
pub(crate) fn map_frames<R, F>(n: usize, f: F) -> Vec<R>
where
    R: Send,
    F: Fn(usize) -> R + Sync + Send,
{
    if in_parallel(n) { (0..n).into_par_iter().map(f).collect() } else { (0..n).map(f).collect() }
}

/// Runs `f` over frames, in parallel when [`in_parallel`].
pub(crate) fn for_each_frame<F>(states: &mut [FrameState], f: F)
where
    F: Fn(usize, &mut FrameState) + Sync + Send,
{
    if in_parallel(states.len()) {
        states.par_iter_mut().enumerate().for_each(|(i, st)| f(i, st));
    } else {
        states.iter_mut().enumerate().for_each(|(i, st)| f(i, st));
    }
}

/// A group's frames with what the steps over them need; the solvers drive it.
pub(crate) struct Group<'a> {
    pub basis: &'a LandmarkBasis,
    pub observations: &'a [FrameObservations],
    pub image_height: Real,
    pub params: &'a SolverParams,
    /// Frame numbers, for the temporal neighbours of the expression step.
    frame_no: Vec<usize>,
}

impl<'a> Group<'a> {
    pub fn new(
        basis: &'a LandmarkBasis,
        observations: &'a [FrameObservations],
        image_height: Real,
        params: &'a SolverParams,
    ) -> Self {
        let frame_no = observations.iter().map(|o| o.frame).collect();
        Self { basis, observations, image_height, params, frame_no }
    }

    /// Every unfailed frame's pose for its current landmark points (identity part `id_pts`
    /// plus its expressions); `warm` starts from the current pose (see [`estimate_pose`]).
    pub fn pose_step(&self, states: &mut [FrameState], id_pts: &[Vector3], warm: bool) {
        for_each_frame(states, |f, st| {
            if st.failed.is_some() {
                return;
            }
            let pts = frame_points(self.basis, id_pts, &st.beta);
            let prev = warm.then_some(&st.pose);
            let obs = &self.observations[f];
            match estimate_pose(self.basis, obs, &pts, self.image_height, self.params, prev) {
                Ok(p) => st.pose = p,
                Err(e) => st.failed = Some(e),
            }
        });
    }

    /// Every unfailed frame's expressions with pose and identity fixed, the temporal term
    /// pulling towards the neighbours' expressions of before this step.
    pub fn expression_step(&self, states: &mut [FrameState], id_pts: &[Vector3]) {
        let old: Vec<DVector> = if self.params.temporal_smoothness > 0.0 {
            states.iter().map(|s| s.beta.clone()).collect()
        } else {
            Vec::new()
        };
        let frame_no = &self.frame_no;
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
            let obs = &self.observations[f];
            solve_expressions(self.basis, obs, st, id_pts, &nb, self.image_height, self.params);
        });
    }

    /// [`objective`] of this group under `params` (the joint solver rescales the priors).
    pub fn objective(
        &self,
        states: &[FrameState],
        id_pts: &[Vector3],
        alpha: &DVector,
        params: &SolverParams,
    ) -> Real {
        self.residual_sums(states, id_pts).objective(alpha, params)
    }

    /// [`ResidualSums`] of this group's frames.
    pub fn residual_sums(&self, states: &[FrameState], id_pts: &[Vector3]) -> ResidualSums {
        ResidualSums::of_group(self.basis, self.observations, states, id_pts, self.image_height)
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
    fit_group_in(basis, observations, image_height, params, alpha_fixed, &mut Scratch::default())
}

/// [`fit_group`] with the joint solver's buffers kept in `scratch`, for a caller that fits
/// many groups one after the other (each frame alone).
pub fn fit_group_in(
    basis: &LandmarkBasis,
    observations: &[FrameObservations],
    image_height: Real,
    params: &SolverParams,
    alpha_fixed: Option<&DVector>,
    scratch: &mut Scratch,
) -> GroupFit {
    let (kid, kexp) = (basis.k_id, basis.k_exp);
    let alpha = alpha_fixed.cloned().unwrap_or_else(|| DVector::zeros(kid));
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
    let group = Group::new(basis, observations, image_height, params);
    // Start: pose from the mean shape, expressions from that pose (as eos does).
    let id_pts = identity_points(basis, &alpha);
    group.pose_step(&mut states, &id_pts, false);
    group.expression_step(&mut states, &id_pts);
    let solve_identity = alpha_fixed.is_none() && kid > 0;
    let (alpha, mut states, id_pts) = match params.solver {
        Solver::Alternating => alternating::solve(&group, states, alpha, id_pts, solve_identity),
        Solver::Joint { estimate_noise, .. } => {
            joint::solve(&group, states, alpha, id_pts, solve_identity, estimate_noise, scratch)
        }
    };
    group.pose_step(&mut states, &id_pts, true);
    GroupFit { alpha, frames: states }
}
