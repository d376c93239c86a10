//! The frames view (and the fit view, which shares its keys): correcting landmarks with keys
//! and the mouse, what moves together, zoom and pan of the image, and the decoded frames
//! arriving from their job.

use crate::landmarks::edit;
use crate::landmarks::flags::LipEdgeOffset;
use crate::landmarks::{LandmarkPoint, N_LANDMARKS};
use crate::tui::app::history::{apply_reviewed, commit, mark_changed, push_edit};
use crate::tui::app::{App, Edit, FrameImage};
use crate::tui::screens;
use crate::tui::screens::frames::{Scope, tracking};
use std::collections::BTreeSet;
use std::sync::Arc;

/// Zoom limit; 64× makes one image pixel 64 display pixels, enough for sub-pixel work.
pub const MAX_ZOOM: f64 = 64.0;

pub fn center_on_point(app: &mut App) {
    if let Some(p) = current_point(app) {
        app.frames.image_view.center = Some((p.x, p.y));
    }
}

/// Moves the points of the scope by `dx, dy` keyboard steps.
pub fn nudge(app: &mut App, dx: i32, dy: i32) {
    let step = step_px(app);
    let idx = app.scope_indices();
    let f = app.frame();
    let r = edit::move_points(&mut app.track, f, &idx, dx as f64 * step, dy as f64 * step);
    commit(app, r);
}

pub fn next_point(app: &mut App) {
    select_point(app, (app.frames.selected + 1) % N_LANDMARKS);
}

pub fn prev_point(app: &mut App) {
    select_point(app, (app.frames.selected + N_LANDMARKS - 1) % N_LANDMARKS);
}

pub fn cycle_scope(app: &mut App) {
    app.frames.scope = app.frames.scope.next();
    app.status = match app.frames.scope {
        Scope::Group => {
            format!(
                "moving: group ({})",
                crate::reference::current()
                    .names
                    .group_of(app.frames.selected)
                    .map_or("point", |g| g.name)
            )
        }
        s => format!("moving: {}", s.label()),
    };
}

pub fn toggle_visible(app: &mut App) {
    let (f, idx) = (app.frame(), app.scope_indices());
    let r = edit::toggle_visible(&mut app.track, f, &idx);
    commit(app, r);
}

pub fn copy_point_from_prev(app: &mut App) {
    let (f, idx) = (app.frame(), app.scope_indices());
    let r = edit::copy_from_previous(&mut app.track, f, &idx);
    commit(app, r);
}

pub fn copy_frame_from_prev(app: &mut App) {
    let f = app.frame();
    let all: Vec<usize> = (0..N_LANDMARKS).collect();
    let r = edit::copy_from_previous(&mut app.track, f, &all);
    commit(app, r);
}

pub fn interpolate_selected(app: &mut App) {
    let idx = app.scope_indices();
    interpolate(app, &idx);
}

pub fn interpolate_all(app: &mut App) {
    let all: Vec<usize> = (0..N_LANDMARKS).collect();
    interpolate(app, &all);
}

/// Interpolates points `idx` between the hand-corrected keyframes over the clip.
fn interpolate(app: &mut App, idx: &[usize]) {
    let changes = edit::interpolate_keyframes(&mut app.track, idx);
    if changes.is_empty() {
        app.status = "nothing to interpolate: needs two corrected keyframes".into();
    } else {
        let n = changes.iter().map(|c| c.frame).collect::<BTreeSet<_>>().len();
        commit(app, Ok(changes));
        app.status = format!("interpolated over {n} frames");
    }
}

pub fn revert_point(app: &mut App) {
    let (f, idx) = (app.frame(), app.scope_indices());
    let r = edit::revert_points(&mut app.track, &app.tracked, f, &idx);
    commit(app, r);
}

pub fn toggle_reviewed(app: &mut App) {
    let f = app.frame();
    let now = !app.reviewed.contains(&f);
    apply_reviewed(app, f, now);
    push_edit(app, Edit::Reviewed { frame: f, now });
}

pub fn mouse_up(app: &mut App) {
    app.frames.dragging = false;
    tracking::face_box_mouse_up(app);
}

/// A decoded frame for the cache (its size is the clip's).
pub fn frame_loaded(app: &mut App, frame: usize, image: Arc<FrameImage>) {
    app.frames.cache.size = Some((image.width, image.height));
    app.frames.cache.errors.remove(&frame);
    app.cache_image(frame, image);
}

/// The whole clip's image evidence from the job: it replaces the findings, then the decoded
/// frames are re-measured (edits made meanwhile are on them).
pub fn images_checked(app: &mut App, offsets: Vec<(usize, f64, LipEdgeOffset)>) {
    app.lip_edges = offsets.into_iter().map(|(f, size, o)| (f, (size, o))).collect();
    app.recompute_flags();
}

pub fn frame_failed(app: &mut App, frame: usize, error: String) {
    app.frames.cache.errors.insert(frame, error);
}

/// Propagates the selected points' correction to the next `n` frames.
pub fn propagate(app: &mut App, n: usize) {
    let (f, idx) = (app.frame(), app.scope_indices());
    let r = edit::propagate_correction(&mut app.track, &app.tracked, f, &idx, n);
    let count = r.as_ref().map_or(0, |c| c.len());
    commit(app, r);
    if count > 0 {
        app.status = format!("propagated to the next {n} frames ({count} points)");
    }
}

/// Selects a point and, when zoomed in, pans to it if it is off screen.
pub fn select_point(app: &mut App, index: usize) {
    app.frames.selected = index;
    let (Some(m), Some(p)) = (screens::image_mapping(app, app.term_size), current_point(app))
    else {
        return;
    };
    let (x, y) = m.image_to_display(p.x, p.y);
    let (w, h) = (f64::from(m.area.width), 2.0 * f64::from(m.area.height));
    if app.frames.image_view.zoom > 1.0 && !((0.0..w).contains(&x) && (0.0..h).contains(&y)) {
        app.frames.image_view.center = Some((p.x, p.y));
    }
}

fn current_point(app: &App) -> Option<LandmarkPoint> {
    app.track.frames.get(app.frame_pos).and_then(|f| f.points.get(app.frames.selected)).copied()
}

/// Image pixels one keyboard step moves ([`Mapping::nudge_px`]: one, or finer when zoomed
/// in), or 1 px when nothing is on screen.
///
/// [`Mapping::nudge_px`]: crate::tui::widgets::halfblock::Mapping::nudge_px
fn step_px(app: &App) -> f64 {
    screens::image_mapping(app, app.term_size).map_or(1.0, |m| m.nudge_px())
}

/// Zooms the image by `factor` (within 1..`MAX_ZOOM`).
pub(crate) fn zoom(app: &mut App, factor: f64) {
    let z = (app.frames.image_view.zoom * factor).clamp(1.0, MAX_ZOOM);
    if app.frames.image_view.center.is_none() && z > 1.0 {
        // Zoom towards the selected point: that is what one zooms in to correct.
        app.frames.image_view.center = current_point(app).map(|p| (p.x, p.y));
    }
    app.frames.image_view.zoom = z;
    if z == 1.0 {
        app.frames.image_view.center = None;
    }
}

pub(crate) fn zoom_reset(app: &mut App) {
    app.frames.image_view = Default::default();
}

/// Pans the image by `dx, dy` tenths of the visible width and height.
pub fn pan(app: &mut App, dx: i32, dy: i32) {
    let Some(m) = screens::image_mapping(app, app.term_size) else { return };
    let (w, h) = (f64::from(m.area.width), 2.0 * f64::from(m.area.height));
    let (cx, cy) =
        (m.cx + f64::from(dx) * w / 10.0 / m.scale, m.cy + f64::from(dy) * h / 10.0 / m.scale);
    app.frames.image_view.center = Some((cx, cy));
}

/// Selects the point nearest the click and starts dragging it.
pub fn mouse_down(app: &mut App, col: u16, row: u16) {
    let Some(m) = screens::image_mapping(app, app.term_size) else { return };
    let Some((x, y)) = m.cell_to_image(col, row) else { return };
    if tracking::face_box_mouse_down(app, x, y) {
        return;
    }
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
        app.frames.selected = i;
        app.frames.dragging = true;
        app.frames.drag_open = false;
    }
}

/// Moves the dragged point under the mouse (or the face box being drawn); one drag is one
/// undo step.
pub fn mouse_drag(app: &mut App, col: u16, row: u16) {
    let Some(m) = screens::image_mapping(app, app.term_size) else { return };
    let Some((x, y)) = m.cell_to_image(col, row) else { return };
    if tracking::face_box_mouse_drag(app, x, y) || !app.frames.dragging {
        return;
    }
    let f = app.frame();
    match edit::place_point(&mut app.track, f, app.frames.selected, x, y) {
        Ok(changes) if !changes.is_empty() => {
            mark_changed(app, &changes);
            // One drag is one undo step: extend the entry the drag opened.
            if app.frames.drag_open
                && let Some(Edit::Points(prev)) = app.undo.last_mut()
            {
                prev.extend(changes);
                app.save.change_made();
            } else {
                push_edit(app, Edit::Points(changes));
                app.frames.drag_open = true;
            }
        }
        Ok(_) => {}
        Err(e) => app.status = e.to_string(),
    }
}
