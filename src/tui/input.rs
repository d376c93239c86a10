//! Terminal events to actions: which keymap tables a key is looked up in depends on the
//! `App` (its overlay and view), and a prompt takes text keys before the keymap sees them.

use crate::tui::action::Action;
use crate::tui::app::App;
use crate::tui::keymap::{KeyChord, KeyMode, Keymap};
use crate::tui::overlays::Overlay;
use crate::tui::screens::View;
use ratatui::crossterm::event::{
    KeyCode, KeyEvent, KeyEventKind, MouseButton, MouseEvent, MouseEventKind,
};

/// The keymap tables consulted for the app's current overlay and view, in order.
pub fn mode_chain(app: &App) -> Vec<KeyMode> {
    let mut chain = Vec::with_capacity(4);
    match app.top_overlay() {
        Some(Overlay::Help { .. }) => chain.push(KeyMode::Help),
        Some(Overlay::FaceBox(_)) => chain.push(KeyMode::FaceBox),
        _ => {}
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
