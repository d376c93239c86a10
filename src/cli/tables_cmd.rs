//! `lipmap tables --out DIR`: the built-in reference tables written out to edit, and
//! `--data DIR` (every command): a folder of edited tables replacing the built-ins.

use crate::workflow::reference::{read_data_folder, write_builtin_tables};
use anyhow::{Context, Result};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Write the built-in reference tables (phone inventory, viseme classes, facial-index bounds,
/// iBUG point names, TUI keys) into a folder to edit; use the folder with
/// `lipmap --data DIR <command>`.
#[derive(clap::Args, Debug)]
pub struct TablesArgs {
    /// The folder to write into (created when missing; existing files are never overwritten).
    #[arg(long)]
    pub out: PathBuf,
}

/// The environment variable naming a data folder when `--data` is not given.
pub const DATA_ENV: &str = "LIPMAP_DATA";

/// Writes the built-in tables and says where.
pub fn run(a: &TablesArgs, out: &mut impl Write) -> Result<()> {
    let written = write_builtin_tables(&a.out)?;
    for p in &written {
        writeln!(out, "wrote {}", p.display())?;
    }
    writeln!(
        out,
        "edit them (delete those you keep as they are), then: lipmap --data {} eval SESSION",
        a.out.display()
    )?;
    Ok(())
}

/// Installs the tables of `--data DIR` (else `$LIPMAP_DATA`) for this process, and returns the
/// folder's keymap file for the TUI.
pub fn install_data_folder(flag: Option<&Path>) -> Result<Option<PathBuf>> {
    let Some(dir) =
        flag.map(Path::to_path_buf).or_else(|| std::env::var_os(DATA_ENV).map(PathBuf::from))
    else {
        return Ok(None);
    };
    let folder = read_data_folder(&dir).context("--data")?;
    let keymap = folder.keymap.clone();
    crate::reference::install(folder.tables)
        .map_err(|_| anyhow::anyhow!("reference tables were installed twice"))?;
    Ok(keymap)
}
