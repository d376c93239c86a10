//! The fit driver: a `Fitter` holds the per-model, per-landmark-set precomputation and turns
//! landmark frames into `FrameFit`s, one frame at a time (in parallel) or a clip at once.
//!
//! Start with [`Fitter::new`] and [`Fitter::fit_frames`]; `fit::fit_frame`/`fit::fit_clip`
//! are one-call wrappers.

use super::camera::{OrthoPose, rotation_from_yaw_pitch_roll_deg};
use super::clip::{
    FrameState, SolverParams, fit_group, fit_group_in, identity_points, landmark_point,
};
use super::joint::Scratch;
use super::result::{FitSettings, FrameFit, Solver};
use super::shape::{EOS_SIGMA_SQUARED, FrameObservations, LandmarkBasis};
use crate::landmarks::{FrameLandmarks, N_LANDMARKS};
use crate::math::{DVector, Point2, Point3, Real, Vector3};
use crate::model::{LandmarkMap, MorphableModel};
use rayon::prelude::*;

/// The least lip-contact precision (px) a gain is made from: two coordinates rounded to whole
/// pixels leave a gap with variance 2/12 px² whatever the tracker.
const MIN_CONTACT_SD_PX: Real = 0.408_248_290_463_863;

/// Frames fitted between two progress reports in per-frame mode.
const PROGRESS_CHUNK: usize = 64;

/// The most meeting frames whose plain fits give the data variance a contact is weighed
/// against ([`Fitter::data_variance`]): the median of 32 noise estimates is within a few
/// per cent of the median of all, and each estimate is a whole extra fit, so a long clip
/// whose lips meet in a third of its frames was fitted a third again for it.
const MAX_VARIANCE_FRAMES: usize = 32;

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
            solver: s.solver,
            sigma2: EOS_SIGMA_SQUARED,
            min_points: 4,
            tolerance: s.convergence_tolerance,
        }
    }

    /// Fits one frame on its own (its own identity).
    pub fn fit_frame(&self, lm: &FrameLandmarks, image_height: Real) -> FrameFit {
        let contact = self.contact_basis(std::slice::from_ref(lm), image_height);
        self.fit_alone(
            contact.as_ref().unwrap_or(&self.basis),
            lm,
            image_height,
            &mut Scratch::default(),
        )
    }

    /// Fits one frame on its own with `basis` (this fitter's, or its lip-contact version).
    fn fit_alone(
        &self,
        basis: &LandmarkBasis,
        lm: &FrameLandmarks,
        image_height: Real,
        scratch: &mut Scratch,
    ) -> FrameFit {
        let obs = FrameObservations::new(basis, lm);
        let frames = std::slice::from_ref(&obs);
        let g = fit_group_in(basis, frames, image_height, &self.params(), None, scratch);
        let id_pts = identity_points(basis, &g.alpha);
        self.frame_fit(basis, &obs, &g.alpha, &id_pts, &g.frames[0], image_height)
    }

    /// The basis with lip-contact entries when some of `frames` have their inner lips
    /// meeting and the contact says more than their points: gain γ = √(2σ²/σ_c²), σ² the
    /// data term's per-coordinate variance ([`Fitter::data_variance`]) and σ_c the contact
    /// precision the frames carry (their median), so that the gap of a pair in contact
    /// weighs as that precision says (`docs/closure.md`). `None` when γ ≤ 1: a gap no more
    /// precise than two independent points (σ_c² ≥ 2σ²) is weighed as those points are.
    fn contact_basis(
        &self,
        frames: &[FrameLandmarks],
        image_height: Real,
    ) -> Option<LandmarkBasis> {
        let meeting: Vec<&FrameLandmarks> = frames
            .iter()
            .filter(|f| f.lip_contact_px.is_some_and(|v| v.is_finite() && v >= 0.0))
            .collect();
        let mut sd: Vec<Real> = meeting.iter().filter_map(|f| f.lip_contact_px).collect();
        if sd.is_empty() {
            return None;
        }
        sd.sort_by(Real::total_cmp);
        let sigma_c = sd[sd.len() / 2].max(MIN_CONTACT_SD_PX);
        let gain = (2.0 * self.data_variance(&meeting, image_height) / (sigma_c * sigma_c)).sqrt();
        (gain > 1.0).then(|| self.basis.with_lip_contact(self.model, gain))
    }

    /// The data term's per-coordinate variance (px²) a lip contact is weighed against. When
    /// the solver estimates the landmark noise (empirical Bayes, the default), the data term
    /// is the tracker's own noise, not the assumed [`EOS_SIGMA_SQUARED`]: the median over
    /// `frames` (at most [`MAX_VARIANCE_FRAMES`] of them, evenly spaced) of the noise a plain
    /// fit of each leaves, SSE/(2L − p) over its L landmarks and p unknowns. Against the
    /// assumed 3 px² a tracker much more precise than that (the demo's) has its meeting gaps
    /// weighed several times its points even where the gap is no more precise than they are,
    /// and the fits follow its noise there (`docs/speech.md`).
    /// Otherwise, and when no frame has a plain fit with residual freedom,
    /// `EOS_SIGMA_SQUARED`.
    fn data_variance(&self, frames: &[&FrameLandmarks], image_height: Real) -> Real {
        if !matches!(self.settings.solver, Solver::Joint { estimate_noise: true, .. }) {
            return EOS_SIGMA_SQUARED;
        }
        let (n, m) = (frames.len(), frames.len().min(MAX_VARIANCE_FRAMES));
        let sample: Vec<&FrameLandmarks> = (0..m).map(|k| frames[k * n / m]).collect();
        let mut variances: Vec<Real> = sample
            .par_iter()
            .map_init(Scratch::default, |scratch, lm| {
                let fit = self.fit_alone(&self.basis, lm, image_height, scratch);
                let coordinates = 2.0 * fit.residuals.iter().flatten().count() as Real;
                let unknowns = 6.0 + (fit.identity.len() + fit.expression.len()) as Real;
                let sse = fit.reproj_rms_px.powi(2) * coordinates / 2.0;
                (fit.failed.is_none() && coordinates > unknowns)
                    .then(|| sse / (coordinates - unknowns))
            })
            .flatten()
            .collect();
        if variances.is_empty() {
            return EOS_SIGMA_SQUARED;
        }
        variances.sort_by(Real::total_cmp);
        variances[variances.len() / 2]
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
        let contact = self.contact_basis(frames, image_height);
        let basis = contact.as_ref().unwrap_or(&self.basis);
        if !self.settings.clip {
            let mut out = Vec::with_capacity(frames.len());
            for chunk in frames.chunks(PROGRESS_CHUNK) {
                out.par_extend(chunk.par_iter().map_init(Scratch::default, |scratch, lm| {
                    self.fit_alone(basis, lm, image_height, scratch)
                }));
                report(out.len());
            }
            return out;
        }
        let obs: Vec<FrameObservations> =
            frames.par_iter().map(|lm| FrameObservations::new(basis, lm)).collect();
        let g = fit_group(basis, &obs, image_height, &self.params(), None);
        let id_pts = identity_points(basis, &g.alpha);
        let out: Vec<FrameFit> = obs
            .par_iter()
            .zip(g.frames.par_iter())
            .map(|(o, st)| self.frame_fit(basis, o, &g.alpha, &id_pts, st, image_height))
            .collect();
        report(out.len());
        out
    }

    /// Turns a solver state into the reported `FrameFit`: pose angles, residuals of the
    /// used points, reprojection RMS and the failure checks. `id_pts` is the identity part
    /// of the landmark points for `alpha`.
    fn frame_fit(
        &self,
        basis: &LandmarkBasis,
        obs: &FrameObservations,
        alpha: &DVector,
        id_pts: &[Vector3],
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
            identity: vec![0.0; basis.k_id],
            expression: vec![0.0; basis.k_exp],
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
        // Every landmark seen, its own vertex against its own point: a pair the fit took as
        // a contact is reported like the others.
        for i in (0..basis.len()).filter(|&i| obs.seen[i]) {
            let x = landmark_point(basis, id_pts, st.beta.as_slice(), i);
            let p = st.pose.project(&Point3::from(x), image_height);
            let d = p - obs.points[i];
            fit.residuals[basis.landmarks[i]] = Some([d.x, d.y]);
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fit::camera::{rotation_angle_between_deg, rotation_from_yaw_pitch_roll_deg};
    use crate::landmarks::LandmarkPoint;
    use crate::math::{DMatrix, Matrix3};
    use crate::model::{Expressions, PcaModel};
    use proptest::prelude::*;

    /// A small face-like model: 68 vertices on a curved sheet, 4 smooth identity modes and 2
    /// expression offsets; landmark i ↦ vertex i.
    fn toy_model() -> (MorphableModel, LandmarkMap) {
        let n = N_LANDMARKS;
        let mut mean = DVector::zeros(3 * n);
        for i in 0..n {
            let (x, y) = (((i % 9) as Real - 4.0) * 15.0, ((i / 9) as Real - 3.5) * 18.0);
            mean[3 * i] = x;
            mean[3 * i + 1] = y;
            mean[3 * i + 2] = 50.0 - 0.005 * (x * x + y * y) + 4.0 * ((i * 7 % 5) as Real);
        }
        let raw = DMatrix::from_fn(3 * n, 4, |r, c| ((r * (c + 3)) as Real * 0.37).sin());
        let basis = raw.qr().q();
        let eigenvalues = DVector::from_vec(vec![9.0, 4.0, 2.0, 1.0]);
        let deltas = DMatrix::from_fn(3 * n, 2, |r, c| {
            if r % 3 == 1 { ((r + c) as Real * 0.11).cos() * 3.0 } else { 0.0 }
        });
        let model = MorphableModel {
            shape: PcaModel { mean, basis, eigenvalues },
            expressions: Some(Expressions { names: vec!["a".into(), "b".into()], deltas }),
            triangles: vec![],
        };
        let map = LandmarkMap { to_vertex: (0..n).map(|i| (i, i)).collect() };
        (model, map)
    }

    fn project_frame(model: &MorphableModel, pose: &OrthoPose, h: Real) -> FrameLandmarks {
        let pts = (0..N_LANDMARKS)
            .map(|i| {
                let p = pose.project(&model.mean_vertex(i).unwrap(), h);
                LandmarkPoint::tracked(p.x, p.y)
            })
            .collect();
        FrameLandmarks::new(0, pts)
    }

    fn assert_flagged_and_finite(fit: &FrameFit) {
        assert!(fit.failed.is_some());
        let vals = [fit.yaw, fit.pitch, fit.roll, fit.scale, fit.tx, fit.ty, fit.reproj_rms_px];
        assert!(vals.iter().all(|v| v.is_finite()));
        assert!(fit.identity.iter().chain(&fit.expression).all(|v| v.is_finite()));
    }

    #[test]
    fn degenerate_frames_are_flagged_not_panics() {
        let (model, map) = toy_model();
        let s = FitSettings::default();
        let pose = OrthoPose {
            r: rotation_from_yaw_pitch_roll_deg(10.0, 5.0, 0.0),
            s: 2.0,
            tx: 300.0,
            ty: 200.0,
        };
        let good = project_frame(&model, &pose, 720.0);
        // Too few visible points.
        let mut few = good.clone();
        few.points.iter_mut().skip(3).for_each(|p| p.visible = false);
        assert_flagged_and_finite(&fit_frame(&model, &map, &few, 720.0, &s));
        // NaN and infinite coordinates everywhere.
        let mut nan = good.clone();
        nan.points.iter_mut().for_each(|p| p.x = Real::NAN);
        assert_flagged_and_finite(&fit_frame(&model, &map, &nan, 720.0, &s));
        let mut inf = good.clone();
        inf.points.iter_mut().for_each(|p| p.y = Real::INFINITY);
        assert_flagged_and_finite(&fit_frame(&model, &map, &inf, 720.0, &s));
        // All points at one pixel (zero scale) and on one line (collinear).
        let mut same = good.clone();
        same.points.iter_mut().for_each(|p| (p.x, p.y) = (100.0, 100.0));
        assert_flagged_and_finite(&fit_frame(&model, &map, &same, 720.0, &s));
        let mut line = good.clone();
        line.points
            .iter_mut()
            .enumerate()
            .for_each(|(i, p)| (p.x, p.y) = (i as Real, 2.0 * i as Real));
        let fit = fit_frame(&model, &map, &line, 720.0, &s);
        assert!(fit.reproj_rms_px.is_finite() && fit.scale.is_finite());
        // A clip mixing bad and good frames still fits the good ones.
        let fits = fit_clip(
            &model,
            &map,
            &[few, good.clone()],
            720.0,
            &FitSettings { clip: true, ..s.clone() },
            None,
        );
        assert!(fits[0].failed.is_some() && fits[1].failed.is_none());
        // Residuals: 68 entries, Some exactly for used points.
        assert_eq!(fits[1].residuals.len(), N_LANDMARKS);
        assert!(fits[1].residuals.iter().all(|r| r.is_some()));
    }

    #[test]
    fn residual_limit_flags_the_frame() {
        let (model, map) = toy_model();
        let pose = OrthoPose {
            r: rotation_from_yaw_pitch_roll_deg(0.0, 0.0, 0.0),
            s: 2.0,
            tx: 300.0,
            ty: 200.0,
        };
        let mut lm = project_frame(&model, &pose, 720.0);
        for (i, p) in lm.points.iter_mut().enumerate() {
            p.x += if i % 2 == 0 { 40.0 } else { -40.0 };
        }
        let s = FitSettings { max_reproj_rms_px: 5.0, ..FitSettings::default() };
        let fit = fit_frame(&model, &map, &lm, 720.0, &s);
        assert!(
            fit.failed.as_deref().is_some_and(|f| f.contains("reprojection")),
            "{:?}",
            fit.failed
        );
    }

    /// The projected gap of an inner-lip pair in a fit: both points are observed at one
    /// place, so the gap is the difference of their residuals.
    fn fitted_gap(fit: &FrameFit, upper: usize, lower: usize) -> Real {
        let (u, l) = (fit.residuals[upper].unwrap(), fit.residuals[lower].unwrap());
        ((u[0] - l[0]).powi(2) + (u[1] - l[1]).powi(2)).sqrt()
    }

    #[test]
    fn lip_contact_entries_keep_the_midpoint_and_scale_the_gap() {
        let (model, map) = toy_model();
        let plain = LandmarkBasis::new(&model, &map, crate::landmarks::LandmarkSet::F5, &[]);
        let contact = plain.with_lip_contact(&model, 3.0);
        assert_eq!(contact.len(), plain.len() + 6);
        let c = vec![0.3, -0.2, 0.1, 0.4, 0.5, 0.2];
        let at = |b: &LandmarkBasis, l: usize, side: Option<Real>| {
            let i = (0..b.len())
                .find(|&i| b.landmarks[i] == l && b.contact[i].map(|c| c.side) == side)
                .unwrap();
            b.point(i, &c).coords
        };
        for (u, l) in crate::landmarks::closure::INNER_LIP_PAIRS {
            let (pu, pl) = (at(&plain, u, None), at(&plain, l, None));
            let (a, b) = (at(&contact, u, Some(1.0)), at(&contact, l, Some(-1.0)));
            assert!(((a + b) / 2.0 - (pu + pl) / 2.0).norm() < 1e-9);
            assert!(((a - b) - 3.0 * (pu - pl)).norm() < 1e-9);
        }
        // A frame whose lips meet uses the contact entries instead of the pair's, and still
        // sees the pair; one whose lips do not uses neither contact entry.
        let pose = OrthoPose { r: Matrix3::identity(), s: 2.0, tx: 300.0, ty: 200.0 };
        let mut lm = project_frame(&model, &pose, 720.0);
        let open = FrameObservations::new(&contact, &lm);
        lm.lip_contact_px = Some(0.5);
        let meet = FrameObservations::new(&contact, &lm);
        for i in 0..contact.len() {
            let paired = crate::landmarks::closure::INNER_LIP_PAIRS
                .iter()
                .any(|&(u, l)| contact.landmarks[i] == u || contact.landmarks[i] == l);
            match contact.contact[i] {
                None => {
                    assert!(open.active[i] && meet.seen[i]);
                    assert_eq!(meet.active[i], !paired, "landmark {}", contact.landmarks[i]);
                }
                Some(c) => {
                    assert!(!open.active[i] && meet.active[i] && !meet.seen[i]);
                    // Lips in contact have no gap: both sides are observed at the tracked
                    // pair's midpoint, however far apart the tracker put the pair.
                    let (u, l) = (lm.points[c.upper].pos(), lm.points[c.lower].pos());
                    assert!((u - l).norm() > 1.0);
                    assert!((meet.points[i] - nalgebra::center(&u, &l)).norm() < 1e-9);
                }
            }
        }
        assert_eq!(open.num_active, meet.num_active);
    }

    #[test]
    fn a_lip_contact_closes_the_fitted_gap_that_the_other_points_hold_open() {
        // The toy model's inner-lip pairs lie far apart; the tracked pairs are moved to
        // their midpoints (sealed), so the rest of the points and the pair disagree.
        let (model, map) = toy_model();
        let pose = OrthoPose { r: Matrix3::identity(), s: 2.0, tx: 300.0, ty: 200.0 };
        let mut lm = project_frame(&model, &pose, 720.0);
        crate::landmarks::closure::close_inner_lips(&mut lm);
        // The toy's pairs are tens of pixels apart: the fit cannot follow, which is the point.
        let settings = FitSettings { max_reproj_rms_px: 1e6, ..FitSettings::default() };
        let alone = fit_frame(&model, &map, &lm, 720.0, &settings);
        lm.lip_contact_px = Some(0.5);
        let contact = fit_frame(&model, &map, &lm, 720.0, &settings);
        assert!(alone.failed.is_none() && contact.failed.is_none(), "{:?}", contact.failed);
        // The toy's few components close about half of each gap (62/66: 150 → 76 px); the
        // contact must take at least 40 % of the pairs' total away and shrink every pair.
        let (mut before, mut after) = (0.0, 0.0);
        for (u, l) in crate::landmarks::closure::INNER_LIP_PAIRS {
            let (b, a) = (fitted_gap(&alone, u, l), fitted_gap(&contact, u, l));
            assert!(a < b, "pair {u}/{l}: {b:.2} → {a:.2} px");
            (before, after) = (before + b, after + a);
        }
        assert!(after < 0.6 * before, "inner-lip gaps {before:.2} → {after:.2} px in all");
        // Every landmark's own residual is reported, the pairs' included.
        assert!(contact.residuals.iter().all(|r| r.is_some()));
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(24))]
        #[test]
        fn fit_recovers_a_random_pose(yaw in -35.0..35.0f64, pitch in -20.0..20.0f64, roll in -20.0..20.0f64,
                                      s in 0.8..3.0f64, tx in 150.0..350.0f64, ty in 120.0..250.0f64,
                                      clip in any::<bool>()) {
            let (model, map) = toy_model();
            let pose = OrthoPose { r: rotation_from_yaw_pitch_roll_deg(yaw, pitch, roll), s, tx, ty };
            let lm = project_frame(&model, &pose, 720.0);
            let settings = FitSettings { clip, ..FitSettings::default() };
            let fits = fit_clip(&model, &map, std::slice::from_ref(&lm), 720.0, &settings, None);
            let fit = &fits[0];
            prop_assert!(fit.failed.is_none(), "{:?}", fit.failed);
            let est = pose_of(fit);
            prop_assert!(rotation_angle_between_deg(&est.r, &pose.r) < 0.05);
            prop_assert!((fit.scale / s - 1.0).abs() < 1e-3);
            prop_assert!(fit.reproj_rms_px < 0.05);
            let p = project(fit, Point3::new(10.0, -5.0, 40.0), 720.0);
            let q = pose.project(&Point3::new(10.0, -5.0, 40.0), 720.0);
            prop_assert!((p - q).norm() < 0.5);
        }
    }
}
