//! Actions that work in every view: help and prompts, saving and quitting, switching views
//! and clips, moving through the frames, undo and redo (the edits themselves are in `edits`).

use super::edits::undo_redo;
use super::{DEFAULT_PROPAGATE, frames, head};
use crate::landmarks::N_LANDMARKS;
use crate::tui::action::Action;
use crate::tui::app::{App, Effect, Overlay, PromptKind, SideState, View};
use crate::tui::save_state::QuitStep;

/// Applies an action of this file (routed here by `update`).
pub(super) fn update(app: &mut App, action: Action) {
    use Action as A;
    match action {
        A::Quit => {
            app.switch_clip = None;
            quit(app);
        }
        A::ToggleHelp => {
            if matches!(app.top_overlay(), Some(Overlay::Help { .. })) {
                app.overlays.pop();
            } else {
                app.overlays.push(Overlay::Help { scroll: 0 });
            }
        }
        A::Cancel => {
            let closed = app.overlays.pop();
            if closed.is_none() {
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
        // After a failed save autosave waits for the next edit rather than retrying in a loop.
        A::Idle if app.save.autosave_due() && !app.dragging => request_save(app),
        A::Idle => {}
        A::Undo => undo_redo(app, true),
        A::Redo => undo_redo(app, false),
        A::ShowFrames => app.view = View::Frames,
        A::ShowHead => {
            app.view = View::Head;
            super::transferred::request_head_frame(app);
        }
        A::ShowFit => app.view = View::Fit,
        A::ShowAnalysis => {
            app.view = View::Analysis;
            if let Some(why) = super::analysis::speech_absent(app) {
                app.status = why;
            }
        }
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
                return;
            }
            let next =
                if action == A::NextClip { (app.clip + 1) % n } else { (app.clip + n - 1) % n };
            app.switch_clip = Some(next);
            quit(app);
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
        A::TogglePlay => {
            app.playing = !app.playing && app.n_frames() > 1;
            if app.playing {
                if app.frame_pos + 1 >= app.n_frames() {
                    go_to_pos(app, 0);
                }
                app.status = format!("playing at {:.0} fps", app.fps);
            }
        }
        // The end of the clip stops playback where it is.
        A::PlayTick if app.playing => {
            if app.frame_pos + 1 >= app.n_frames() {
                app.playing = false;
                app.status = "end of the clip".into();
            } else {
                go_to_pos(app, app.frame_pos + 1);
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
        A::PromptSubmit => submit_prompt(app),
        A::Resize { width, height } => app.term_size = (width, height),
        _ => {}
    }
}

/// Leaves, or saves first and leaves on the save's reply.
pub(super) fn quit(app: &mut App) {
    match app.save.quit_requested() {
        QuitStep::Leave => app.effects.push(Effect::Quit),
        // Autosave normally leaves nothing unsaved; save the last batch before leaving.
        QuitStep::SaveFirst => request_save(app),
    }
}

/// Queues a save of everything edited so far; its reply (`Saved`) names its generation.
pub(super) fn request_save(app: &mut App) {
    let generation = app.save.save_requested();
    app.effects.push(Effect::Save { generation });
}

fn open_prompt(app: &mut App, kind: PromptKind) {
    app.overlays.push(Overlay::Prompt { kind, input: String::new() });
}

fn submit_prompt(app: &mut App) {
    let Some(Overlay::Prompt { kind, input }) = app.overlays.pop() else { return };
    let n: Option<usize> = input.parse().ok();
    match kind {
        PromptKind::GotoPoint | PromptKind::GotoLabel => match n.filter(|&n| n < N_LANDMARKS) {
            Some(n) if kind == PromptKind::GotoPoint => frames::select_point(app, n),
            Some(n) => head::set_label_target(app, n),
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
            match n {
                Some(n) => frames::propagate(app, n),
                None => app.status = format!("not a number of frames: `{input}`"),
            }
        }
    }
}

pub(super) fn go_to_frame(app: &mut App, frame: usize) {
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
    super::transferred::request_head_frame(app);
}
