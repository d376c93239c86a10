//! lipmap: map a speaker's lip motion, tracked as iBUG-68 landmarks in video, onto a 3D head
//! by fitting a 3D morphable model, and measure how faithfully the 3D lips follow.
//!
//! Layers, one way only: the core (`landmarks`, `alignment`, `model`, `fit`, `measure`,
//! `eval`) never touches files or the terminal; `io` and `session` read and write; `render`,
//! `demo`, `cli` and `tui` sit on top.

pub mod alignment;
pub mod cli;
pub mod demo;
pub mod eval;
pub mod fit;
pub mod io;
pub mod landmarks;
pub mod math;
pub mod measure;
pub mod model;
pub mod plot;
pub mod reference;
pub mod render;
pub mod saqp;
pub mod session;
pub mod speech;
pub mod table_text;
#[cfg(any(test, feature = "test-fixtures"))]
pub mod testdata;
pub mod transfer;
pub mod tui;
pub mod workflow;
