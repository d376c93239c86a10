//! The side view: correcting the upper lip's foremost point of the side frame shown with the
//! current front frame (the protrusion P is measured from it).

use super::edits::push_edit;
use crate::math::{Point2, Vector2};
use crate::tui::action::Action;
use crate::tui::app::{App, Edit};
use crate::tui::views;

/// Applies an action of this file (routed here by `update`).
pub(super) fn update(app: &mut App, action: Action) {
    match action {
        Action::NudgeLipPoint { dx, dy } => nudge_profile_point(app, dx, dy),
        Action::RevertLipPoint => match side_point(app) {
            Some((k, before @ Some(_))) => set_profile_point(app, k, before, None),
            Some((_, None)) => app.status = "this side frame has no correction".into(),
            None => {}
        },
        _ => {}
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
/// centre where extraction failed) by keyboard steps of one display pixel.
fn nudge_profile_point(app: &mut App, dx: i32, dy: i32) {
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
    let step = views::side::side_mapping(app, app.term_size).map_or(1.0, |m| m.step_px());
    let after = start + Vector2::new(f64::from(dx) * step, f64::from(dy) * step);
    set_profile_point(app, k, before, Some(after));
}
