//! A user's phone inventory on disk (CSV, the format of `data/phones.csv`). The parsing is the
//! core's ([`PhoneInventory::from_csv_str`]); this module reads the file and names it in
//! errors.

use super::error::{FormatError, Result};
use crate::alignment::PhoneInventory;
use std::path::Path;

/// Reads a phone inventory from `path`.
///
/// # Errors
/// The file unreadable, or a parse error naming the file and line.
pub fn read_phone_inventory(path: &Path) -> Result<PhoneInventory> {
    let text = super::input::read_input_string(path)?;
    PhoneInventory::from_csv_str(&text).map_err(|e| FormatError::at_line(path, e.line, e.message))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::alignment::DEFAULT_PHONES_CSV;

    #[test]
    fn reads_the_builtin_file_and_names_the_line_of_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("phones.csv");
        std::fs::write(&p, DEFAULT_PHONES_CSV.replace("AE,æ a,", "AE,æ,")).unwrap();
        let t = read_phone_inventory(&p).unwrap();
        assert_eq!(t.key_of("æ"), "AE");
        assert_eq!(t.key_of("a"), "a");
        std::fs::write(&p, "phone,ipa,labels\nsil,,\nAA,ɑ,\nAO,ɑ,\n").unwrap();
        let e = read_phone_inventory(&p).unwrap_err().to_string();
        assert!(e.starts_with(&format!("{}:4: ", p.display())), "{e}");
        assert!(e.contains("already names `AA`"), "{e}");
    }
}
