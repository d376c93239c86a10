//! lipmap: map a speaker's lip motion, tracked as iBUG-68 landmarks in video, onto a 3D head
//! by fitting a 3D morphable model, and measure how faithfully the 3D lips follow.
//!
//! Layers, imports pointing down only (`docs/design.md`; one line per folder in
//! `docs/layout.md`):
//!
//! - fronts: [`cli`] (one file per subcommand) and [`tui`] (the terminal UI), which parse,
//!   present and edit, and never import each other;
//! - use cases: [`workflow`] (every session-level use case as a function with typed results:
//!   opening a session, fitting, evaluating, exporting, validating, indices, heads, side
//!   view, transfer, SAQP, speech) and [`reference`] (the replaceable tables in use, which
//!   only fronts and use cases read and then pass down);
//! - storage and formats: [`session`] (the session file, lock and journal) and [`io`] (one
//!   reader/writer per format);
//! - core, plain values in and out: [`landmarks`], [`alignment`], [`model`], [`fit`],
//!   [`measure`], [`eval`], [`saqp`], [`transfer`], [`speech`], [`track`], [`render`],
//!   [`plot`], [`math`], [`table_text`];
//! - [`demo`], the synthetic speaker generator; [`glossary`], the names of what lipmap
//!   prints and their explanations (`docs/glossary.md`).

pub mod alignment;
pub mod cli;
pub mod demo;
pub mod eval;
pub mod fit;
pub mod glossary;
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
pub mod track;
pub mod transfer;
pub mod tui;
pub mod workflow;
