//! Replies from the workers and the run loop: decoded frames, fit progress and results,
//! analysis tables, the side view, a loaded map, and how saving went. Only replies to the
//! newest request (by generation) change what they answer.

use super::edits::relabel;
use super::global::{request_images, request_save};
use crate::tui::action::Action;
use crate::tui::app::{App, Effect, SideState, SideView};
use crate::tui::save_state::AfterSave;

/// Applies an action of this file (routed here by `update`).
pub(super) fn update(app: &mut App, action: Action) {
    use Action as A;
    match action {
        A::FrameLoaded { frame, image } => {
            app.image_size = Some((image.width, image.height));
            app.image_errors.remove(&frame);
            app.cache_image(frame, image);
        }
        A::FrameFailed { frame, error } => {
            app.image_errors.insert(frame, error);
        }
        A::FitProgress { generation, done, total } if generation == app.fit.generation => {
            app.fit.progress = (done, total);
        }
        A::FitDone { generation, fits } if generation == app.fit.generation => {
            fit_done(app, fits);
        }
        A::FitFailed { generation, error } if generation == app.fit.generation => {
            app.fit.running = false;
            app.status = format!("fit failed: {error}");
            app.fit.error = Some(error);
        }
        // The cache is part of the session: autosave writes it.
        A::FitsStored => app.save.change_made(),
        A::FitsNotStored { error } => app.status = format!("fit cache not updated: {error}"),
        A::AnalysisReady { generation, data } if generation == app.analysis_generation => {
            if let Some(w) = data.warnings.first() {
                app.status.clone_from(w);
            }
            let (own_before, own) =
                (app.analysis.tables.len().saturating_sub(app.quality.len()), data.tables.len());
            app.analysis = data;
            app.analysis.tables.extend(app.quality.iter().cloned());
            // Still where the previous clip left it (the user has not moved): keep the cursor
            // on the same quality table behind the new own tables.
            if let Some(v) = app.quality_view.take()
                && app.analysis_view.table == own_before + v.table
            {
                app.analysis_view.table = own + v.table;
            }
            let n = app.analysis.tables.len().max(1);
            app.analysis_view.table = app.analysis_view.table.min(n - 1);
        }
        A::SideReady { side } => {
            let failed = side.track.automatic.iter().filter(|p| p.failed.is_some()).count();
            app.status = format!(
                "side view measured: {} frames ({failed} failed)",
                side.track.automatic.len()
            );
            app.side = SideState::Ready(side);
            request_images(app);
            app.request_analysis();
        }
        A::SideFailed { error } => {
            app.status = format!("side view: {error}");
            app.side = SideState::Failed(error);
        }
        A::SideFrameLoaded { frame, image } => {
            if let Some(side) = app.side.view_mut() {
                side.image_errors.remove(&frame);
                side.images.insert(frame, image);
                // Keep the frames nearest the one just decoded (the one being looked at).
                while side.images.len() > SideView::CACHE {
                    let far = side.images.keys().copied().max_by_key(|k| k.abs_diff(frame));
                    if let Some(far) = far {
                        side.images.remove(&far);
                    }
                }
            }
        }
        A::SideFrameFailed { frame, error } => {
            if let Some(side) = app.side.view_mut() {
                side.image_errors.insert(frame, error);
            }
        }
        A::MapLoaded { map, path } => {
            let mut labels: Vec<(usize, Option<usize>)> =
                map.to_vertex.iter().map(|(&l, &v)| (l, Some(v))).collect();
            if let Some(old) = &app.map {
                labels.extend(
                    old.to_vertex.keys().filter(|l| map.vertex(**l).is_none()).map(|&l| (l, None)),
                );
            }
            let n = relabel(app, labels);
            app.status =
                format!("{} landmarks from {path} ({n} labels changed; u undoes)", map.len());
        }
        A::Saved { generation } => {
            let (newest, next) = app.save.saved(generation);
            if newest {
                // The tables follow the corrections (the head's side uses the fits as they
                // are until the next fit).
                app.request_analysis();
            }
            // The status line's right side shows the save state; keep the message.
            match next {
                AfterSave::Leave => app.effects.push(Effect::Quit),
                AfterSave::SaveAgain => request_save(app),
                AfterSave::Nothing => {}
            }
        }
        A::SaveFailed { error } => {
            app.save.save_failed();
            app.switch_clip = None;
            app.status = if app.save.force_quit_armed() {
                format!(
                    "save failed: {error} (q again quits without saving; the edits stay in the \
                     session's journal and are restored when it is opened again)"
                )
            } else {
                format!("save failed: {error} (s retries; q retries, then quits)")
            };
        }
        A::Status(s) => app.status = s,
        _ => {}
    }
}

/// Takes the newest fit's results; when nothing was edited since it was requested, its fits
/// match the landmarks the session holds, so they go to the session's fit cache too.
fn fit_done(app: &mut App, fits: Vec<crate::fit::FrameFit>) {
    app.fit.running = false;
    app.fit.error = None;
    let n = fits.len();
    let failed = fits.iter().filter(|f| !f.is_usable()).count();
    if app.fit.stale.is_empty() {
        app.effects.push(Effect::StoreFits { fits: fits.clone() });
    }
    for f in fits {
        app.fit.fits.insert(f.frame, f);
    }
    app.recompute_flags();
    app.request_analysis();
    // A transferred head follows the new fit.
    app.heads.current = None;
    super::transferred::request_head_frame(app);
    app.status = format!("fitted {n} frames ({failed} failed)");
}

#[cfg(test)]
mod tests {
    use crate::tui::action::Action;
    use crate::tui::fixtures::{synthetic_analysis, synthetic_app};

    #[test]
    fn an_analysis_warning_reaches_the_status_line() {
        let mut app = synthetic_app(10, 320, 240, true);
        let mut data = synthetic_analysis(10);
        data.warnings.push("warning: the model's upper-lip region: no lip band".into());
        let generation = app.analysis_generation;
        super::super::update(&mut app, Action::AnalysisReady { generation, data });
        assert_eq!(app.status, "warning: the model's upper-lip region: no lip band");
    }
}
