//! The terminal UI: correct landmarks, label the head, fit, and hunt failing frames.
//! Start at `run::run`; the shape is `App` (state) + `Action` + `update` + `draw`.
//!
//! Keys become actions through `keymap` and `input`; only `update` changes the `App`;
//! drawing only reads it; slow work runs in `jobs` and replies as actions. `session_bridge`
//! loads an `App` from a session and writes the corrections back.
//!
//! Where things are:
//! - `screens/{frames,head,fit,analysis,side}/`: one folder per screen, each with its
//!   `state.rs` (held in `App` under the screen's name), `update.rs` (its handlers) and
//!   `view.rs` (its drawing);
//! - `overlays/`: the help and the prompts, a stack over the screen;
//! - `app/`: `App` itself and what the screens share (the clip, resources, fits, the edit
//!   `history`, `save` state); `global.rs`: the handlers of what works on every screen;
//! - `action.rs`: the `actions!` table; `update.rs`: `update`, which dispatches through it;
//! - `jobs/`: decoding, fitting, the analysis and the other slow work, on threads;
//! - `draw.rs`: the whole screen (title, shown screen, flag strip, status line, overlays);
//! - `run.rs`: the event loop: read events, map keys, `update`, draw, perform effects.
//!
//! # Adding an action
//! Add one entry to the `actions!` table in `action.rs` — its variant (with fields), the
//! screen and function that handle it, and its help text — then write that function in the
//! screen's `update.rs`, e.g. `ToggleGrid => frames::toggle_grid, "show or hide the grid";`
//! and `pub fn toggle_grid(app: &mut App)` (fields come as arguments, in order). The enum,
//! the name keymap files bind it by, the help overlay's line and the dispatch all come from
//! the entry. Give it a key in `data/keymap.toml`; a user's `--keymap` file can bind it by the
//! same name. A handler returns `()`, or `Option<Action>` for a follow-up `update` applies
//! next.

pub mod action;
pub mod app;
pub mod draw;
#[cfg(any(test, feature = "test-fixtures"))]
pub mod fixtures;
pub mod global;
pub mod input;
pub mod jobs;
pub mod keymap;
pub mod overlays;
pub mod run;
pub mod screens;
pub mod session_bridge;
pub mod update;
pub mod widgets;

pub use action::Action;
pub use app::{App, FrameImage, FrameProvider};
pub use draw::draw;
pub use input::key_to_action;
pub use keymap::Keymap;
pub use run::run;
pub use update::{apply, update};
