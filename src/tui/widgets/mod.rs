//! TUI building blocks with no view logic: the half-block image widget, terminal graphics
//! protocols, and terminal setup/restore.

pub mod graphics;
pub mod halfblock;
pub mod terminal;
pub mod wrap;
