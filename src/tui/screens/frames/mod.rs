//! The frames screen: the frame with its 68 landmarks, corrected with keys and the mouse.
//! `state` is what it keeps, `update` its handlers (named in the `actions!` table), `view`
//! its drawing, which the fit screen reuses for its image.

pub mod state;
pub mod update;
pub mod view;

pub use state::{FrameCache, FramesScreen, ImageView, Scope};
