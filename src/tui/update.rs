//! `update(&mut App, Action)`: the only place the TUI's state changes. Edits go through
//! `landmarks::edit` and land on an unlimited undo stack; slow work is queued as `Effect`s.
//!
//! Also here: turning key and mouse events into actions (`key_to_action`,
//! `mouse_to_action`), because which table a key is looked up in depends on the `App`.

use super::app::{App, Edit, Effect, LabelChange, Overlay, PromptKind, SideState, View};
use super::keymap::{KeyChord, KeyMode, Keymap};
use super::views::{self, head};
use super::{action::Action, app::FrameImage};
use crate::fit::OrthoPose;
use crate::fit::suggest::SuggestHead;
use crate::landmarks::N_LANDMARKS;
use crate::landmarks::edit::{self, EditError, PointChange};
use crate::model::LandmarkMap;
use ratatui::crossterm::event::{
    KeyCode, KeyEvent, KeyEventKind, MouseButton, MouseEvent, MouseEventKind,
};
use std::sync::Arc;

/// Default number of frames `PropagatePrompt` covers when the user just presses Enter.
pub const DEFAULT_PROPAGATE: usize = 10;
/// Zoom limits; 64× makes one image pixel 64 display pixels, enough for sub-pixel work.
pub const MAX_ZOOM: f64 = 64.0;

/// The keymap tables consulted for the app's current overlay and view, in order.
pub fn mode_chain(app: &App) -> Vec<KeyMode> {
    let mut chain = Vec::with_capacity(4);
    if matches!(app.top_overlay(), Some(Overlay::Help { .. })) {
        chain.push(KeyMode::Help);
    }
    match app.view {
        View::Frames => chain.push(KeyMode::Frames),
        View::Head => chain.push(KeyMode::Head),
        View::Fit => chain.extend([KeyMode::Fit, KeyMode::Frames]),
        View::Analysis => chain.push(KeyMode::Analysis),
        View::Side => chain.push(KeyMode::Side),
    }
    chain.push(KeyMode::Global);
    chain
}

/// The action for a key event: a prompt takes text keys; otherwise the keymap decides.
pub fn key_to_action(app: &App, keymap: &Keymap, ev: &KeyEvent) -> Option<Action> {
    if ev.kind == KeyEventKind::Release {
        return None;
    }
    if let Some(Overlay::Prompt { .. }) = app.top_overlay() {
        return match ev.code {
            KeyCode::Char(c) if c.is_ascii_digit() => Some(Action::PromptChar(c)),
            KeyCode::Backspace => Some(Action::PromptBackspace),
            KeyCode::Enter => Some(Action::PromptSubmit),
            KeyCode::Esc => Some(Action::Cancel),
            _ => None,
        };
    }
    keymap.lookup(&mode_chain(app), KeyChord::from_event(ev)).cloned()
}

/// The action for a mouse event (left button only).
pub fn mouse_to_action(ev: &MouseEvent) -> Option<Action> {
    let (col, row) = (ev.column, ev.row);
    match ev.kind {
        MouseEventKind::Down(MouseButton::Left) => Some(Action::MouseDown { col, row }),
        MouseEventKind::Drag(MouseButton::Left) => Some(Action::MouseDrag { col, row }),
        MouseEventKind::Up(MouseButton::Left) => Some(Action::MouseUp),
        _ => None,
    }
}

/// Applies one action; may return a follow-up action to apply next.
pub fn update(app: &mut App, action: Action) -> Option<Action> {
    use Action as A;
    // A message answers the key that caused it; the next key clears it.
    // (Autosave applies `Save` itself, so it must not wipe the message of the edit it saves.)
    if action.is_bindable() && !matches!(action, A::Cancel | A::Save) {
        app.status.clear();
    }
    match action {
        A::Quit => {
            app.switch_clip = None;
            return quit(app);
        }
        A::ToggleHelp => {
            if matches!(app.top_overlay(), Some(Overlay::Help { .. })) {
                app.overlays.pop();
            } else {
                app.overlays.push(Overlay::Help { scroll: 0 });
            }
        }
        A::Cancel => {
            if app.overlays.pop().is_none() {
                app.status.clear();
            }
        }
        A::ScrollDown | A::ScrollUp => {
            if let Some(Overlay::Help { scroll }) = app.overlays.last_mut() {
                *scroll = if action == A::ScrollDown {
                    scroll.saturating_add(1)
                } else {
                    scroll.saturating_sub(1)
                };
            }
        }
        A::Save => request_save(app),
        A::Undo => undo_redo(app, true),
        A::Redo => undo_redo(app, false),
        A::RunFit => run_fit(app),
        A::ShowFrames => app.view = View::Frames,
        A::ShowHead => app.view = View::Head,
        A::ShowFit => app.view = View::Fit,
        A::ShowAnalysis => app.view = View::Analysis,
        A::ShowSide => match &app.side {
            SideState::None => app.status = "this clip has no side view".into(),
            _ => {
                app.view = View::Side;
                request_images(app);
            }
        },
        A::NextClip | A::PrevClip => {
            let n = app.clip_names.len();
            if n <= 1 {
                app.status = "the session has one clip".into();
                return None;
            }
            let next =
                if action == A::NextClip { (app.clip + 1) % n } else { (app.clip + n - 1) % n };
            app.switch_clip = Some(next);
            return quit(app);
        }
        A::NextFrame => go_to_pos(app, app.frame_pos.saturating_add(1)),
        A::PrevFrame => go_to_pos(app, app.frame_pos.saturating_sub(1)),
        A::FirstFrame => go_to_pos(app, 0),
        A::LastFrame => go_to_pos(app, app.n_frames().saturating_sub(1)),
        A::NextFlagged => {
            let cur = app.frame();
            match app.flags.iter().find(|f| f.frame > cur).map(|f| f.frame) {
                Some(f) => go_to_frame(app, f),
                None => app.status = "no flagged frame after this one".into(),
            }
        }
        A::PrevFlagged => {
            let cur = app.frame();
            match app.flags.iter().rev().find(|f| f.frame < cur).map(|f| f.frame) {
                Some(f) => go_to_frame(app, f),
                None => app.status = "no flagged frame before this one".into(),
            }
        }
        A::NextUnreviewed => {
            let n = app.n_frames();
            let next = (1..=n)
                .map(|k| (app.frame_pos + k) % n.max(1))
                .find(|&p| !app.reviewed.contains(&app.track.frames[p].frame));
            match next {
                Some(p) => go_to_pos(app, p),
                None => app.status = "every frame is reviewed".into(),
            }
        }
        A::GotoFramePrompt => open_prompt(app, PromptKind::GotoFrame),
        A::GotoPointPrompt => open_prompt(app, PromptKind::GotoPoint),
        A::PropagatePrompt => open_prompt(app, PromptKind::Propagate),
        A::GotoLabelPrompt => open_prompt(app, PromptKind::GotoLabel),
        A::PromptChar(c) => {
            if let Some(Overlay::Prompt { input, .. }) = app.overlays.last_mut()
                && input.len() < 9
            {
                input.push(c);
            }
        }
        A::PromptBackspace => {
            if let Some(Overlay::Prompt { input, .. }) = app.overlays.last_mut() {
                input.pop();
            }
        }
        A::PromptSubmit => return submit_prompt(app),
        A::ZoomIn | A::ZoomOut | A::ZoomReset if app.view == View::Head => {
            app.head.zoom = match action {
                A::ZoomIn => (app.head.zoom * 1.5).min(20.0),
                A::ZoomOut => (app.head.zoom / 1.5).max(0.2),
                _ => 1.0,
            };
        }
        A::ZoomIn => zoom(app, 2.0),
        A::ZoomOut => zoom(app, 0.5),
        A::ZoomReset => app.image_view = Default::default(),
        A::Pan { dx, dy } => pan(app, dx, dy),
        A::CenterOnPoint => {
            if let Some(p) = current_point(app) {
                app.image_view.center = Some((p.x, p.y));
            }
        }
        A::NudgeLipPoint { dx, dy } => nudge_profile_point(app, dx, dy),
        A::RevertLipPoint => {
            let (k, before) = side_point(app)?;
            if before.is_some() {
                set_profile_point(app, k, before, None);
            } else {
                app.status = "this side frame has no correction".into();
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
                super::app::Scope::Group => format!(
                    "moving: group ({})",
                    crate::landmarks::ibug::group_of(app.selected).map_or("point", |g| g.name)
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
                let frames: std::collections::BTreeSet<usize> =
                    changes.iter().map(|c| c.frame).collect();
                let n = frames.len();
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
        A::Rotate { yaw, pitch } => {
            app.head.yaw = (app.head.yaw + f64::from(yaw)).rem_euclid(360.0);
            app.head.pitch = (app.head.pitch + f64::from(pitch)).clamp(-90.0, 90.0);
        }
        A::ResetView => {
            app.head = super::app::HeadView { label: app.head.label, ..Default::default() }
        }
        A::MoveCursor { dx, dy } => {
            app.head.suggested = None;
            let k = 0.01 / app.head.zoom;
            let (x, y) = app.head.cursor;
            app.head.cursor = (
                (x + f64::from(dx) * k).clamp(-1.5, 1.5),
                (y + f64::from(dy) * k).clamp(-1.5, 1.5),
            );
        }
        A::NextLabel => set_label_target(app, (app.head.label + 1) % N_LANDMARKS),
        A::PrevLabel => set_label_target(app, (app.head.label + N_LANDMARKS - 1) % N_LANDMARKS),
        A::ConfirmLabel => {
            let l = app.head.label;
            let picked = match app.head.suggested {
                Some((sl, v)) if sl == l => Some(v),
                _ => app.mesh.as_ref().and_then(|m| {
                    let eligible = app.label_candidates.as_deref().map(Vec::as_slice);
                    head::pick_vertex(m, &app.head_framing, &app.head, eligible)
                }),
            };
            match picked {
                Some(v) => {
                    relabel(app, vec![(l, Some(v))]);
                    app.status = format!("landmark {l} → vertex {v}");
                    set_label_target(app, (l + 1) % N_LANDMARKS);
                }
                None => app.status = "no visible vertex under the cursor".into(),
            }
        }
        A::ClearLabel => {
            relabel(app, vec![(app.head.label, None)]);
        }
        A::SuggestLabel => suggest_label(app),
        A::SuggestAllLabels => suggest_all_labels(app),
        // The session then records the map file it now refers to.
        A::LoadMap => app.effects.push(Effect::LoadMap),
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
        A::SaveMap => {
            app.effects.push(Effect::SaveMap);
            request_save(app);
        }
        A::RowDown | A::RowUp => {
            let n = analysis_rows(app);
            let r = &mut app.analysis_view.row;
            *r = if action == A::RowDown {
                (*r + 1).min(n.saturating_sub(1))
            } else {
                r.saturating_sub(1)
            };
        }
        A::NextTable => {
            let n = app.analysis.tables.len().max(1);
            app.analysis_view = super::app::AnalysisView {
                table: (app.analysis_view.table + 1) % n,
                ..Default::default()
            };
        }
        A::SortNextColumn => {
            let ncols = app
                .analysis
                .tables
                .get(app.analysis_view.table)
                .map_or(1, |t| t.columns.len().max(1));
            app.analysis_view.sort_column = (app.analysis_view.sort_column + 1) % ncols;
            app.analysis_view.row = 0;
        }
        A::SortReverse => {
            app.analysis_view.descending = !app.analysis_view.descending;
            app.analysis_view.row = 0;
        }
        A::OpenRow => {
            let frame = app.analysis.tables.get(app.analysis_view.table).and_then(|t| {
                let order = views::analysis::sorted_rows(t, &app.analysis_view);
                order.get(app.analysis_view.row).and_then(|&i| t.rows[i].frame)
            });
            match frame {
                Some(f) => {
                    go_to_frame(app, f);
                    app.view = View::Frames;
                }
                None => app.status = "this row has no frame".into(),
            }
        }
        A::MouseDown { col, row } => mouse_down(app, col, row),
        A::MouseDrag { col, row } => mouse_drag(app, col, row),
        A::MouseUp => app.dragging = false,
        A::Resize { width, height } => app.term_size = (width, height),
        A::FrameLoaded { frame, image } => frame_loaded(app, frame, image),
        A::FrameFailed { frame, error } => {
            app.image_errors.insert(frame, error);
        }
        A::FitProgress { generation, done, total } => {
            if generation == app.fit.generation {
                app.fit.progress = (done, total);
            }
        }
        A::FitDone { generation, fits } => {
            if generation == app.fit.generation {
                app.fit.running = false;
                app.fit.error = None;
                let n = fits.len();
                let failed = fits.iter().filter(|f| f.failed.is_some()).count();
                for f in fits {
                    app.fit.fits.insert(f.frame, f);
                }
                app.recompute_flags();
                app.request_analysis();
                app.status = format!("fitted {n} frames ({failed} failed)");
            }
        }
        A::FitFailed { generation, error } => {
            if generation == app.fit.generation {
                app.fit.running = false;
                app.status = format!("fit failed: {error}");
                app.fit.error = Some(error);
            }
        }
        A::AnalysisReady { generation, data } => {
            if generation == app.analysis_generation {
                app.analysis = data;
                let n = app.analysis.tables.len().max(1);
                app.analysis_view.table = app.analysis_view.table.min(n - 1);
            }
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
                while side.images.len() > super::app::SideView::CACHE {
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
        A::Saved { generation } => {
            if generation >= app.save_generation {
                // Edits made while the save was on its way stay unsaved.
                app.unsaved_edits = app.unsaved_edits.saturating_sub(app.save_pending_edits);
                app.save_pending_edits = 0;
                app.saving = false;
                // The tables follow the corrections (the head's side uses the fits as they
                // are until the next fit).
                app.request_analysis();
            }
            // The status line's right side shows the save state; keep the message.
            app.save_failed = false;
            if app.quit_requested && app.unsaved_edits == 0 {
                app.should_quit = true;
                app.effects.push(Effect::Quit);
            } else if app.quit_requested && !app.saving {
                request_save(app);
            }
        }
        A::SaveFailed { error } => {
            app.saving = false;
            app.switch_clip = None;
            app.status = format!("save failed: {error} (q again quits without saving)");
            app.quit_requested = false;
            app.save_failed = true;
        }
        A::Status(s) => app.status = s,
    }
    None
}

fn quit(app: &mut App) -> Option<Action> {
    if app.unsaved_edits == 0 || app.save_failed {
        app.should_quit = true;
        app.effects.push(Effect::Quit);
    } else {
        // Autosave normally leaves nothing unsaved; save the last batch before leaving.
        app.quit_requested = true;
        request_save(app);
    }
    None
}

/// Queues a save of everything edited so far; its reply (`Saved`) names its generation.
fn request_save(app: &mut App) {
    app.save_generation += 1;
    app.saving = true;
    app.save_pending_edits = app.unsaved_edits;
    app.effects.push(Effect::Save);
}

fn open_prompt(app: &mut App, kind: PromptKind) {
    app.overlays.push(Overlay::Prompt { kind, input: String::new() });
}

fn submit_prompt(app: &mut App) -> Option<Action> {
    let Some(Overlay::Prompt { kind, input }) = app.overlays.pop() else { return None };
    let n: Option<usize> = input.parse().ok();
    match kind {
        PromptKind::GotoPoint | PromptKind::GotoLabel => match n.filter(|&n| n < N_LANDMARKS) {
            Some(n) if kind == PromptKind::GotoPoint => select_point(app, n),
            Some(n) => set_label_target(app, n),
            None => app.status = format!("no landmark `{input}` (0-67)"),
        },
        PromptKind::GotoFrame => {
            match n.and_then(|f| app.track.frames.iter().position(|x| x.frame == f)) {
                Some(p) => go_to_pos(app, p),
                None => app.status = format!("no frame `{input}`"),
            }
        }
        PromptKind::Propagate => {
            let n = if input.is_empty() { Some(DEFAULT_PROPAGATE) } else { n };
            let Some(n) = n else {
                app.status = format!("not a number of frames: `{input}`");
                return None;
            };
            let (f, idx) = (app.frame(), app.scope_indices());
            let r = edit::propagate_correction(&mut app.track, &app.tracked, f, &idx, n);
            let count = r.as_ref().map_or(0, |c| c.len());
            commit(app, r);
            if count > 0 {
                app.status = format!("propagated to the next {n} frames ({count} points)");
            }
        }
    }
    None
}

/// Records an edit's changes: undo entry, autosave counter, stale fits, flags.
fn commit(app: &mut App, result: Result<Vec<PointChange>, EditError>) {
    match result {
        Ok(changes) if changes.is_empty() => app.status = "nothing changed".into(),
        Ok(changes) => {
            mark_changed(app, &changes);
            push_edit(app, Edit::Points(changes));
        }
        Err(e) => app.status = e.to_string(),
    }
}

fn mark_changed(app: &mut App, changes: &[PointChange]) {
    app.fit.stale.extend(changes.iter().map(|c| c.frame));
    app.recompute_flags();
}

fn push_edit(app: &mut App, e: Edit) {
    app.undo.push(e);
    app.redo.clear();
    app.unsaved_edits += 1;
    // A new edit batch deserves a new autosave attempt after a failed one.
    app.save_failed = false;
}

fn apply_reviewed(app: &mut App, frame: usize, now: bool) {
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

/// Sets landmarks' vertices (None removes) as one undoable edit; unchanged ones are skipped.
fn relabel(app: &mut App, labels: Vec<(usize, Option<usize>)>) -> usize {
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
        // Another map means other fits, for every frame.
        let all: Vec<usize> = app.track.frames.iter().map(|f| f.frame).collect();
        app.fit.stale.extend(all);
    }
    n
}

fn set_label_target(app: &mut App, landmark: usize) {
    app.head.label = landmark;
    app.head.suggested = None;
}

/// The head's vertices and the camera to see them through for suggestions: the current
/// frame's fitted shape and pose when it has a fit, else the mesh (or the model's mean)
/// with the pose left to be estimated from the labels.
type SuggestionBasis = (Vec<crate::math::Point3>, Vec<[u32; 3]>, Option<OrthoPose>);

fn suggestion_basis(app: &App) -> Option<SuggestionBasis> {
    // The head mesh's faces hide what is behind the surface; fan-triangulated polygons.
    let faces = |mesh: &crate::model::Mesh| -> Vec<[u32; 3]> {
        mesh.faces
            .iter()
            .flat_map(|f| (1..f.len().saturating_sub(1)).map(move |k| [f[0], f[k], f[k + 1]]))
            .collect()
    };
    let fit = app.fit.fits.get(&app.frame()).filter(|f| f.failed.is_none());
    if let (Some(model), Some(fit)) = (&app.model, fit) {
        let shape = crate::fit::fitted_shape(model, fit);
        let tris = match &app.mesh {
            Some(m) if model.triangles.is_empty() => faces(m),
            _ => model.triangles.clone(),
        };
        return Some((model.to_mesh(&shape).vertices, tris, Some(crate::fit::pose_of(fit))));
    }
    match (&app.mesh, &app.model) {
        (Some(mesh), _) => Some((mesh.vertices.clone(), faces(mesh), None)),
        (None, Some(model)) => Some((model.mean_mesh().vertices, model.triangles.clone(), None)),
        (None, None) => None,
    }
}

fn suggest_label(app: &mut App) {
    let Some((vertices, tris, pose)) = suggestion_basis(app) else {
        app.status = "no head to label".into();
        return;
    };
    let Some(frame) = app.track.frames.get(app.frame_pos) else { return };
    let map = app.map.clone().unwrap_or_default();
    let l = app.head.label;
    let how = if pose.is_some() { "fitted pose" } else { "pose from the labels" };
    let h = f64::from(app.frame_dims().1);
    let head = SuggestHead {
        vertices: &vertices,
        triangles: &tris,
        eligible: app.label_candidates.as_deref().map(Vec::as_slice),
    };
    match crate::fit::suggest::suggest_label(&head, &map, frame, h, pose, l) {
        Ok(s) => {
            if let Some(mesh) = &app.mesh {
                let rot = head::rotation(app.head.yaw, app.head.pitch);
                let pts = head::project(mesh, &rot, &app.head_framing);
                if let Some(p) = pts.get(s.vertex) {
                    app.head.cursor = (p.0, -p.1);
                }
            }
            app.head.suggested = Some((l, s.vertex));
            app.status = format!(
                "suggested vertex {} for {l} ({:.1} px off the tracked point, {how}): \
                 Enter assigns",
                s.vertex, s.distance_px
            );
        }
        Err(e) => app.status = format!("no suggestion: {e}"),
    }
}

fn suggest_all_labels(app: &mut App) {
    let Some((vertices, tris, pose)) = suggestion_basis(app) else {
        app.status = "no head to label".into();
        return;
    };
    let Some(frame) = app.track.frames.get(app.frame_pos) else { return };
    let map = app.map.clone().unwrap_or_default();
    let unmapped: Vec<usize> = (0..N_LANDMARKS).filter(|l| map.vertex(*l).is_none()).collect();
    let h = f64::from(app.frame_dims().1);
    let head = SuggestHead {
        vertices: &vertices,
        triangles: &tris,
        eligible: app.label_candidates.as_deref().map(Vec::as_slice),
    };
    match crate::fit::suggest::suggest_labels(&head, &map, frame, h, pose, unmapped) {
        Ok(list) => {
            let worst = list.iter().map(|s| s.distance_px).fold(0.0, f64::max);
            let n = relabel(app, list.iter().map(|s| (s.landmark, Some(s.vertex))).collect());
            app.status = format!(
                "labelled {n} landmarks from suggestions (worst {worst:.1} px off); u undoes"
            );
        }
        Err(e) => app.status = format!("no suggestions: {e}"),
    }
}

/// The side frame shown now and its user point, when the side view is ready.
fn side_point(app: &App) -> Option<(usize, Option<crate::math::Point2>)> {
    let side = app.side.view()?;
    let k = side.frame_for(app.frame(), app.fps)?;
    Some((k, side.track.corrected.get(&k).copied()))
}

fn set_profile_point(
    app: &mut App,
    k: usize,
    before: Option<crate::math::Point2>,
    after: Option<crate::math::Point2>,
) {
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
            crate::math::Point2::new(
                f64::from(c.x) + f64::from(c.width) / 2.0,
                f64::from(c.y) + f64::from(c.height) / 2.0,
            )
        });
    let step = views::side::side_mapping(app, app.term_size).map_or(1.0, |m| m.step_px());
    let after = start + crate::math::Vector2::new(f64::from(dx) * step, f64::from(dy) * step);
    set_profile_point(app, k, before, Some(after));
}

/// Selects a point and, when zoomed in, pans to it if it is off screen.
fn select_point(app: &mut App, index: usize) {
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

/// What an undo or redo entry changed, for the status line.
fn describe_edit(e: &Edit) -> String {
    match e {
        Edit::Points(changes) => {
            let frames: std::collections::BTreeSet<usize> =
                changes.iter().map(|c| c.frame).collect();
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
        Edit::Labels(c) if c.len() == 1 => format!("label of landmark {}", c[0].landmark),
        Edit::Labels(c) => format!("{} labels", c.len()),
    }
}

fn undo_redo(app: &mut App, undo: bool) {
    let (from, to) =
        if undo { (&mut app.undo, &mut app.redo) } else { (&mut app.redo, &mut app.undo) };
    let Some(e) = from.pop() else {
        app.status = if undo { "nothing to undo" } else { "nothing to redo" }.into();
        return;
    };
    to.push(e.clone());
    app.unsaved_edits += 1;
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
            let all: Vec<usize> = app.track.frames.iter().map(|f| f.frame).collect();
            app.fit.stale.extend(all);
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

fn run_fit(app: &mut App) {
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

fn go_to_frame(app: &mut App, frame: usize) {
    if let Ok(p) = app.track.frames.binary_search_by_key(&frame, |f| f.frame) {
        go_to_pos(app, p);
    }
}

/// Moves to a position in the track and asks for the frame (and neighbours) to be decoded.
fn go_to_pos(app: &mut App, pos: usize) {
    let n = app.n_frames();
    if n == 0 {
        return;
    }
    app.frame_pos = pos.min(n - 1);
    request_images(app);
}

/// Queues decoding of the current frame and prefetch of its neighbours, uncached ones only.
pub fn request_images(app: &mut App) {
    let p = app.frame_pos;
    let wanted: Vec<usize> = [Some(p), p.checked_add(1), p.checked_add(2), p.checked_sub(1)]
        .into_iter()
        .flatten()
        .filter_map(|q| app.track.frames.get(q).map(|f| f.frame))
        .filter(|f| !app.images.contains_key(f) && !app.image_errors.contains_key(f))
        .collect();
    if !wanted.is_empty() {
        app.effects.push(Effect::LoadFrames(wanted));
    }
    if app.view == View::Side
        && let Some(side) = app.side.view()
        && let Some(k) = side.frame_for(app.frame(), app.fps)
        && !side.images.contains_key(&k)
        && !side.image_errors.contains_key(&k)
    {
        app.effects.push(Effect::LoadSideFrame(k));
    }
}

fn frame_loaded(app: &mut App, frame: usize, image: Arc<FrameImage>) {
    app.image_size = Some((image.width, image.height));
    app.image_errors.remove(&frame);
    app.cache_image(frame, image);
}

fn current_point(app: &App) -> Option<crate::landmarks::LandmarkPoint> {
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
                app.unsaved_edits += 1;
            } else {
                push_edit(app, Edit::Points(changes));
                app.drag_open = true;
            }
        }
        Ok(_) => {}
        Err(e) => app.status = e.to_string(),
    }
}

fn analysis_rows(app: &App) -> usize {
    app.analysis.tables.get(app.analysis_view.table).map_or(0, |t| t.rows.len())
}
