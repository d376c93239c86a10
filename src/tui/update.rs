//! `update(&mut App, Action)`: the only place the TUI's state changes. Each action goes to
//! the handler the `actions!` table in `action.rs` names for it: a screen's `update.rs`
//! (`screens/`), the overlays' (`overlays/update.rs`), or `global.rs` for what works on every
//! screen. Edits land on an unlimited undo stack (`app::history`); slow work is queued as
//! `Effect`s for the run loop to carry out.

use super::action::Action;
use crate::tui::app::App;

/// Applies one action through its handler. Returns the follow-up action the handler asks
/// for (a prompt's answer, a save after the map is written, the clip to switch to), which
/// the caller applies next, and so on until there is none.
pub fn update(app: &mut App, action: Action) -> Option<Action> {
    // A message answers the key that caused it; the next key clears it.
    // (`Save` may come from autosave, which must not wipe the message of the edit it saves.)
    if action.is_bindable() && !matches!(action, Action::Cancel | Action::Save) {
        app.status.clear();
    }
    action.dispatch(app)
}

/// Applies an action and its follow-ups.
pub fn apply(app: &mut App, action: Action) {
    let mut next = Some(action);
    while let Some(a) = next {
        next = update(app, a);
    }
}
