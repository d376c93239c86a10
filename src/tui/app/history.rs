//! The edit history: recording an edit (undo entry, a change to save, stale fits, flags),
//! and undoing or redoing one. Every view's edits end here, so the rules for what an edit
//! invalidates live in one place.

use crate::landmarks::edit::{self, EditError, PointChange};
use crate::math::Point2;
use crate::model::LandmarkMap;
use crate::tui::app::App;
use crate::tui::global::go_to_frame;
use std::collections::BTreeSet;

/// One undoable edit.
#[derive(Clone, Debug, PartialEq)]
pub enum Edit {
    Points(Vec<PointChange>),
    Reviewed {
        frame: usize,
        now: bool,
    },
    /// Landmark map changes, applied together (one label, or all suggestions at once).
    Labels(Vec<LabelChange>),
    /// The user's upper-lip point of a side-view frame (None = the automatic one).
    Profile {
        side_frame: usize,
        before: Option<Point2>,
        after: Option<Point2>,
    },
}

/// One landmark's vertex before and after a labelling edit.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LabelChange {
    pub landmark: usize,
    pub before: Option<usize>,
    pub after: Option<usize>,
}

/// Records an edit's changes: undo entry, autosave counter, stale fits, flags.
pub(crate) fn commit(app: &mut App, result: Result<Vec<PointChange>, EditError>) {
    match result {
        Ok(changes) if changes.is_empty() => app.status = "nothing changed".into(),
        Ok(changes) => {
            mark_changed(app, &changes);
            push_edit(app, Edit::Points(changes));
        }
        Err(e) => app.status = e.to_string(),
    }
}

/// Point changes make their frames' fits stale and may raise or clear flags.
pub(crate) fn mark_changed(app: &mut App, changes: &[PointChange]) {
    app.fits.stale.extend(changes.iter().map(|c| c.frame));
    app.recompute_flags();
}

/// Pushes a new undo entry (clearing redo) and counts it as unsaved.
pub(crate) fn push_edit(app: &mut App, e: Edit) {
    app.undo.push(e);
    app.redo.clear();
    app.save.edit_made();
}

pub(crate) fn apply_reviewed(app: &mut App, frame: usize, now: bool) {
    if now {
        app.reviewed.insert(frame);
    } else {
        app.reviewed.remove(&frame);
    }
}

fn set_label(app: &mut App, landmark: usize, vertex: Option<usize>) {
    let map = app.map.get_or_insert_with(LandmarkMap::default);
    match vertex {
        Some(v) => map.to_vertex.insert(landmark, v),
        None => map.to_vertex.remove(&landmark),
    };
}

/// Another map means other fits, for every frame.
fn stale_every_fit(app: &mut App) {
    let all: Vec<usize> = app.track.frames.iter().map(|f| f.frame).collect();
    app.fits.stale.extend(all);
}

/// Sets landmarks' vertices (None removes) as one undoable edit; unchanged ones are skipped.
/// Returns how many changed.
pub(crate) fn relabel(app: &mut App, labels: Vec<(usize, Option<usize>)>) -> usize {
    let changes: Vec<LabelChange> = labels
        .into_iter()
        .map(|(landmark, after)| {
            let before = app.map.as_ref().and_then(|m| m.vertex(landmark));
            LabelChange { landmark, before, after }
        })
        .filter(|c| c.before != c.after)
        .collect();
    for c in &changes {
        set_label(app, c.landmark, c.after);
    }
    let n = changes.len();
    if n > 0 {
        push_edit(app, Edit::Labels(changes));
        stale_every_fit(app);
    }
    n
}

/// What an undo or redo entry changed, for the status line.
fn describe_edit(e: &Edit) -> String {
    match e {
        Edit::Points(changes) => {
            let frames: BTreeSet<usize> = changes.iter().map(|c| c.frame).collect();
            let n = changes.len();
            let pts = if n == 1 { "point" } else { "points" };
            match (frames.first(), frames.len()) {
                (Some(f), 1) => format!("{n} {pts} on frame {f}"),
                (Some(f), k) => format!("{n} {pts} on {k} frames from {f}"),
                (None, _) => "nothing".into(),
            }
        }
        Edit::Reviewed { frame, .. } => format!("reviewed mark of frame {frame}"),
        Edit::Profile { side_frame, .. } => format!("lip point of side frame {side_frame}"),
        Edit::Labels(c) if c.len() == 1 => {
            format!("label of landmark {}", crate::landmarks::PointNo(c[0].landmark))
        }
        Edit::Labels(c) => format!("{} labels", c.len()),
    }
}

/// Undoes (`undo`) or redoes the newest entry of its stack.
pub(crate) fn undo_redo(app: &mut App, undo: bool) {
    let (from, to) =
        if undo { (&mut app.undo, &mut app.redo) } else { (&mut app.redo, &mut app.undo) };
    let Some(e) = from.pop() else {
        app.status = if undo { "nothing to undo" } else { "nothing to redo" }.into();
        return;
    };
    to.push(e.clone());
    app.save.change_made();
    match e {
        Edit::Points(changes) => {
            edit::apply_changes(&mut app.track, &changes, !undo);
            mark_changed(app, &changes);
            if let Some(c) = changes.first() {
                go_to_frame(app, c.frame);
            }
        }
        Edit::Reviewed { frame, now } => apply_reviewed(app, frame, now != undo),
        Edit::Labels(changes) => {
            for c in changes {
                set_label(app, c.landmark, if undo { c.before } else { c.after });
            }
            stale_every_fit(app);
        }
        Edit::Profile { side_frame, before, after } => {
            if let Some(side) = app.side.view_mut() {
                side.set_correction(side_frame, if undo { before } else { after });
            }
        }
    }
    if let Some(e) = if undo { app.redo.last() } else { app.undo.last() } {
        app.status = format!("{}: {}", if undo { "undone" } else { "redone" }, describe_edit(e));
    }
}
