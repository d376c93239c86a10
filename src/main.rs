//! The `lipmap` binary: parse the command line, run the command, open the TUI when the
//! command asks for it (`tui`, `demo`), and map the outcome to an exit code (0 ok, 1 some
//! frames skipped or failed, 2 usage or fatal error; see README).

use clap::Parser;
use lipmap::cli::{Cli, Next, OpenTui, exit};
use lipmap::tui::widgets::graphics::GraphicsChoice;
use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = Cli::parse();
    let result = lipmap::cli::run(cli).and_then(|next| match next {
        Next::Exit(outcome) => Ok(outcome),
        Next::OpenTui(open, outcome) => open_tui(&open).map(|()| outcome),
    });
    match result {
        Ok(outcome) => outcome.into(),
        Err(err) if exit::is_broken_pipe(&err) => ExitCode::SUCCESS,
        Err(err) => {
            lipmap::cli::output::eprint_line(format_args!("lipmap: {}", one_line(&err)));
            ExitCode::from(exit::EXIT_FATAL)
        }
    }
}

/// Opens a session in the TUI as the command line asked.
fn open_tui(open: &OpenTui) -> anyhow::Result<()> {
    let flag = open.graphics.map(|g| g.name().parse::<GraphicsChoice>()).transpose();
    let graphics = GraphicsChoice::from_flag_or_env(flag.map_err(anyhow::Error::msg)?)
        .map_err(anyhow::Error::msg)?;
    let options = lipmap::tui::run::RunOptions {
        keymap: open.keymap.clone(),
        graphics,
        clip: open.clip.clone(),
        tracker: open.tracker.clone(),
    };
    lipmap::tui::run::run_with(&open.session, &options)
}

/// The error and its causes on one line, without repeating a cause already in the message,
/// control characters escaped.
fn one_line(err: &anyhow::Error) -> String {
    let msg = lipmap::workflow::error_chain(&**err).replace('\n', " ");
    lipmap::cli::output::terminal_safe(&msg).into_owned()
}
