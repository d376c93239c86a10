//! `lipmap tui SESSION`: the flags of opening a session in the terminal UI. The binary
//! (`main.rs`) opens it: the command line and the TUI do not call each other.

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
    pub graphics: Option<GraphicsArg>,
    /// The clip to open (by name; default the first). `<` and `>` switch clips in the TUI.
    #[arg(long)]
    pub clip: Option<String>,
    /// The tracker's files for re-aligning a frame (`a`) and drawing a face box (`b`).
    #[command(flatten)]
    pub tracker: crate::cli::track_cmd::TrackerArgs,
}

/// `--graphics`: the names the TUI's graphics choice parses.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum GraphicsArg {
    /// Query the terminal; never inside tmux or over SSH.
    Auto,
    Halfblocks,
    Sixel,
    Kitty,
    Iterm2,
}

impl GraphicsArg {
    /// The mode's name as the flag spells it.
    pub fn name(self) -> &'static str {
        match self {
            GraphicsArg::Auto => "auto",
            GraphicsArg::Halfblocks => "halfblocks",
            GraphicsArg::Sixel => "sixel",
            GraphicsArg::Kitty => "kitty",
            GraphicsArg::Iterm2 => "iterm2",
        }
    }
}

/// A session for the binary to open in the TUI once a command is done.
#[derive(Clone, Debug, PartialEq)]
pub struct OpenTui {
    pub session: PathBuf,
    pub keymap: Option<PathBuf>,
    pub graphics: Option<GraphicsArg>,
    pub clip: Option<String>,
    pub tracker: crate::workflow::track::TrackerFiles,
}

impl OpenTui {
    /// What `lipmap tui` asks for.
    pub fn of(a: &TuiArgs) -> Self {
        Self {
            session: crate::workflow::session_path(&a.session),
            keymap: a.keymap.clone(),
            graphics: a.graphics,
            clip: a.clip.clone(),
            tracker: a.tracker.files(),
        }
    }
}
