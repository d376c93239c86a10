//! The frames view (and the fit view, which shares its keys): correcting landmarks with keys
//! and the mouse, what moves together, zoom and pan of the image.

use super::MAX_ZOOM;
use super::edits::{apply_reviewed, commit, mark_changed, push_edit};
use crate::landmarks::edit;
use crate::landmarks::{LandmarkPoint, N_LANDMARKS};
use crate::tui::action::Action;
use crate::tui::app::{App, Edit, Scope};
use crate::tui::views;
use std::collections::BTreeSet;

/// Applies an action of this file (routed here by `update`).
pub(super) fn update(app: &mut App, action: Action) {
    use Action as A;
    match action {
        A::ZoomIn => zoom(app, 2.0),
        A::ZoomOut => zoom(app, 0.5),
        A::ZoomReset => app.image_view = Default::default(),
        A::Pan { dx, dy } => pan(app, dx, dy),
        A::CenterOnPoint => {
            if let Some(p) = current_point(app) {
                app.image_view.center = Some((p.x, p.y));
            }
        }
        A::Nudge { dx, dy } => {
            let step = step_px(app);
            let idx = app.scope_indices();
            let f = app.frame();
            let r = edit::move_points(&mut app.track, f, &idx, dx as f64 * step, dy as f64 * step);
            commit(app, r);
        }
        A::NextPoint => select_point(app, (app.selected + 1) % N_LANDMARKS),
        A::PrevPoint => select_point(app, (app.selected + N_LANDMARKS - 1) % N_LANDMARKS),
        A::CycleScope => {
            app.scope = app.scope.next();
            app.status = match app.scope {
                Scope::Group => format!(
                    "moving: group ({})",
                    crate::reference::current()
                        .names
                        .group_of(app.selected)
                        .map_or("point", |g| g.name)
                ),
                s => format!("moving: {}", s.label()),
            };
        }
        A::ToggleVisible => {
            let (f, idx) = (app.frame(), app.scope_indices());
            let r = edit::toggle_visible(&mut app.track, f, &idx);
            commit(app, r);
        }
        A::CopyPointFromPrev => {
            let (f, idx) = (app.frame(), app.scope_indices());
            let r = edit::copy_from_previous(&mut app.track, f, &idx);
            commit(app, r);
        }
        A::CopyFrameFromPrev => {
            let f = app.frame();
            let all: Vec<usize> = (0..N_LANDMARKS).collect();
            let r = edit::copy_from_previous(&mut app.track, f, &all);
            commit(app, r);
        }
        A::InterpolateSelected | A::InterpolateAll => {
            let idx = if action == A::InterpolateAll {
                (0..N_LANDMARKS).collect()
            } else {
                app.scope_indices()
            };
            let changes = edit::interpolate_keyframes(&mut app.track, &idx);
            if changes.is_empty() {
                app.status = "nothing to interpolate: needs two corrected keyframes".into();
            } else {
                let n = changes.iter().map(|c| c.frame).collect::<BTreeSet<_>>().len();
                commit(app, Ok(changes));
                app.status = format!("interpolated over {n} frames");
            }
        }
        A::RevertPoint => {
            let (f, idx) = (app.frame(), app.scope_indices());
            let r = edit::revert_points(&mut app.track, &app.tracked, f, &idx);
            commit(app, r);
        }
        A::ToggleReviewed => {
            let f = app.frame();
            let now = !app.reviewed.contains(&f);
            apply_reviewed(app, f, now);
            push_edit(app, Edit::Reviewed { frame: f, now });
        }
        A::MouseDown { col, row } => mouse_down(app, col, row),
        A::MouseDrag { col, row } => mouse_drag(app, col, row),
        A::MouseUp => app.dragging = false,
        _ => {}
    }
}

/// Propagates the selected points' correction to the next `n` frames.
pub(super) fn propagate(app: &mut App, n: usize) {
    let (f, idx) = (app.frame(), app.scope_indices());
    let r = edit::propagate_correction(&mut app.track, &app.tracked, f, &idx, n);
    let count = r.as_ref().map_or(0, |c| c.len());
    commit(app, r);
    if count > 0 {
        app.status = format!("propagated to the next {n} frames ({count} points)");
    }
}

/// Selects a point and, when zoomed in, pans to it if it is off screen.
pub(super) fn select_point(app: &mut App, index: usize) {
    app.selected = index;
    let (Some(m), Some(p)) = (views::image_mapping(app, app.term_size), current_point(app)) else {
        return;
    };
    let (x, y) = m.image_to_display(p.x, p.y);
    let (w, h) = (f64::from(m.area.width), 2.0 * f64::from(m.area.height));
    if app.image_view.zoom > 1.0 && !((0.0..w).contains(&x) && (0.0..h).contains(&y)) {
        app.image_view.center = Some((p.x, p.y));
    }
}

fn current_point(app: &App) -> Option<LandmarkPoint> {
    app.track.frames.get(app.frame_pos).and_then(|f| f.points.get(app.selected)).copied()
}

/// Image pixels one keyboard step moves: one display pixel (so a step is always visible,
/// and sub-pixel when zoomed in), or 1 px when nothing is on screen.
fn step_px(app: &App) -> f64 {
    views::image_mapping(app, app.term_size).map_or(1.0, |m| m.step_px())
}

fn zoom(app: &mut App, factor: f64) {
    let z = (app.image_view.zoom * factor).clamp(1.0, MAX_ZOOM);
    if app.image_view.center.is_none() && z > 1.0 {
        // Zoom towards the selected point: that is what one zooms in to correct.
        app.image_view.center = current_point(app).map(|p| (p.x, p.y));
    }
    app.image_view.zoom = z;
    if z == 1.0 {
        app.image_view.center = None;
    }
}

fn pan(app: &mut App, dx: i32, dy: i32) {
    let Some(m) = views::image_mapping(app, app.term_size) else { return };
    let (w, h) = (f64::from(m.area.width), 2.0 * f64::from(m.area.height));
    let (cx, cy) =
        (m.cx + f64::from(dx) * w / 10.0 / m.scale, m.cy + f64::from(dy) * h / 10.0 / m.scale);
    app.image_view.center = Some((cx, cy));
}

fn mouse_down(app: &mut App, col: u16, row: u16) {
    let Some(m) = views::image_mapping(app, app.term_size) else { return };
    let Some((x, y)) = m.cell_to_image(col, row) else { return };
    let Some(f) = app.track.frames.get(app.frame_pos) else { return };
    let (cx, cy) = m.image_to_display(x, y);
    let nearest = f
        .points
        .iter()
        .enumerate()
        .map(|(i, p)| {
            let (px, py) = m.image_to_display(p.x, p.y);
            (i, (px - cx).powi(2) + (py - cy).powi(2))
        })
        .min_by(|a, b| a.1.total_cmp(&b.1));
    if let Some((i, _)) = nearest {
        app.selected = i;
        app.dragging = true;
        app.drag_open = false;
    }
}

fn mouse_drag(app: &mut App, col: u16, row: u16) {
    if !app.dragging {
        return;
    }
    let Some(m) = views::image_mapping(app, app.term_size) else { return };
    let Some((x, y)) = m.cell_to_image(col, row) else { return };
    let f = app.frame();
    match edit::place_point(&mut app.track, f, app.selected, x, y) {
        Ok(changes) if !changes.is_empty() => {
            mark_changed(app, &changes);
            // One drag is one undo step: extend the entry the drag opened.
            if app.drag_open
                && let Some(Edit::Points(prev)) = app.undo.last_mut()
            {
                prev.extend(changes);
                app.save.change_made();
            } else {
                push_edit(app, Edit::Points(changes));
                app.drag_open = true;
            }
        }
        Ok(_) => {}
        Err(e) => app.status = e.to_string(),
    }
}
