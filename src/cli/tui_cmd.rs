//! `lipmap tui SESSION`: open a session in the terminal UI.

use crate::cli::new::session_path;
use anyhow::Result;
use std::path::PathBuf;

/// Open a session in the terminal UI (frames, head, fit and analysis views).
#[derive(clap::Args, Debug)]
pub struct TuiArgs {
    /// Session file or name.
    pub session: String,
    /// A TOML keymap overriding the default keys (only the keys it names).
    #[arg(long)]
    pub keymap: Option<PathBuf>,
}

pub fn run(a: &TuiArgs) -> Result<()> {
    crate::tui::run::run(&session_path(&a.session), a.keymap.as_deref())
}
