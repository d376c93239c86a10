//! The head screen: the head mesh turned, zoomed and labelled (landmark → vertex), or one of
//! the session's transferred heads moving with the current frame. `state`, `update` (and
//! `transferred` for the transferred heads), `view` as every screen.

pub mod state;
pub mod transferred;
pub mod update;
pub mod view;

pub use state::{
    HeadFrame, HeadFraming, HeadScreen, HeadSetup, HeadView, PreparedHead, TransferredHeads,
};
