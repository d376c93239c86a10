//! The terminal UI: correct landmarks, label the head, fit, and hunt failing frames.
//! Start at `run::run`; the shape is `App` (state) + `Action` + `update` + `views::draw`.
//!
//! Keys become actions through `keymap`; only `update` changes the `App`; views only read it;
//! slow work runs in `jobs` and replies as actions. `session_bridge` loads an
//! `App` from a session and writes the corrections back.

pub mod action;
pub mod app;
#[cfg(any(test, feature = "test-fixtures"))]
pub mod fixtures;
pub mod head_state;
pub mod jobs;
pub mod keymap;
pub mod save_state;
pub mod update;
pub mod views;
pub mod widgets;

pub use action::Action;
pub use app::{App, FrameImage, FrameProvider};
pub use keymap::Keymap;
pub use update::update;
pub mod run;
pub mod session_bridge;

pub use run::run;
