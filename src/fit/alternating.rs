//! The alternating solver (eos's scheme, `Solver::Alternating`): pose per frame (eos's linear
//! camera); the identity jointly with the free expressions (Schur complement, the prior once
//! per clip); expressions per frame (NNLS, optional temporal smoothness); repeated until the
//! objective stops falling.
//!
//! Start with [`solve`]; `clip.rs` runs it between eos's start and the final pose step.

use super::clip::{
    FrameState, Group, SolverParams, identity_normal_matrix, identity_points, in_parallel,
};
use super::shape::{
    FrameObservations, LandmarkBasis, apply_forces, cholesky_solve_in_place, landmark_forces,
    normal_matrix,
};
use crate::math::{DMatrix, DVector, Real, Vector3};
use rayon::prelude::*;

/// Alternates pose, identity (when `solve_identity`) and expressions from the started states
/// until the objective falls by less than the tolerance or the iterations run out; returns
/// the identity, the states and the identity part of the landmark points.
pub(crate) fn solve(
    group: &Group<'_>,
    mut states: Vec<FrameState>,
    mut alpha: DVector,
    mut id_pts: Vec<Vector3>,
    solve_identity: bool,
) -> (DVector, Vec<FrameState>, Vec<Vector3>) {
    let (basis, params) = (group.basis, group.params);
    let mean_pts = basis.points_partial(&vec![0.0; basis.num_coefficients()], 0..0);
    let mut last = Real::INFINITY;
    for _ in 0..params.iterations {
        group.pose_step(&mut states, &id_pts, true);
        if solve_identity {
            let (obs, h) = (group.observations, group.image_height);
            match solve_identity_jointly(basis, obs, &states, &mean_pts, h, params) {
                Some(a) => alpha = a,
                None => break,
            }
            id_pts = identity_points(basis, &alpha);
        }
        group.expression_step(&mut states, &id_pts);
        // Stop once the objective stops falling (docs/fitting.md, "Method").
        let cost = group.objective(&states, &id_pts, &alpha, params);
        if cost.is_nan() || cost >= last * (1.0 - params.tolerance) {
            break;
        }
        last = cost;
    }
    (alpha, states, id_pts)
}

/// Identity shared by the frames, jointly with each frame's free expressions (eliminated by a
/// Schur complement); clamped expressions stay at 0. The prior λ_id·|α|² enters once.
/// The identity block of all frames is one Gram combination per set of entries the frames
/// use, with those frames' projectors summed ([`identity_normal_matrix`]).
fn solve_identity_jointly(
    basis: &LandmarkBasis,
    observations: &[FrameObservations],
    states: &[FrameState],
    mean_pts: &[Vector3],
    image_height: Real,
    params: &SolverParams,
) -> Option<DVector> {
    let (kid, k) = (basis.k_id, basis.num_coefficients());
    let grams: Vec<_> = observations.iter().map(|o| basis.used_grams(&o.active)).collect();
    let mut s = identity_normal_matrix(kid, &grams, states, params);
    let per_frame =
        |(obs, st): (&FrameObservations, &FrameState)| -> (Option<DMatrix>, DVector, Vec<Vector3>) {
            let pose = &st.pose;
            let mut corr: Option<DMatrix> = None;
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
    let parts: Vec<(Option<DMatrix>, DVector, Vec<Vector3>)> = if in_parallel(observations.len()) {
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
