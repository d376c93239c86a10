//! Facial-index class-bound tables on disk: TOML for `.toml` files, CSV otherwise. The
//! parsing itself is the core's ([`BoundsTable::from_csv_str`], [`BoundsTable::from_toml_str`]);
//! this module reads and writes the file and names it in errors.

use super::error::{FormatError, Location, Result};
use crate::measure::indices::{BoundsError, BoundsTable};
use std::path::Path;

fn is_toml(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("toml"))
}

/// A core [`BoundsError`] naming the file it came from (line and field kept).
pub fn bounds_error_in(path: &Path, e: BoundsError) -> FormatError {
    match (e.line, e.field) {
        (Some(l), Some(f)) => FormatError::at_line(path, l, format!("field `{f}`: {}", e.message)),
        (Some(l), None) => FormatError::at_line(path, l, e.message),
        (None, Some(f)) => FormatError::new(path, Location::Field(f), e.message),
        (None, None) => FormatError::whole(path, e.message),
    }
}

/// Parses `text` read from `path` (the extension picks TOML or CSV).
///
/// # Errors
/// A parse error naming the file and the line or field.
pub fn parse_bounds_table(path: &Path, text: &str) -> Result<BoundsTable> {
    let parsed = if is_toml(path) {
        BoundsTable::from_toml_str(text)
    } else {
        BoundsTable::from_csv_str(text)
    };
    parsed.map_err(|e| bounds_error_in(path, e))
}

/// Reads a user's bounds table.
///
/// # Errors
/// The file unreadable, or a parse error naming the file and the line or field.
pub fn read_bounds_table(path: &Path) -> Result<BoundsTable> {
    let text = super::input::read_input_string(path)?;
    parse_bounds_table(path, &text)
}

/// Writes `table` in the format [`read_bounds_table`] reads back for this path.
///
/// # Errors
/// The write failing.
pub fn write_bounds_table(table: &BoundsTable, path: &Path) -> Result<()> {
    let text = if is_toml(path) { table.to_toml_string() } else { table.to_csv_string() };
    super::atomic::write_atomic_bytes(path, text.as_bytes()).map_err(|e| FormatError::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn errors_name_the_file_line_and_field() {
        let p = Path::new("b.csv");
        let e = parse_bounds_table(p, "index,low,high\nfacial,90,x\n").unwrap_err();
        assert_eq!(e.to_string(), "b.csv:2: field `high`: not a number: `x`");
        let text = "[[bounds]]\nindex = \"facial\"\nlow = \"a\"\nhigh = 2\n";
        let e = parse_bounds_table(Path::new("b.toml"), text).unwrap_err();
        assert!(e.to_string().starts_with("b.toml:3: "), "{e}");
        let e = parse_bounds_table(Path::new("b.csv"), "index,low,high\nfacial,1,2\nfacial,1,2\n");
        assert_eq!(e.unwrap_err().to_string(), "b.csv:3: field `facial`: index listed twice");
    }

    #[test]
    fn both_formats_round_trip_through_files() {
        let dir = tempfile::tempdir().unwrap();
        for name in ["b.csv", "b.toml"] {
            let p = dir.path().join(name);
            write_bounds_table(&BoundsTable::default(), &p).unwrap();
            assert_eq!(read_bounds_table(&p).unwrap(), BoundsTable::default(), "{name}");
        }
    }
}
