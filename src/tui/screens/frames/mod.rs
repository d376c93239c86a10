//! The frames screen: the frame with its 68 landmarks, corrected with keys and the mouse.
//! `state` is what it keeps, `update` its handlers (named in the `actions!` table),
//! `tracking` the handlers that use lipmap's tracker (re-align, the face box), `view` its
//! drawing, which the fit screen reuses for its image.

pub mod state;
pub mod tracking;
pub mod update;
pub mod view;

pub use state::{FaceBoxDraft, FrameCache, FramesScreen, ImageView, Scope};
