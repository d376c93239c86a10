//! The fit job: fits the frames of the clip's current track off the UI thread.

use crate::fit::{FitSettings, FrameFit};
use crate::landmarks::FrameLandmarks;
use crate::model::{LandmarkMap, MorphableModel};
use crate::tui::app::App;
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

impl FitJob {
    /// The fit of `frames` (all when `None`) of the app's current track, as request
    /// `generation`; `None` without a model or a map.
    pub fn of(app: &App, generation: u64, frames: Option<&[usize]>) -> Option<Self> {
        let (model, map) = (app.model.clone()?, app.fit_map()?.clone());
        let input = app.fit_input_track();
        let frames = match frames {
            Some(list) => list.iter().filter_map(|f| input.get(*f).cloned()).collect(),
            None => input.frames,
        };
        let image_height = f64::from(app.frame_dims().1);
        let settings = app.fit_settings.clone();
        Some(Self { generation, model, map, settings, frames, image_height })
    }
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
