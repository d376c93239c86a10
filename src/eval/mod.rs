//! Evaluation of how faithfully a head's lips follow the video: RMSE per sentence, phoneme and
//! viseme class, correlation and normalised MSE, worst frames, configuration comparisons with
//! paired t-tests, and the generic [`report::Table`] every front end renders.
//!
//! Start with an [`Utterance`] per sentence (alignment, fps, video and head trajectories),
//! then [`rmse::sentence_rmse`], [`rmse::phoneme_rmse`], [`rmse::viseme_rmse`],
//! [`compare::compare_configurations`] and the table builders in [`report`]; [`Tally`] builds
//! the same tables one sentence at a time, for corpora too large to hold.

pub mod compare;
pub mod report;
pub mod rmse;
pub mod seal;
pub mod stats;
pub mod tally;
pub mod visemes;
pub mod worst;

use crate::alignment::Alignment;
use crate::measure::{Measure, Trajectory};
use serde::{Deserialize, Serialize};

pub use compare::{Comparison, Configuration, RowKey, compare_configurations};
pub use report::{Cell, Table};
pub use rmse::{GroupRmse, phoneme_rmse, sentence_rmse, viseme_rmse};
pub use stats::{TTest, normalised_mse, paired_t_test, pearson};
pub use tally::Tally;
pub use visemes::VisemeTable;
pub use worst::{WorstFit, WorstFrame, worst_frames_by_error, worst_frames_by_residual};

/// One sentence's evaluation input: its phone alignment, frame rate, the video's measured
/// trajectory (the reference) and the head's (the estimate), both indexed by the same
/// 0-based frame numbers (frame k at time k / fps).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Utterance {
    /// Sentence name (row label in tables), e.g. `bbaf2n`.
    pub name: String,
    /// Speaker, for tables whose rows are speakers; `None` groups as `?`.
    #[serde(default)]
    pub speaker: Option<String>,
    pub alignment: Alignment,
    /// Video frames per second (> 0).
    pub fps: f64,
    /// Measures from the video landmarks (the reference).
    pub video: Trajectory,
    /// Measures from the fitted 3D head (the estimate).
    pub head: Trajectory,
}

impl Utterance {
    /// The same utterance with video and head min–max normalised separately, per measure,
    /// as the published method compares them (trajectory shapes, not amplitudes).
    pub fn min_max_normalised(&self) -> Self {
        Self {
            video: self.video.min_max_normalised(),
            head: self.head.min_max_normalised(),
            ..self.clone()
        }
    }
}

/// One value per measure (W, H, P); `None` where it could not be computed.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct PerMeasure {
    pub w: Option<f64>,
    pub h: Option<f64>,
    pub p: Option<f64>,
}

impl PerMeasure {
    /// Builds from a function of the measure.
    pub fn from_fn(mut f: impl FnMut(Measure) -> Option<f64>) -> Self {
        Self { w: f(Measure::W), h: f(Measure::H), p: f(Measure::P) }
    }

    /// The value of one measure.
    pub fn get(&self, m: Measure) -> Option<f64> {
        match m {
            Measure::W => self.w,
            Measure::H => self.h,
            Measure::P => self.p,
        }
    }
}

/// The finite mean of the present values, `None` when there are none.
pub(crate) fn mean_of(values: impl IntoIterator<Item = Option<f64>>) -> Option<f64> {
    let (sum, n) = values
        .into_iter()
        .flatten()
        .filter(|v| v.is_finite())
        .fold((0.0, 0usize), |(s, n), v| (s + v, n + 1));
    (n > 0).then(|| sum / n as f64)
}
