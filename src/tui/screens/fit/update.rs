//! The fit: starting one (all frames, or only those edited since their fit) once the map can
//! support it, its progress and results (only the newest request's count), and whether the
//! results reached the session's fit cache.

use crate::fit::FrameFit;
use crate::tui::app::{App, Effect};
use crate::tui::screens::analysis::update::request_analysis;

/// Queues a fit of the frames that need one, or says why not.
pub fn run_fit(app: &mut App) {
    let Some(model) = &app.model else {
        app.status = "cannot fit: the session has no model".into();
        return;
    };
    let map = app.map.clone().unwrap_or_default();
    // One message now rather than every frame failing the same way.
    if let Err(e) =
        crate::workflow::check_map_for_fit(&map, model.num_vertices(), &app.fit_settings)
    {
        app.status = format!("cannot fit: {e}; label more in the head view (2), `O` suggests");
        return;
    }
    if app.fits.stale.is_empty()
        && app.track.frames.iter().all(|f| app.fits.by_frame.contains_key(&f.frame))
    {
        app.status = "every frame is fitted and nothing changed since the last fit".into();
        return;
    }
    app.fit.generation += 1;
    let frames =
        if !app.fits.by_frame.is_empty() && !app.fit_settings.clip && !app.fits.stale.is_empty() {
            Some(app.fits.stale.iter().copied().collect())
        } else {
            None
        };
    let total = frames.as_ref().map_or(app.n_frames(), Vec::len);
    app.fits.stale.clear();
    app.fit.running = true;
    app.fit.progress = (0, total);
    app.fit.error = None;
    app.effects.push(Effect::Fit { generation: app.fit.generation, frames });
}

pub fn fit_progress(app: &mut App, generation: u64, done: usize, total: usize) {
    if generation == app.fit.generation {
        app.fit.progress = (done, total);
    }
}

/// Takes the newest fit's results; when nothing was edited since it was requested, its fits
/// match the landmarks the session holds, so they go to the session's fit cache too.
pub fn fit_done(app: &mut App, generation: u64, fits: Vec<FrameFit>) {
    if generation != app.fit.generation {
        return;
    }
    app.fit.running = false;
    app.fit.error = None;
    let n = fits.len();
    let failed = fits.iter().filter(|f| !f.is_usable()).count();
    if app.fits.stale.is_empty() {
        app.effects.push(Effect::StoreFits { fits: fits.clone() });
    }
    for f in fits {
        app.fits.by_frame.insert(f.frame, f);
    }
    app.recompute_flags();
    request_analysis(app);
    // A transferred head follows the new fit.
    app.head.heads.current = None;
    crate::tui::screens::head::transferred::request_head_frame(app);
    app.status = format!("fitted {n} frames ({failed} failed)");
}

pub fn fit_failed(app: &mut App, generation: u64, error: String) {
    if generation == app.fit.generation {
        app.fit.running = false;
        app.status = format!("fit failed: {error}");
        app.fit.error = Some(error);
    }
}

/// The cache is part of the session: autosave writes it.
pub fn fits_stored(app: &mut App) {
    app.save.change_made();
}

pub fn fits_not_stored(app: &mut App, error: String) {
    app.status = format!("fit cache not updated: {error}");
}
