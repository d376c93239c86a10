//! Fitting a session's clips with the fit cache: refit only what the cache cannot give.
//!
//! Start with [`fit_session`] (what `lipmap fit SESSION` does) or, for a use case that fits
//! on its way to something else, [`fit_clip_cached`].

use super::error::{Progress, ProgressFn, Result, Warning};
use super::flags::clip_flag_lines;
use super::resources::{Resources, check_map_for_fit, load_resources};
use super::session::{EditSession, image_height, select_clips};
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
        self.fits.iter().filter(|f| !f.is_usable()).count()
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

/// One clip of a session, fitted.
#[derive(Clone, Debug)]
pub struct ClipFitted {
    pub name: String,
    pub fits: ClipFits,
    /// The clip's flags as lines: a count, then one line per flagged frame
    /// ([`super::flags::flag_lines`]).
    pub flag_lines: Vec<String>,
}

/// What fitting a session did.
#[derive(Clone, Debug, Default)]
pub struct SessionFitted {
    pub clips: Vec<ClipFitted>,
    pub warnings: Vec<Warning>,
}

impl SessionFitted {
    /// Whether any frame of any clip failed.
    pub fn any_failed(&self) -> bool {
        self.clips.iter().any(|c| c.fits.failed() > 0)
    }
}

/// Fits the clips of an opened session (the one called `only`, or all) with `settings`,
/// which become the session's fit settings, then saves the session with the new fits.
/// Progress: a stage per clip, then its frames.
///
/// # Errors
/// As [`load_resources`], [`select_clips`] and [`fit_clip_cached`]; the save's error.
pub fn fit_session(
    opened: &mut EditSession,
    settings: &FitSettings,
    only: Option<&str>,
    progress: ProgressFn<'_>,
) -> Result<SessionFitted> {
    let session = &mut opened.session;
    session.fit_settings = settings.clone();
    let (res, warnings) = load_resources(session, &opened.path)?;
    let mut out = SessionFitted { clips: Vec::new(), warnings };
    for c in select_clips(session, only)? {
        let name = session.clip(c)?.name.clone();
        progress(Progress::Stage { what: format!("fitting {name}"), total: 0 });
        let steps = |done: usize, total: usize| progress(Progress::Steps { done, total });
        let fits = fit_clip_cached(session, &res, c, settings, Some(&steps))?;
        let flag_lines = clip_flag_lines(session, c, &fits.fits)?;
        out.clips.push(ClipFitted { name, fits, flag_lines });
    }
    progress(Progress::Finished);
    opened.save()?;
    Ok(out)
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
    for f in fits.iter().filter(|f| f.is_usable_within(n_frames)) {
        shapes[f.frame] = Some(fitted_shape(model, f));
    }
    shapes
}
