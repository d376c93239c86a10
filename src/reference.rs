//! The reference tables a user may replace — the files in `data/`: the phone inventory, the
//! phoneme → viseme classes, the facial-index class bounds and the iBUG point names. The built-ins are embedded
//! at build time; a front may install a user's set once, at start-up, before any table is read
//! (`lipmap --data DIR`). Everything that groups, classes or names by these tables reads
//! [`current`], so one installed set reaches every command and the TUI alike.
//!
//! A process-wide set rather than a parameter threaded through every use case: the tables are
//! the reader's conventions (like a locale), fixed for the life of the process, and the
//! functions that consult them sit many calls below the fronts.

use crate::alignment::PhoneInventory;
use crate::eval::VisemeTable;
use crate::landmarks::LandmarkNames;
use crate::landmarks::ibug::DEFAULT_NAMES_CSV;
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
            names: LandmarkNames::from_csv_str(DEFAULT_NAMES_CSV)
                .expect("the embedded table parses (tested)"),
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
}
