//! A user's phoneme → viseme table on disk (TOML, the format of `data/visemes.toml`). The
//! parsing is the core's ([`VisemeTable::from_toml_str`]); this module reads the file and
//! names it in errors.

use super::error::{FormatError, Result};
use crate::eval::VisemeTable;
use std::path::Path;

/// Reads a viseme table from `path`.
///
/// # Errors
/// The file unreadable, or a parse error naming the file (and the line when TOML gives one).
pub fn read_viseme_table(path: &Path) -> Result<VisemeTable> {
    let text = super::input::read_input_string(path)?;
    VisemeTable::from_toml_str(&text).map_err(|e| match e.line {
        Some(l) => FormatError::at_line(path, l, e.message),
        None => FormatError::whole(path, e.message),
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_file_reads_back_and_a_bad_one_is_named() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("v.toml");
        std::fs::write(&p, VisemeTable::default().to_toml_string()).unwrap();
        assert_eq!(read_viseme_table(&p).unwrap(), VisemeTable::default());
        std::fs::write(&p, "[[classes]]\nid = 3\n").unwrap();
        let e = read_viseme_table(&p).unwrap_err().to_string();
        assert!(e.starts_with(&format!("{}:2: ", p.display())), "{e}");
        assert!(read_viseme_table(&dir.path().join("missing.toml")).is_err());
    }
}
