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
    let map = app.fit_map().cloned().unwrap_or_default();
    // The CLI's rule, so the TUI refuses and asks exactly where `lipmap fit` does. Asked
    // once per list of problems: `f` again with the same list is the user's yes.
    let asked = std::mem::take(&mut app.fit.map_problems);
    match crate::workflow::check_before_fit(model, &map, &app.fit_settings, false) {
        Ok(_) => {}
        Err(crate::workflow::FitRefusal::Implausible { problems }) if problems == asked => {}
        Err(crate::workflow::FitRefusal::Implausible { problems }) => {
            app.status = format!(
                "the model map fails the anatomy check ({} problems, listed in the fit view 3): \
                 press f again to fit anyway (as `lipmap fit --accept-map-warnings`), or fix \
                 the map in the head view (2)",
                problems.len()
            );
            app.fit.map_problems = problems;
            return;
        }
        Err(e) => {
            app.status = cannot_fit_message(&e, app.head.label_role);
            return;
        }
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

/// Why `f` cannot fit yet and what to do here, in the TUI: the model map (what a fit uses)
/// is labelled in the head view, where `m` switches to it while the head's own map is shown.
fn cannot_fit_message(
    e: &crate::workflow::FitRefusal,
    labelling: crate::session::MapRole,
) -> String {
    use crate::session::MapRole;
    use crate::workflow::{FitRefusal, MapCheckError, NO_MAP_MESSAGE};
    let label = match labelling {
        MapRole::Model => "label it in the head view (2), `O` suggests from 4-6 labels",
        MapRole::Head => "press m in the head view (2) to label it",
    };
    match e {
        FitRefusal::Unusable(MapCheckError::Empty) => format!(
            "cannot fit: {NO_MAP_MESSAGE}: {label}, or `lipmap import SESSION --mapping FILE`"
        ),
        e => format!("cannot fit: {e}; model map: {label}"),
    }
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tui::fixtures::synthetic_app;
    use std::sync::Arc;

    /// The SFM model with the eyes' and the outer mouth's vertices exchanged in its map: the
    /// TUI refuses, lists the problems `lipmap fit` lists, and fits when asked again.
    #[test]
    fn a_swapped_map_is_listed_and_asked_about_before_the_tui_fits() {
        let Some(eos) = crate::testdata::shared("peer/eos/share") else { return };
        let model =
            crate::io::model_source::load_model(&eos.join("sfm_shape_3448.bin"), None).unwrap();
        let sfm =
            crate::io::landmark_map_toml::read_landmark_map(&eos.join("ibug_to_sfm.txt")).unwrap();
        let mut bad = sfm.clone();
        for k in 0..12 {
            if let (Some(a), Some(b)) = (sfm.vertex(36 + k), sfm.vertex(48 + k)) {
                bad.to_vertex.insert(36 + k, b);
                bad.to_vertex.insert(48 + k, a);
            }
        }
        let cli = crate::workflow::check_before_fit(&model, &bad, &Default::default(), false);
        let Err(crate::workflow::FitRefusal::Implausible { problems }) = cli else {
            panic!("the CLI's rule must refuse the swapped map")
        };
        let mut app = synthetic_app(3, 64, 48, false);
        app.model = Some(Arc::new(model));
        app.map = Some(bad);
        run_fit(&mut app);
        assert!(!app.effects.iter().any(|e| matches!(e, Effect::Fit { .. })), "no fit started");
        assert_eq!(app.fit.map_problems, problems, "the same list as `lipmap fit`");
        assert!(app.status.contains("f again"), "{}", app.status);
        run_fit(&mut app);
        assert!(app.effects.iter().any(|e| matches!(e, Effect::Fit { .. })), "asked, then fitted");
        // The good map fits without a question.
        let mut app2 = synthetic_app(3, 64, 48, false);
        app2.model = app.model.clone();
        app2.map = Some(sfm);
        run_fit(&mut app2);
        assert!(app2.effects.iter().any(|e| matches!(e, Effect::Fit { .. })));
        assert!(app2.fit.map_problems.is_empty());
    }
}
