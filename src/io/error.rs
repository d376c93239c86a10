//! `FormatError`: one-line errors naming the file and the line, column or field.

use std::fmt;
use std::path::{Path, PathBuf};

/// Where in a file a problem was found.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Location {
    None,
    Line(usize),
    LineColumn(usize, usize),
    Field(String),
    Offset(u64),
}

/// A parse or read error in one file, printed as `path:line: message`.
#[derive(Debug)]
pub struct FormatError {
    pub path: PathBuf,
    pub location: Location,
    pub message: String,
}

impl FormatError {
    pub fn new(path: &Path, location: Location, message: impl Into<String>) -> Self {
        Self { path: path.to_path_buf(), location, message: message.into() }
    }

    /// An error at a 1-based line number.
    pub fn at_line(path: &Path, line: usize, message: impl Into<String>) -> Self {
        Self::new(path, Location::Line(line), message)
    }

    /// An error in a named field (a JSON key, an array name inside an .npz, a header field).
    pub fn at_field(path: &Path, field: impl Into<String>, message: impl Into<String>) -> Self {
        Self::new(path, Location::Field(field.into()), message)
    }

    /// An error about the file as a whole.
    pub fn whole(path: &Path, message: impl Into<String>) -> Self {
        Self::new(path, Location::None, message)
    }

    /// An I/O failure reading or writing the file.
    pub fn io(path: &Path, err: std::io::Error) -> Self {
        Self::whole(path, err.to_string())
    }
}

impl fmt::Display for FormatError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let p = self.path.display();
        match &self.location {
            Location::None => write!(f, "{p}: {}", self.message),
            Location::Line(l) => write!(f, "{p}:{l}: {}", self.message),
            Location::LineColumn(l, c) => write!(f, "{p}:{l}:{c}: {}", self.message),
            Location::Field(name) => write!(f, "{p}: field `{name}`: {}", self.message),
            Location::Offset(o) => write!(f, "{p}: byte {o}: {}", self.message),
        }
    }
}

impl std::error::Error for FormatError {}

pub type Result<T> = std::result::Result<T, FormatError>;
