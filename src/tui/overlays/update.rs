//! The overlays over the view, a stack whose top sees keys first: the help (toggled,
//! scrolled) and the prompts (opened, typed into, answered). A prompt's answer is a follow-up
//! action for the view that asked (go to a frame, select a point, propagate, label).

use super::{Overlay, PromptKind};
use crate::landmarks::ibug::parse_point_no;
use crate::tui::action::Action;
use crate::tui::app::App;

pub fn toggle_help(app: &mut App) {
    if matches!(app.top_overlay(), Some(Overlay::Help { .. })) {
        app.overlays.pop();
    } else {
        app.overlays.push(Overlay::Help { scroll: 0 });
    }
}

/// Closes the top overlay; with none open, clears the status line.
pub fn cancel(app: &mut App) {
    if app.overlays.pop().is_none() {
        app.status.clear();
    }
}

pub fn scroll_down(app: &mut App) {
    if let Some(Overlay::Help { scroll }) = app.overlays.last_mut() {
        *scroll = scroll.saturating_add(1);
    }
}

pub fn scroll_up(app: &mut App) {
    if let Some(Overlay::Help { scroll }) = app.overlays.last_mut() {
        *scroll = scroll.saturating_sub(1);
    }
}

pub fn goto_frame_prompt(app: &mut App) {
    open_prompt(app, PromptKind::GotoFrame);
}

pub fn goto_point_prompt(app: &mut App) {
    open_prompt(app, PromptKind::GotoPoint);
}

pub fn propagate_prompt(app: &mut App) {
    open_prompt(app, PromptKind::Propagate);
}

pub fn goto_label_prompt(app: &mut App) {
    open_prompt(app, PromptKind::GotoLabel);
}

fn open_prompt(app: &mut App, kind: PromptKind) {
    app.overlays.push(Overlay::Prompt { kind, input: String::new() });
}

/// A digit typed into the prompt (nine at most: no frame number is longer).
pub fn prompt_char(app: &mut App, c: char) {
    if let Some(Overlay::Prompt { input, .. }) = app.overlays.last_mut()
        && input.len() < 9
    {
        input.push(c);
    }
}

pub fn prompt_backspace(app: &mut App) {
    if let Some(Overlay::Prompt { input, .. }) = app.overlays.last_mut() {
        input.pop();
    }
}

/// Frames `PropagatePrompt` covers when the user just presses Enter.
pub const DEFAULT_PROPAGATE: usize = 10;

/// Closes the prompt and answers it: the action it asked for, or why the input is not one.
pub fn prompt_submit(app: &mut App) -> Option<Action> {
    let Some(Overlay::Prompt { kind, input }) = app.overlays.pop() else { return None };
    let n: Option<usize> = input.parse().ok();
    let answer = match kind {
        // People type points as they read them, 1–68.
        PromptKind::GotoPoint | PromptKind::GotoLabel => match parse_point_no(&input) {
            Ok(index) if kind == PromptKind::GotoPoint => Ok(Action::SelectPoint { index }),
            Ok(landmark) => Ok(Action::LabelLandmark { landmark }),
            Err(why) => Err(why),
        },
        PromptKind::GotoFrame => match n {
            Some(frame) => Ok(Action::GoToFrame { frame }),
            None => Err(format!("no frame `{input}`")),
        },
        PromptKind::Propagate => match if input.is_empty() { Some(DEFAULT_PROPAGATE) } else { n } {
            Some(frames) => Ok(Action::Propagate { frames }),
            None => Err(format!("not a number of frames: `{input}`")),
        },
    };
    answer.map_err(|why| app.status = why).ok()
}
