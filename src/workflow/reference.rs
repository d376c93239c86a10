//! The user's reference tables: a folder laid out like `data/` (`lipmap --data DIR`) whose
//! files replace the built-in ones, and the built-ins written out to start such a folder from.

use super::error::{Error, Result};
use crate::alignment::DEFAULT_PHONES_CSV;
use crate::eval::visemes::DEFAULT_VISEMES_TOML;
use crate::landmarks::ibug::DEFAULT_NAMES_CSV;
use crate::measure::indices::DEFAULT_BOUNDS_CSV;
use crate::reference::ReferenceTables;
use std::path::{Path, PathBuf};

/// The phone inventory.
pub const PHONES_FILE: &str = "phones.csv";
/// The phoneme → viseme classes.
pub const VISEMES_FILE: &str = "visemes.toml";
/// The facial-index class bounds.
pub const BOUNDS_FILE: &str = "facial_index_bounds.csv";
/// The iBUG point names and groups.
pub const NAMES_FILE: &str = "ibug68.csv";
/// The TUI's keys (read by the TUI itself when it opens).
pub const KEYMAP_FILE: &str = "keymap.toml";

/// Every file a data folder may hold, with the built-in text it replaces.
const DATA_FILES: [(&str, &str); 5] = [
    (PHONES_FILE, DEFAULT_PHONES_CSV),
    (VISEMES_FILE, DEFAULT_VISEMES_TOML),
    (BOUNDS_FILE, DEFAULT_BOUNDS_CSV),
    (NAMES_FILE, DEFAULT_NAMES_CSV),
    (KEYMAP_FILE, include_str!("../../data/keymap.toml")),
];

/// A data folder read: the tables (built-ins where the folder has no file) and the keymap
/// file when it has one.
#[derive(Clone, Debug)]
pub struct DataFolder {
    pub tables: ReferenceTables,
    pub keymap: Option<PathBuf>,
    /// The files that replaced a built-in, in [`DATA_FILES`] order.
    pub replaced: Vec<PathBuf>,
}

/// Reads the tables a data folder replaces.
///
/// # Errors
/// `dir` not a folder, a folder holding none of the tables (most likely the wrong folder), or
/// a table that does not parse (the error names the file and line).
pub fn read_data_folder(dir: &Path) -> Result<DataFolder> {
    let io_err = |source| Error::Io { path: dir.to_path_buf(), source };
    if !std::fs::metadata(dir).map_err(io_err)?.is_dir() {
        return Err(Error::Invalid(format!(
            "{}: --data names a folder, not a file",
            dir.display()
        )));
    }
    let present = |name: &str| Some(dir.join(name)).filter(|p| p.exists());
    let mut tables = ReferenceTables::builtin();
    if let Some(p) = present(PHONES_FILE) {
        tables.phones = crate::io::phone_table::read_phone_inventory(&p)?;
    }
    if let Some(p) = present(VISEMES_FILE) {
        tables.visemes = crate::io::viseme_table::read_viseme_table(&p)?;
    }
    if let Some(p) = present(BOUNDS_FILE) {
        tables.bounds = crate::io::bounds_table::read_bounds_table(&p)?;
    }
    if let Some(p) = present(NAMES_FILE) {
        tables.names = crate::io::names_table::read_landmark_names(&p)?;
    }
    let replaced: Vec<PathBuf> = DATA_FILES.iter().filter_map(|(name, _)| present(name)).collect();
    if replaced.is_empty() {
        let names: Vec<&str> = DATA_FILES.iter().map(|(n, _)| *n).collect();
        return Err(Error::Invalid(format!(
            "{}: holds none of {}; `lipmap tables --out {}` writes the built-in ones to edit",
            dir.display(),
            names.join(", "),
            dir.display()
        )));
    }
    Ok(DataFolder { tables, keymap: present(KEYMAP_FILE), replaced })
}

/// Writes the built-in tables into `dir` (created when missing) for the user to edit, and
/// returns the files written.
///
/// # Errors
/// A file of the same name already in `dir` (never overwritten: it may hold the user's
/// edits), or the folder or a file that cannot be written.
pub fn write_builtin_tables(dir: &Path) -> Result<Vec<PathBuf>> {
    let io_err = |path: &Path| {
        let path = path.to_path_buf();
        move |source| Error::Io { path, source }
    };
    std::fs::create_dir_all(dir).map_err(io_err(dir))?;
    let targets: Vec<(PathBuf, &str)> =
        DATA_FILES.iter().map(|(name, text)| (dir.join(name), *text)).collect();
    if let Some((p, _)) = targets.iter().find(|(p, _)| p.symlink_metadata().is_ok()) {
        return Err(Error::Invalid(format!(
            "{}: already exists; not overwritten (write into an empty folder)",
            p.display()
        )));
    }
    for (p, text) in &targets {
        crate::io::atomic::write_atomic_bytes(p, text.as_bytes()).map_err(io_err(p))?;
    }
    Ok(targets.into_iter().map(|(p, _)| p).collect())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn written_tables_read_back_as_the_builtins() {
        let dir = tempfile::tempdir().unwrap();
        let written = write_builtin_tables(dir.path()).unwrap();
        assert_eq!(written.len(), DATA_FILES.len());
        let folder = read_data_folder(dir.path()).unwrap();
        assert_eq!(folder.tables, ReferenceTables::builtin());
        assert_eq!(folder.replaced, written);
        assert_eq!(folder.keymap, Some(dir.path().join(KEYMAP_FILE)));
        let again = write_builtin_tables(dir.path()).unwrap_err().to_string();
        assert!(again.contains("already exists"), "{again}");
    }

    #[test]
    fn a_folder_replaces_only_the_tables_it_holds() {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join(NAMES_FILE), DEFAULT_NAMES_CSV.replace("nose tip", "tip"))
            .unwrap();
        let folder = read_data_folder(dir.path()).unwrap();
        assert_eq!(folder.tables.names.name(30), "tip");
        assert_eq!(folder.tables.visemes, ReferenceTables::builtin().visemes);
        assert_eq!(folder.keymap, None);
        std::fs::write(
            dir.path().join(PHONES_FILE),
            DEFAULT_PHONES_CSV.replace("AE,æ a,", "AE,æ,"),
        )
        .unwrap();
        let folder = read_data_folder(dir.path()).unwrap();
        assert_eq!(folder.tables.phones.key_of("a"), "a");
        assert_eq!(folder.tables.names.name(30), "tip");
    }

    #[test]
    fn wrong_folders_and_bad_tables_are_named() {
        let dir = tempfile::tempdir().unwrap();
        let e = read_data_folder(dir.path()).unwrap_err().to_string();
        assert!(
            e.contains("holds none of phones.csv, visemes.toml")
                && e.contains("lipmap tables --out"),
            "{e}"
        );
        let file = dir.path().join(VISEMES_FILE);
        std::fs::write(&file, "[[classes]]\nid = \"x\"\n").unwrap();
        let e = read_data_folder(dir.path()).unwrap_err().to_string();
        assert!(e.contains("visemes.toml"), "{e}");
        let e = read_data_folder(&file).unwrap_err().to_string();
        assert!(e.contains("names a folder"), "{e}");
    }
}
