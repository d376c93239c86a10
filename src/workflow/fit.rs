//! Fitting a session's clips with the fit cache: refit only what the cache cannot give.

use super::error::Result;
use super::resources::{Resources, check_map_for_fit};
use super::session::image_height;
use crate::fit::{FitSettings, FrameFit, fit_clip, fitted_shape};
use crate::landmarks::FrameLandmarks;
use crate::math::DVector;
use crate::model::MorphableModel;
use crate::session::Session;

/// What fitting one clip did.
#[derive(Clone, Debug)]
pub struct ClipFits {
    /// One fit per frame with landmarks, ascending by frame.
    pub fits: Vec<FrameFit>,
    /// How many frames were fitted now (the rest came from the cache).
    pub refitted: usize,
}

impl ClipFits {
    pub fn failed(&self) -> usize {
        self.fits.iter().filter(|f| f.failed.is_some()).count()
    }
}

/// Fits clip `clip` with `settings`, refitting only what the cache cannot give: the stale
/// frames in per-frame mode, the whole clip in clip mode (its identity is shared, so one
/// changed frame changes them all). The new fits are stored in the session's cache.
/// `progress` receives (frames done, frames to do).
///
/// # Errors
/// Unknown clip; landmarks missing for a frame the cache names; a map the fit cannot use
/// ([`check_map_for_fit`]), before anything is fitted.
pub fn fit_clip_cached(
    session: &mut Session,
    res: &Resources,
    clip: usize,
    settings: &FitSettings,
    progress: Option<&(dyn Fn(usize, usize) + Sync)>,
) -> Result<ClipFits> {
    check_map_for_fit(&res.map, res.model.num_vertices(), settings)?;
    let stale = session.stale_frames_with(clip, settings);
    let height = image_height(session, clip)?;
    let track = session.fit_input_track(clip, settings)?;
    let to_fit: Vec<FrameLandmarks> = if stale.is_empty() {
        Vec::new()
    } else if settings.clip {
        track.frames.clone()
    } else {
        let stale: std::collections::BTreeSet<usize> = stale.into_iter().collect();
        track.frames.iter().filter(|f| stale.contains(&f.frame)).cloned().collect()
    };
    let refitted = to_fit.len();
    if refitted > 0 {
        let total = refitted;
        let report = |done: usize| {
            if let Some(p) = progress {
                p(done, total);
            }
        };
        let fits = fit_clip(&res.model, &res.map, &to_fit, height, settings, Some(&report));
        session.store_fits(clip, settings, fits)?;
    }
    let fits: Vec<FrameFit> = session.cached_fits(clip, settings).into_iter().cloned().collect();
    Ok(ClipFits { fits, refitted })
}

/// Fitted model-space shapes indexed by frame number (`None` for failed or missing fits),
/// `n_frames` long. Every shape is a whole mesh: for measures use
/// [`super::measure_fits::head_trajectory`], which keeps none.
pub fn shapes_by_frame(
    model: &MorphableModel,
    fits: &[FrameFit],
    n_frames: usize,
) -> Vec<Option<DVector>> {
    let mut shapes = vec![None; n_frames];
    for f in fits.iter().filter(|f| f.failed.is_none()) {
        if f.frame < n_frames {
            shapes[f.frame] = Some(fitted_shape(model, f));
        }
    }
    shapes
}

/// `n` fits, frame f's or, where it failed or is missing, the last good one before it (the
/// first good one for leading frames); `None` without any good fit.
pub fn held_fits(fits: &[FrameFit], n: usize) -> Option<Vec<FrameFit>> {
    let mut by_frame: Vec<Option<&FrameFit>> = vec![None; n];
    for f in fits.iter().filter(|f| f.failed.is_none() && f.frame < n) {
        by_frame[f.frame] = Some(f);
    }
    let first = by_frame.iter().flatten().next().copied()?;
    let mut last = first;
    Some(
        by_frame
            .iter()
            .enumerate()
            .map(|(frame, f)| {
                last = f.unwrap_or(last);
                FrameFit { frame, ..last.clone() }
            })
            .collect(),
    )
}
