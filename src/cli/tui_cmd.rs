//! `lipmap tui SESSION`: open a session in the terminal UI.

use crate::cli::new::session_path;
use crate::tui::widgets::graphics::GraphicsChoice;
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
    /// How the frame image is drawn: `auto` asks the terminal for a graphics protocol
    /// (never inside tmux or over SSH) and falls back to half-blocks; the others force one.
    /// Default: $LIPMAP_GRAPHICS, else auto.
    #[arg(long, value_enum, value_name = "MODE")]
    pub graphics: Option<GraphicsChoice>,
    /// The clip to open (by name; default the first). `<` and `>` switch clips in the TUI.
    #[arg(long)]
    pub clip: Option<String>,
}

pub fn run(a: &TuiArgs) -> Result<()> {
    let graphics = GraphicsChoice::from_flag_or_env(a.graphics).map_err(anyhow::Error::msg)?;
    let options =
        crate::tui::run::RunOptions { keymap: a.keymap.clone(), graphics, clip: a.clip.clone() };
    crate::tui::run::run_with(&session_path(&a.session), &options)
}
