//! The side view: correcting the upper lip's foremost point of the side frame shown with the
//! current front frame (the protrusion P is measured from it), and the side view's
//! measurement and frames arriving from their jobs.

use crate::math::{Point2, Vector2};
use crate::tui::app::history::push_edit;
use crate::tui::app::{App, Edit, FrameImage};
use crate::tui::global::request_images;
use crate::tui::screens::analysis::update::request_analysis;
use crate::tui::screens::side::{SideState, SideView};
use std::sync::Arc;

/// Drops the side frame's correction: the automatic point again.
pub fn revert_lip_point(app: &mut App) {
    match side_point(app) {
        Some((k, before @ Some(_))) => set_profile_point(app, k, before, None),
        Some((_, None)) => app.status = "this side frame has no correction".into(),
        None => {}
    }
}

/// The side view measured on a job: shown, its frame asked for, P in the analysis.
pub fn side_ready(app: &mut App, side: Box<SideView>) {
    let failed = side.track.automatic.iter().filter(|p| p.failed.is_some()).count();
    app.status =
        format!("side view measured: {} frames ({failed} failed)", side.track.automatic.len());
    app.side = SideState::Ready(side);
    request_images(app);
    request_analysis(app);
}

pub fn side_failed(app: &mut App, error: String) {
    app.status = format!("side view: {error}");
    app.side = SideState::Failed(error);
}

pub fn side_frame_loaded(app: &mut App, frame: usize, image: Arc<FrameImage>) {
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

pub fn side_frame_failed(app: &mut App, frame: usize, error: String) {
    if let Some(side) = app.side.view_mut() {
        side.image_errors.insert(frame, error);
    }
}

/// The side frame shown now and its user point, when the side view is ready.
fn side_point(app: &App) -> Option<(usize, Option<Point2>)> {
    let side = app.side.view()?;
    let k = side.frame_for(app.frame(), app.fps)?;
    Some((k, side.track.corrected.get(&k).copied()))
}

fn set_profile_point(app: &mut App, k: usize, before: Option<Point2>, after: Option<Point2>) {
    if let Some(side) = app.side.view_mut() {
        side.set_correction(k, after);
        push_edit(app, Edit::Profile { side_frame: k, before, after });
    }
}

/// Moves the side frame's upper-lip point (starting from the automatic one, or the crop's
/// centre where extraction failed) by keyboard steps of an image pixel (finer when zoomed).
pub fn nudge_lip_point(app: &mut App, dx: i32, dy: i32) {
    let Some((k, before)) = side_point(app) else {
        app.status = "no side frame here".into();
        return;
    };
    let Some(side) = app.side.view() else { return };
    let start =
        side.track.effective(k, &side.setup).and_then(|p| p.upper_lip_px).unwrap_or_else(|| {
            let c = side.setup.crop;
            Point2::new(
                f64::from(c.x) + f64::from(c.width) / 2.0,
                f64::from(c.y) + f64::from(c.height) / 2.0,
            )
        });
    let step = super::view::side_mapping(app, app.term_size).map_or(1.0, |m| m.nudge_px());
    let after = start + Vector2::new(f64::from(dx) * step, f64::from(dy) * step);
    set_profile_point(app, k, before, Some(after));
}
