//! The fit driver: a `Fitter` holds the per-model, per-landmark-set precomputation and turns
//! landmark frames into `FrameFit`s, one frame at a time (in parallel) or a clip at once.
//!
//! Start with [`Fitter::new`] and [`Fitter::fit_frames`]; `fit::fit_frame`/`fit::fit_clip`
//! are one-call wrappers.

use super::camera::{OrthoPose, rotation_from_yaw_pitch_roll_deg};
use super::clip::{FrameState, SolverParams, fit_group};
use super::result::{FitSettings, FrameFit};
use super::shape::{EOS_SIGMA_SQUARED, FrameObservations, LandmarkBasis};
use crate::landmarks::{FrameLandmarks, N_LANDMARKS};
use crate::math::{DVector, Point2, Point3, Real};
use crate::model::{LandmarkMap, MorphableModel};
use rayon::prelude::*;

/// Frames fitted between two progress reports in per-frame mode.
const PROGRESS_CHUNK: usize = 64;

/// A fit configuration bound to one model and landmark map, reusable across frames and clips.
#[derive(Clone, Debug)]
pub struct Fitter<'m> {
    model: &'m MorphableModel,
    basis: LandmarkBasis,
    settings: FitSettings,
}

impl<'m> Fitter<'m> {
    /// Precomputes the model rows of the landmarks `settings.set` uses (those `map` maps).
    pub fn new(model: &'m MorphableModel, map: &LandmarkMap, settings: &FitSettings) -> Self {
        let basis = LandmarkBasis::new(model, map, settings.set, &settings.landmark_weights);
        Self { model, basis, settings: settings.clone() }
    }

    pub fn settings(&self) -> &FitSettings {
        &self.settings
    }

    pub fn basis(&self) -> &LandmarkBasis {
        &self.basis
    }

    fn params(&self) -> SolverParams {
        let s = &self.settings;
        SolverParams {
            lambda_identity: s.lambda,
            lambda_expression: s.lambda_expression,
            iterations: s.iterations,
            temporal_smoothness: s.temporal_smoothness,
            nonnegative_expressions: s.nonnegative_expressions,
            pose_refinement_steps: s.pose_refinement_steps,
            sigma2: EOS_SIGMA_SQUARED,
            min_points: 4,
            tolerance: s.convergence_tolerance,
        }
    }

    /// Fits one frame on its own (its own identity).
    pub fn fit_frame(&self, lm: &FrameLandmarks, image_height: Real) -> FrameFit {
        let obs = FrameObservations::new(&self.basis, lm);
        let g = fit_group(&self.basis, std::slice::from_ref(&obs), image_height, &self.params(), None);
        self.frame_fit(&obs, &g.alpha, &g.frames[0], image_height)
    }

    /// Fits frames as `settings.clip` says: one identity for all (clip) or each frame alone
    /// (in parallel). `progress` is called with the number of frames done so far.
    pub fn fit_frames(
        &self,
        frames: &[FrameLandmarks],
        image_height: Real,
        progress: Option<&dyn Fn(usize)>,
    ) -> Vec<FrameFit> {
        let report = |n: usize| {
            if let Some(p) = progress {
                p(n)
            }
        };
        if !self.settings.clip {
            let mut out = Vec::with_capacity(frames.len());
            for chunk in frames.chunks(PROGRESS_CHUNK) {
                out.par_extend(chunk.par_iter().map(|lm| self.fit_frame(lm, image_height)));
                report(out.len());
            }
            return out;
        }
        let obs: Vec<FrameObservations> =
            frames.par_iter().map(|lm| FrameObservations::new(&self.basis, lm)).collect();
        let g = fit_group(&self.basis, &obs, image_height, &self.params(), None);
        let out: Vec<FrameFit> = obs
            .par_iter()
            .zip(g.frames.par_iter())
            .map(|(o, st)| self.frame_fit(o, &g.alpha, st, image_height))
            .collect();
        report(out.len());
        out
    }

    /// Turns a solver state into the reported `FrameFit`: pose angles, residuals of the
    /// used points, reprojection RMS and the failure checks.
    fn frame_fit(
        &self,
        obs: &FrameObservations,
        alpha: &DVector,
        st: &FrameState,
        image_height: Real,
    ) -> FrameFit {
        let mut fit = FrameFit {
            frame: obs.frame,
            yaw: 0.0,
            pitch: 0.0,
            roll: 0.0,
            scale: 0.0,
            tx: 0.0,
            ty: 0.0,
            identity: vec![0.0; self.basis.k_id],
            expression: vec![0.0; self.basis.k_exp],
            reproj_rms_px: 0.0,
            residuals: vec![None; N_LANDMARKS],
            failed: st.failed.clone(),
        };
        if fit.failed.is_some() {
            return fit;
        }
        let c: Vec<Real> = alpha.iter().chain(st.beta.iter()).copied().collect();
        let mut sse = 0.0;
        let mut n = 0usize;
        for i in 0..self.basis.len() {
            if !obs.active[i] {
                continue;
            }
            let p = st.pose.project(&self.basis.point(i, &c), image_height);
            let d = p - obs.points[i];
            fit.residuals[self.basis.landmarks[i]] = Some([d.x, d.y]);
            sse += d.norm_squared();
            n += 1;
        }
        let (yaw, pitch, roll) = st.pose.yaw_pitch_roll_deg();
        let values = [yaw, pitch, roll, st.pose.s, st.pose.tx, st.pose.ty];
        let rms = (sse / n.max(1) as Real).sqrt();
        let finite = values.iter().all(|v| v.is_finite())
            && c.iter().all(|v| v.is_finite())
            && rms.is_finite();
        if !finite {
            fit.residuals = vec![None; N_LANDMARKS];
            fit.failed = Some("fit produced non-finite values".into());
            return fit;
        }
        (fit.yaw, fit.pitch, fit.roll) = (yaw, pitch, roll);
        (fit.scale, fit.tx, fit.ty) = (st.pose.s, st.pose.tx, st.pose.ty);
        fit.identity = alpha.iter().copied().collect();
        fit.expression = st.beta.iter().copied().collect();
        fit.reproj_rms_px = rms;
        if rms > self.settings.max_reproj_rms_px {
            fit.failed = Some(format!(
                "reprojection RMS {rms:.1} px above the limit {:.1} px",
                self.settings.max_reproj_rms_px
            ));
        }
        fit
    }

    /// The model this fitter was built for.
    pub fn model(&self) -> &MorphableModel {
        self.model
    }
}

/// The scaled orthographic pose a `FrameFit` reports.
pub fn pose_of(fit: &FrameFit) -> OrthoPose {
    OrthoPose {
        r: rotation_from_yaw_pitch_roll_deg(fit.yaw, fit.pitch, fit.roll),
        s: fit.scale,
        tx: fit.tx,
        ty: fit.ty,
    }
}

/// Fits one frame: pose, identity and expression from its visible landmarks.
///
/// `image_height` is in pixels (landmarks have y down). Degenerate input (fewer than 4 usable
/// points, collinear points, NaN) gives a `FrameFit` with `failed: Some(reason)`, never a panic.
/// For many frames build a [`Fitter`] once instead: it precomputes the landmark rows.
pub fn fit_frame(
    model: &MorphableModel,
    map: &LandmarkMap,
    landmarks: &FrameLandmarks,
    image_height: Real,
    settings: &FitSettings,
) -> FrameFit {
    Fitter::new(model, map, settings).fit_frame(landmarks, image_height)
}

/// Fits a clip: with `settings.clip` one identity for all frames (pose and expression per
/// frame), otherwise every frame alone in parallel. Results are in the order of `frames`.
/// `progress` receives the number of frames done.
pub fn fit_clip(
    model: &MorphableModel,
    map: &LandmarkMap,
    frames: &[FrameLandmarks],
    image_height: Real,
    settings: &FitSettings,
    progress: Option<&dyn Fn(usize)>,
) -> Vec<FrameFit> {
    Fitter::new(model, map, settings).fit_frames(frames, image_height, progress)
}

/// The fitted shape of a frame in model space (flat `x0 y0 z0 …`, length 3N), identity and
/// expressions included.
pub fn fitted_shape(model: &MorphableModel, fit: &FrameFit) -> DVector {
    model.shape_at(&fit.identity, &fit.expression)
}

/// Projects a model-space point with a frame's fitted pose to image pixels (y down).
pub fn project(fit: &FrameFit, point: Point3, image_height: Real) -> Point2 {
    pose_of(fit).project(&point, image_height)
}
