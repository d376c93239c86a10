//! File formats, one module each. Every parser returns `FormatError`, which names the file
//! and the line (or field) at fault, so a bad file never panics and the user knows where.

pub mod error;

pub use error::FormatError;
