//! What a fit is asked to do (`FitSettings`, stored in sessions and used as the cache key)
//! and what it reports per frame (`FrameFit`).

use crate::landmarks::LandmarkSet;
use crate::landmarks::closure::Closure;
use serde::{Deserialize, Serialize};

/// Every setting that changes a fit's result. Two fits with equal settings on equal input
/// give equal results, so sessions key their cached fits by this.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FitSettings {
    /// Which landmarks drive the fit.
    pub set: LandmarkSet,
    /// Shape prior weight λ (see `fit::shape`); the default is chosen by measurement.
    pub lambda: f64,
    /// Expression prior weight.
    pub lambda_expression: f64,
    /// Camera/shape alternations.
    pub iterations: usize,
    /// One identity shared by all frames of a clip.
    pub clip: bool,
    /// Weight of the temporal smoothness term on per-frame coefficients (clip fits).
    pub temporal_smoothness: f64,
    /// A frame whose reprojection RMS exceeds this (pixels) is flagged failed.
    pub max_reproj_rms_px: f64,
    /// Per-landmark weights indexed by 0-based iBUG id (empty or missing entries = 1; a
    /// weight of 0 leaves the point out).
    #[serde(default)]
    pub landmark_weights: Vec<f64>,
    /// Constrain expression coefficients to β ≥ 0 (blendshapes are one-sided offsets).
    #[serde(default = "default_true")]
    pub nonnegative_expressions: bool,
    /// Which solver runs and its own parameters. Stored as `"solver": {"kind": …}`; files
    /// from before the setting existed chose it by `pose_refinement_steps` (0 = alternating)
    /// and still load as they did (see [`Solver`]).
    #[serde(flatten, with = "solver_field")]
    pub solver: Solver,
    /// Iterations stop early when the fit's objective falls by less than this fraction.
    #[serde(default = "default_convergence_tolerance")]
    pub convergence_tolerance: f64,
    /// Whether the inner lips are closed on the frames in the clip's sealed mode before
    /// fitting and measuring (`landmarks::closure`); files without it get the default.
    #[serde(default, skip_serializing_if = "Closure::is_default")]
    pub closure: Closure,
}

/// How a group of frames (a clip, or one frame alone) is solved; `docs/fitting.md` compares
/// them.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Solver {
    /// eos's scheme: linear camera per frame, then the identity (jointly with the free
    /// expressions), then expressions per frame (NNLS), alternated (`fit::alternating`).
    Alternating,
    /// From eos's linear start, joint Levenberg–Marquardt steps over every pose, the free
    /// expressions and the identity, each followed by an NNLS pass on the expressions
    /// (`fit::joint`).
    Joint {
        /// Gauss–Newton steps refining each camera estimate (0 = eos's linear camera only).
        pose_refinement_steps: usize,
        /// Scale `lambda` and `lambda_expression` by the landmark noise estimated from the
        /// residuals over the 3 px the defaults assume (empirical Bayes; clip fits with
        /// enough residual degrees of freedom only).
        estimate_noise: bool,
    },
}

impl Default for Solver {
    fn default() -> Self {
        Self::Joint { pose_refinement_steps: 1, estimate_noise: true }
    }
}

impl Solver {
    /// Gauss–Newton steps refining each camera estimate (none for the alternation).
    pub fn pose_refinement_steps(&self) -> usize {
        match self {
            Self::Alternating => 0,
            Self::Joint { pose_refinement_steps, .. } => *pose_refinement_steps,
        }
    }
}

/// `FitSettings::solver` in files: written as `"solver"`, read from it or, in files that
/// predate it, from `pose_refinement_steps` and `estimate_noise` (their defaults 1 and true).
mod solver_field {
    use super::Solver;
    use serde::{Deserialize, Deserializer, Serialize, Serializer};

    #[derive(Serialize)]
    struct Written<'a> {
        solver: &'a Solver,
    }

    #[derive(Deserialize)]
    struct Read {
        solver: Option<Solver>,
        pose_refinement_steps: Option<usize>,
        estimate_noise: Option<bool>,
    }

    pub fn serialize<S: Serializer>(solver: &Solver, s: S) -> Result<S::Ok, S::Error> {
        Written { solver }.serialize(s)
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Solver, D::Error> {
        let r = Read::deserialize(d)?;
        Ok(match (r.solver, r.pose_refinement_steps) {
            (Some(solver), _) => solver,
            (None, Some(0)) => Solver::Alternating,
            (None, steps) => Solver::Joint {
                pose_refinement_steps: steps.unwrap_or(1),
                estimate_noise: r.estimate_noise.unwrap_or(true),
            },
        })
    }
}

fn default_convergence_tolerance() -> f64 {
    FitSettings::default().convergence_tolerance
}

fn default_true() -> bool {
    true
}

impl Default for FitSettings {
    fn default() -> Self {
        Self {
            // Every mapped landmark (unmapped jaw points are ignored anyway); docs/fitting.md.
            set: LandmarkSet::F5,
            // λ = σ²/3 for an assumed landmark error σ = 3 px (eos: 30, i.e. σ ≈ 9.5 px).
            lambda: 3.0,
            // Same unit-variance prior and noise as the identity, so the same weight.
            lambda_expression: 3.0,
            // The camera/shape alternation converges slowly along the pose–identity valley.
            iterations: 15,
            clip: false,
            temporal_smoothness: 0.0,
            max_reproj_rms_px: 20.0,
            landmark_weights: Vec::new(),
            nonnegative_expressions: true,
            solver: Solver::default(),
            convergence_tolerance: 1e-3,
            closure: Closure::default(),
        }
    }
}

/// The result of fitting one frame. Angles in degrees with R = Ry(yaw)·Rx(pitch)·Rz(roll);
/// projection `u = s·(r1·X + tx)`, `v = H − s·(r2·X + ty)`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameFit {
    pub frame: usize,
    pub yaw: f64,
    pub pitch: f64,
    pub roll: f64,
    pub scale: f64,
    pub tx: f64,
    pub ty: f64,
    /// Identity (shape PCA) coefficients α.
    pub identity: Vec<f64>,
    /// Expression coefficients β (empty when the model has none).
    pub expression: Vec<f64>,
    /// RMS distance in pixels between the fitted projection and the used landmarks.
    pub reproj_rms_px: f64,
    /// Per iBUG point (68 entries): fitted − observed in pixels, `None` when unused.
    pub residuals: Vec<Option<[f64; 2]>>,
    /// Why the frame failed, when it did.
    pub failed: Option<String>,
}

impl FrameFit {
    /// Whether the fit can be measured, shown or learnt from: it did not fail. A failed fit
    /// stays in the results (its frame and reason are reported) but its shape means nothing.
    pub fn is_usable(&self) -> bool {
        self.failed.is_none()
    }

    /// [`is_usable`](Self::is_usable) for a frame of a clip of `n` frames: fits naming a
    /// frame at or past the clip's end (a cache from a longer clip, a hand-edited session)
    /// are not frames of it.
    pub fn is_usable_within(&self, n: usize) -> bool {
        self.is_usable() && self.frame < n
    }

    /// Frame `frame` seen head-on at unit scale, with no coefficients, residuals or
    /// failure: the value to fill in field by field.
    pub fn unposed(frame: usize) -> Self {
        Self {
            frame,
            yaw: 0.0,
            pitch: 0.0,
            roll: 0.0,
            scale: 1.0,
            tx: 0.0,
            ty: 0.0,
            identity: Vec::new(),
            expression: Vec::new(),
            reproj_rms_px: 0.0,
            residuals: Vec::new(),
            failed: None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn solver_round_trips_and_old_keys_choose_it() {
        for solver in
            [Solver::Alternating, Solver::Joint { pose_refinement_steps: 2, estimate_noise: false }]
        {
            let s = FitSettings { solver, ..FitSettings::default() };
            let text = serde_json::to_string(&s).unwrap();
            assert!(text.contains(r#""solver":{"kind":"#), "{text}");
            assert_eq!(serde_json::from_str::<FitSettings>(&text).unwrap(), s);
        }
        let with_old_keys = |extra: &str| {
            let mut v = serde_json::to_value(FitSettings::default()).unwrap();
            let m = v.as_object_mut().unwrap();
            m.remove("solver");
            let old: serde_json::Value = serde_json::from_str(extra).unwrap();
            m.extend(old.as_object().unwrap().clone());
            serde_json::from_value::<FitSettings>(v).unwrap().solver
        };
        assert_eq!(with_old_keys(r#"{"pose_refinement_steps": 0}"#), Solver::Alternating);
        assert_eq!(
            with_old_keys(r#"{"pose_refinement_steps": 0, "estimate_noise": true}"#),
            Solver::Alternating
        );
        assert_eq!(
            with_old_keys(r#"{"pose_refinement_steps": 4, "estimate_noise": false}"#),
            Solver::Joint { pose_refinement_steps: 4, estimate_noise: false }
        );
        assert_eq!(with_old_keys("{}"), Solver::default());
        assert_eq!(Solver::Alternating.pose_refinement_steps(), 0);
    }
}
