//! A user's iBUG point-names file on disk (CSV, the format of `data/ibug68.csv`). The parsing
//! is the core's ([`LandmarkNames::from_csv_str`]); this module reads the file and names it in
//! errors.

use super::error::{FormatError, Result};
use crate::landmarks::LandmarkNames;
use std::path::Path;

/// Reads a names table that lives as long as the process.
///
/// The names borrow from the file's text, and the text is leaked: it is read once at start-up
/// (`lipmap --data DIR`) and used until exit, so nothing would ever free it anyway.
///
/// # Errors
/// The file unreadable, or a parse error naming the file and line.
pub fn read_landmark_names(path: &Path) -> Result<LandmarkNames<'static>> {
    let text: &'static str = super::input::read_input_string(path)?.leak();
    LandmarkNames::from_csv_str(text).map_err(|e| FormatError::at_line(path, e.line, e.message))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::landmarks::ibug::DEFAULT_NAMES_CSV;

    #[test]
    fn reads_the_builtin_file_and_names_the_line_of_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("names.csv");
        std::fs::write(&p, DEFAULT_NAMES_CSV.replace("nose tip", "Nasenspitze")).unwrap();
        assert_eq!(read_landmark_names(&p).unwrap().name(30), "Nasenspitze");
        std::fs::write(&p, "index,group,name\n0,jaw,\n2,jaw,\n").unwrap();
        let e = read_landmark_names(&p).unwrap_err().to_string();
        assert!(e.contains("names.csv") && e.contains(":3") && e.contains("expected 1"), "{e}");
    }
}
