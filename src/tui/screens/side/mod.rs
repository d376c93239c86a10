//! The side screen: the side camera's frame on the lip crop, the upper lip's foremost point
//! (automatic or corrected) and P. `state`, `update`, `view` as every screen.

pub mod state;
pub mod update;
pub mod view;

pub use state::{SideState, SideView};
