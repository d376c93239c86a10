//! The fit job: fits the frames of the clip's current track off the UI thread.

use crate::fit::{FitSettings, FrameFit};
use crate::landmarks::FrameLandmarks;
use crate::model::{LandmarkMap, MorphableModel};
use std::sync::Arc;

/// Everything a fit needs, copied so the job does not share the `App`.
pub struct FitJob {
    pub generation: u64,
    pub model: Arc<MorphableModel>,
    pub map: LandmarkMap,
    pub settings: FitSettings,
    pub frames: Vec<FrameLandmarks>,
    pub image_height: f64,
}

/// Runs the fit for the TUI: the one call into `crate::fit`, kept here so API changes stay
/// local. `progress` receives the number of frames done.
pub fn fit_for_tui(job: &FitJob, progress: &dyn Fn(usize)) -> Vec<FrameFit> {
    crate::fit::fit_clip(
        &job.model,
        &job.map,
        &job.frames,
        job.image_height,
        &job.settings,
        Some(progress),
    )
}
