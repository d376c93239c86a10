//! The fit: starting one (all frames, or only those edited since their fit) once the map can
//! support it. Its replies are handled in `replies`.

use crate::tui::app::{App, Effect};

/// Queues a fit of the frames that need one, or says why not.
pub(super) fn run_fit(app: &mut App) {
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
    if app.fit.stale.is_empty()
        && app.track.frames.iter().all(|f| app.fit.fits.contains_key(&f.frame))
    {
        app.status = "every frame is fitted and nothing changed since the last fit".into();
        return;
    }
    app.fit.generation += 1;
    let frames = if !app.fit.fits.is_empty() && !app.fit_settings.clip && !app.fit.stale.is_empty()
    {
        Some(app.fit.stale.iter().copied().collect())
    } else {
        None
    };
    let total = frames.as_ref().map_or(app.n_frames(), Vec::len);
    app.fit.stale.clear();
    app.fit.running = true;
    app.fit.progress = (0, total);
    app.fit.error = None;
    app.effects.push(Effect::Fit { generation: app.fit.generation, frames });
}
