//! The frames screen's use of lipmap's tracker: re-aligning the frame to the points the user
//! corrected, and drawing a face box for the tracker where it found no face (or the wrong
//! one). Both run on the tracker's job (`jobs::track`); their replies land here as one
//! undoable edit each, like any hand edit.
//!
//! The face box is a square in image pixels (the predictor was trained from square detector
//! boxes), held by `Overlay::FaceBox` while it is drawn: keys move and size it, the mouse
//! drags it from a corner, Enter tracks from it, Esc leaves it.

use crate::landmarks::edit::{self, PointChange};
use crate::landmarks::{FrameLandmarks, PointSource};
use crate::tui::app::history::commit;
use crate::tui::app::{App, Effect};
use crate::tui::overlays::Overlay;
use crate::tui::screens::View;
use crate::tui::screens::frames::FaceBoxDraft;

/// Asks the tracker to re-align the current frame to its corrected points; says why not
/// when the frame has none.
pub fn realign_frame(app: &mut App) {
    let frame = app.frame();
    let Some(f) = app.track.get(frame) else {
        app.status = format!("frame {frame} has no landmarks");
        return;
    };
    let held = f.points.iter().filter(|p| p.source == PointSource::Corrected).count();
    if held == 0 {
        app.status = format!(
            "frame {frame} has no corrected point: move the points you are sure of, then re-align the rest"
        );
        return;
    }
    app.status = format!("re-aligning frame {frame} to its {held} corrected points…");
    app.effects.push(Effect::Realign { frame });
}

/// The tracker's re-alignment of a frame: its moved points become one edit, unless the frame
/// changed while the tracker worked (then its result is for points no longer there).
#[expect(clippy::boxed_local, reason = "the action carries them boxed to keep `Action` small")]
pub fn realigned(app: &mut App, before: Box<FrameLandmarks>, after: Box<FrameLandmarks>) {
    let frame = before.frame;
    if app.track.get(frame) != Some(&*before) {
        app.status = format!("frame {frame} changed while it was re-aligned: re-align it again");
        return;
    }
    let held = before.points.iter().filter(|p| p.source == PointSource::Corrected).count();
    let r = edit::set_derived_points(&mut app.track, &after);
    let moved = r.as_ref().map_or(0, Vec::len);
    commit(app, r);
    if moved > 0 {
        app.status = format!("frame {frame}: {moved} points re-aligned to the {held} corrected");
    }
}

/// Opens a face box on the current frame: around its landmarks when it has some, else
/// around the nearest frame's, else a square of half the image's height in its middle.
pub fn draw_face_box(app: &mut App) {
    app.view = View::Frames;
    let draft = initial_face_box(app);
    if matches!(app.top_overlay(), Some(Overlay::FaceBox(_))) {
        app.overlays.pop();
    }
    app.overlays.push(Overlay::FaceBox(draft));
}

/// The square around the visible landmarks of the frame at `pos` (its side the larger
/// extent), when it has at least half of them.
fn box_around_points(app: &App, pos: usize) -> Option<FaceBoxDraft> {
    let f = app.track.frames.get(pos)?;
    let visible: Vec<_> = f.points.iter().filter(|p| p.visible).collect();
    if visible.len() * 2 < f.points.len().max(1) {
        return None;
    }
    let (mut lo, mut hi) = (visible[0].pos(), visible[0].pos());
    for p in &visible {
        lo = lo.inf(&p.pos());
        hi = hi.sup(&p.pos());
    }
    let side = (hi - lo).max().max(FaceBoxDraft::MIN_SIDE);
    let c = nalgebra::center(&lo, &hi);
    Some(FaceBoxDraft { cx: c.x, cy: c.y, side, anchor: None })
}

fn initial_face_box(app: &App) -> FaceBoxDraft {
    let here = app.frame_pos;
    let n = app.track.frames.len();
    // Outward from the current frame: the nearest frame whose landmarks place a face.
    let nearest = (0..n).find_map(|d| {
        [here.checked_sub(d), here.checked_add(d).filter(|p| *p < n)]
            .into_iter()
            .flatten()
            .find_map(|p| box_around_points(app, p))
    });
    nearest.unwrap_or_else(|| {
        let (w, h) = app.frame_dims();
        let (w, h) = (f64::from(w), f64::from(h));
        FaceBoxDraft {
            cx: w / 2.0,
            cy: h / 2.0,
            side: (h / 2.0).max(FaceBoxDraft::MIN_SIDE),
            anchor: None,
        }
    })
}

fn face_box_mut(app: &mut App) -> Option<&mut FaceBoxDraft> {
    match app.overlays.last_mut() {
        Some(Overlay::FaceBox(b)) => Some(b),
        _ => None,
    }
}

/// Moves the face box by `dx, dy` twentieths of its side.
pub fn move_face_box(app: &mut App, dx: i32, dy: i32) {
    if let Some(b) = face_box_mut(app) {
        b.cx += f64::from(dx) * b.side / 20.0;
        b.cy += f64::from(dy) * b.side / 20.0;
    }
}

/// Grows the face box by `percent` of its side about its centre (shrinks when negative).
pub fn resize_face_box(app: &mut App, percent: i32) {
    if let Some(b) = face_box_mut(app) {
        b.side = (b.side * (1.0 + f64::from(percent) / 100.0)).max(FaceBoxDraft::MIN_SIDE);
    }
}

/// Closes the face box and asks the tracker to track from it.
pub fn confirm_face_box(app: &mut App) {
    let Some(Overlay::FaceBox(b)) = app.top_overlay().cloned() else { return };
    app.overlays.pop();
    let frame = app.frame();
    app.status = format!("tracking from the face box on frame {frame}…");
    app.effects.push(Effect::TrackFromBox { frame, face: b.rect() });
}

/// A mouse press on the image while a face box is drawn: a new box starts at that corner.
/// Returns whether the box took the press.
pub fn face_box_mouse_down(app: &mut App, x: f64, y: f64) -> bool {
    let Some(b) = face_box_mut(app) else { return false };
    *b = FaceBoxDraft::dragged((x, y), x, y);
    true
}

/// A mouse drag while a face box is drawn: the box reaches from its corner to the mouse.
/// Returns whether the box took the drag.
pub fn face_box_mouse_drag(app: &mut App, x: f64, y: f64) -> bool {
    let Some(b) = face_box_mut(app) else { return false };
    if let Some(anchor) = b.anchor {
        *b = FaceBoxDraft::dragged(anchor, x, y);
    }
    true
}

/// The mouse released: the box keeps its shape and no longer follows the mouse.
pub fn face_box_mouse_up(app: &mut App) {
    if let Some(b) = face_box_mut(app) {
        b.anchor = None;
    }
}

/// The frames the tracker followed from a face box: their new points, one edit.
pub fn tracked_from_box(app: &mut App, frames: Vec<FrameLandmarks>) {
    let mut changes: Vec<PointChange> = Vec::new();
    for f in &frames {
        match edit::set_derived_points(&mut app.track, f) {
            Ok(c) => changes.extend(c),
            Err(e) => {
                // Undo what this reply already set, so it is all or nothing.
                edit::apply_changes(&mut app.track, &changes, false);
                app.status = format!("frame {}: {e}", f.frame);
                return;
            }
        }
    }
    let (first, last) = (frames.first().map(|f| f.frame), frames.last().map(|f| f.frame));
    commit(app, Ok(changes));
    if let (Some(a), Some(b)) = (first, last) {
        let confidence = frames[0].points.first().and_then(|p| p.confidence).unwrap_or(0.0);
        app.status = if a == b {
            format!("tracked frame {a} from the face box (confidence {confidence:.2})")
        } else {
            format!(
                "tracked frames {a}–{b} from the face box (frame {a}: confidence {confidence:.2})"
            )
        };
    }
}

pub fn tracker_failed(app: &mut App, error: String) {
    app.status = error;
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::landmarks::{LandmarkPoint, N_LANDMARKS, Track};
    use crate::tui::action::Action;
    use crate::tui::update::apply;

    fn app_of(frames: usize) -> App {
        let track = Track::new(
            (0..frames)
                .map(|f| {
                    let pts = (0..N_LANDMARKS)
                        .map(|i| LandmarkPoint::tracked(100.0 + i as f64, 50.0 + f as f64))
                        .collect();
                    FrameLandmarks::new(f, pts)
                })
                .collect(),
        );
        let mut app = App::new("t", track.clone(), track);
        app.frames.cache.size = Some((400, 300));
        app
    }

    #[test]
    fn realigning_needs_a_corrected_point_and_lands_as_one_undoable_edit() {
        let mut app = app_of(3);
        apply(&mut app, Action::RealignFrame);
        assert!(app.status.contains("no corrected point") && app.effects.is_empty());
        apply(&mut app, Action::Nudge { dx: 0, dy: 3 });
        app.effects.clear();
        apply(&mut app, Action::RealignFrame);
        assert_eq!(app.take_effects(), vec![Effect::Realign { frame: 0 }]);
        let before = app.track.get(0).unwrap().clone();
        let mut after = before.clone();
        for p in after.points.iter_mut().filter(|p| p.source == PointSource::Tracked) {
            *p = LandmarkPoint {
                source: PointSource::Interpolated,
                ..LandmarkPoint::tracked(p.x + 1.0, p.y)
            };
        }
        let undo_depth = app.undo.len();
        apply(
            &mut app,
            Action::Realigned { before: Box::new(before.clone()), after: Box::new(after.clone()) },
        );
        assert_eq!(app.track.get(0).unwrap(), &after);
        assert_eq!(app.undo.len(), undo_depth + 1, "one edit");
        assert!(app.status.contains("67 points re-aligned to the 1 corrected"), "{}", app.status);
        apply(&mut app, Action::Undo);
        assert_eq!(app.track.get(0).unwrap(), &before);
        // A reply for points that are no longer there is dropped.
        apply(&mut app, Action::Nudge { dx: 1, dy: 0 });
        apply(&mut app, Action::Realigned { before: Box::new(before), after: Box::new(after) });
        assert!(app.status.contains("changed while"), "{}", app.status);
        assert_eq!(app.track.get(0).unwrap().points[5].source, PointSource::Tracked);
    }

    #[test]
    fn a_face_box_is_drawn_with_keys_or_the_mouse_and_confirmed_into_a_request() {
        let mut app = app_of(2);
        apply(&mut app, Action::DrawFaceBox);
        let Some(Overlay::FaceBox(b)) = app.top_overlay().cloned() else { panic!("no box") };
        // Around the frame's points: x 100–167, y 50.
        assert!((b.cx - 133.5).abs() < 1e-9 && (b.side - 67.0).abs() < 1e-9, "{b:?}");
        apply(&mut app, Action::MoveFaceBox { dx: 2, dy: -1 });
        apply(&mut app, Action::ResizeFaceBox { percent: 10 });
        let Some(Overlay::FaceBox(m)) = app.top_overlay().cloned() else { panic!() };
        assert!((m.cx - (b.cx + 6.7)).abs() < 1e-9 && (m.cy - (b.cy - 3.35)).abs() < 1e-9);
        assert!((m.side - 73.7).abs() < 1e-9);
        assert!(face_box_mouse_down(&mut app, 10.0, 20.0));
        assert!(face_box_mouse_drag(&mut app, 70.0, 50.0));
        face_box_mouse_up(&mut app);
        let Some(Overlay::FaceBox(d)) = app.top_overlay().cloned() else { panic!() };
        assert_eq!(d.rect(), [10.0, 20.0, 60.0]);
        apply(&mut app, Action::ConfirmFaceBox);
        assert!(app.overlays.is_empty());
        assert_eq!(app.take_effects(), vec![Effect::TrackFromBox { frame: 0, face: d.rect() }]);
        // Esc leaves a box without tracking.
        apply(&mut app, Action::DrawFaceBox);
        apply(&mut app, Action::Cancel);
        assert!(app.overlays.is_empty() && app.take_effects().is_empty());
    }

    #[test]
    fn frames_tracked_from_a_box_are_one_edit() {
        let mut app = app_of(3);
        let derive = |f: &FrameLandmarks| {
            let mut d = f.clone();
            for p in &mut d.points {
                *p = LandmarkPoint {
                    source: PointSource::Interpolated,
                    confidence: Some(0.9),
                    ..LandmarkPoint::tracked(p.x, p.y + 2.0)
                };
            }
            d
        };
        let frames: Vec<FrameLandmarks> = app.track.frames[..2].iter().map(derive).collect();
        let before = app.track.clone();
        apply(&mut app, Action::TrackedFromBox { frames: frames.clone() });
        assert_eq!(app.track.get(1).unwrap(), &frames[1]);
        assert_eq!(app.track.get(2), before.get(2));
        assert!(app.status.contains("frames 0–1"), "{}", app.status);
        apply(&mut app, Action::Undo);
        assert_eq!(app.track, before);
    }
}
