//! `update(&mut App, Action)`: the only place the TUI's state changes. Each action goes to
//! the handler the `actions!` table in `action.rs` names for it: one file per view
//! (`frames`, `head` with `transferred`, `fit`, `analysis`, `side`), `overlays` for help and
//! prompts, `global` for what works everywhere (saving, quitting, views, clips, frame
//! navigation, replies about saving), and here what goes to whichever view is shown. Edits
//! go through `landmarks::edit` and land on an unlimited undo stack (`edits`); slow work is
//! queued as `Effect`s for the run loop to carry out.
//!
//! Also here: turning key and mouse events into actions (`input`), because which table a key
//! is looked up in depends on the `App`.

pub(crate) mod analysis;
mod edits;
pub(crate) mod fit;
pub(crate) mod frames;
pub(crate) mod global;
pub(crate) mod head;
mod input;
pub(crate) mod overlays;
pub(crate) mod side;
pub(crate) mod transferred;

pub use global::request_images;
pub use input::{key_to_action, mode_chain, mouse_to_action};

use super::action::Action;
use super::app::{App, View};

/// Default number of frames `PropagatePrompt` covers when the user just presses Enter.
pub const DEFAULT_PROPAGATE: usize = 10;
/// Zoom limits; 64× makes one image pixel 64 display pixels, enough for sub-pixel work.
pub const MAX_ZOOM: f64 = 64.0;

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

/// Zooms the shown view in: the head in the head view, the image elsewhere.
pub fn zoom_in(app: &mut App) {
    match app.view {
        View::Head => head::zoom_in(app),
        _ => frames::zoom(app, 2.0),
    }
}

/// Zooms the shown view out.
pub fn zoom_out(app: &mut App) {
    match app.view {
        View::Head => head::zoom_out(app),
        _ => frames::zoom(app, 0.5),
    }
}

/// Back to the unzoomed view.
pub fn zoom_reset(app: &mut App) {
    match app.view {
        View::Head => head::zoom_reset(app),
        _ => frames::zoom_reset(app),
    }
}
