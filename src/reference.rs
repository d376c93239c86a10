//! The reference tables a user may replace — the files in `data/`: the phone inventory, the
//! phoneme → viseme classes, the facial-index class bounds and the iBUG point names. The built-ins are embedded
//! at build time; a front may install a user's set once, at start-up, before any table is read
//! (`lipmap --data DIR`).
//!
//! The set in use is held here for the whole process, but only the fronts and the use cases
//! (`cli`, `tui`, `workflow`) read it ([`current`]): they hand the tables down as arguments
//! (a `VisemeTable` to the evaluation and SAQP, a `BoundsTable` to the indices, the
//! `LandmarkNames` to whatever names points), so the core computes from what it is given, as
//! eos's fitting takes every table it uses. A test below keeps it that way.

use crate::alignment::PhoneInventory;
use crate::eval::VisemeTable;
use crate::landmarks::LandmarkNames;
use crate::measure::BoundsTable;
use std::sync::{LazyLock, OnceLock};

/// One complete set of reference tables.
#[derive(Clone, Debug, PartialEq)]
pub struct ReferenceTables {
    /// Phone labels in any symbol set → one key per phone.
    pub phones: PhoneInventory,
    pub visemes: VisemeTable,
    pub bounds: BoundsTable,
    /// Names borrowed from text that lives as long as the process (the embedded CSV, or a
    /// user's file read once at start-up).
    pub names: LandmarkNames<'static>,
}

impl ReferenceTables {
    /// The tables shipped in `data/`.
    pub fn builtin() -> Self {
        Self {
            phones: PhoneInventory::default(),
            visemes: VisemeTable::default(),
            bounds: BoundsTable::default(),
            names: LandmarkNames::builtin(),
        }
    }
}

static BUILTIN: LazyLock<ReferenceTables> = LazyLock::new(ReferenceTables::builtin);
static INSTALLED: OnceLock<ReferenceTables> = OnceLock::new();

/// Makes `tables` the process's reference tables.
///
/// # Errors
/// Gives the tables back when a set was installed already: a second set would make earlier
/// and later output disagree within one run.
pub fn install(tables: ReferenceTables) -> Result<(), Box<ReferenceTables>> {
    INSTALLED.set(tables).map_err(Box::new)
}

/// The installed tables, else the built-ins.
pub fn current() -> &'static ReferenceTables {
    INSTALLED.get().unwrap_or(&BUILTIN)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn builtin_tables_are_the_defaults_of_each_table() {
        let t = ReferenceTables::builtin();
        assert_eq!(t.phones, PhoneInventory::default());
        assert_eq!(t.visemes, VisemeTable::default());
        assert_eq!(t.bounds, BoundsTable::default());
        assert_eq!(t.names.name(60), "inner lip right corner");
        assert_eq!(t.names.name(61), "inner lip 2");
        assert_eq!(t.names.groups.len(), 9);
    }

    #[test]
    fn only_the_fronts_and_the_use_cases_read_the_installed_tables() {
        let src = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("src");
        let allowed = ["cli", "tui", "workflow", "main.rs", "reference.rs"];
        let mut readers = Vec::new();
        let mut stack = vec![src.clone()];
        while let Some(dir) = stack.pop() {
            for entry in std::fs::read_dir(&dir).unwrap().flatten() {
                let path = entry.path();
                let top = path.strip_prefix(&src).unwrap().components().next().unwrap();
                if allowed.contains(&top.as_os_str().to_str().unwrap()) {
                    continue;
                }
                if path.is_dir() {
                    stack.push(path);
                } else if std::fs::read_to_string(&path).unwrap().contains("reference::current") {
                    readers.push(path);
                }
            }
        }
        assert!(readers.is_empty(), "the core reads the process's tables: {readers:?}");
    }
}
