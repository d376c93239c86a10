//! Progress bars for loops over frames: indicatif on stderr, hidden when stderr is not a
//! terminal so logs and CI output stay clean.

use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::IsTerminal;

/// A bar counting frames, drawn on stderr only when it is a terminal.
pub fn frames_bar(len: u64, message: &str) -> ProgressBar {
    let bar = ProgressBar::new(len);
    if !std::io::stderr().is_terminal() {
        bar.set_draw_target(ProgressDrawTarget::hidden());
    }
    bar.set_style(
        ProgressStyle::with_template("{msg:24} [{bar:30}] {pos}/{len} frames {per_sec} eta {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar.set_message(message.to_string());
    bar
}

/// Shows a use case's [`Progress`](crate::workflow::Progress) on `bar`: a stage sets the
/// message (and the length when known), steps move it, the end clears it.
pub fn show_on(bar: &ProgressBar) -> impl Fn(crate::workflow::Progress) + Sync + '_ {
    use crate::workflow::Progress;
    move |p| match p {
        Progress::Stage { what, total } => {
            bar.set_message(what);
            if total > 0 {
                bar.set_length(total as u64);
                bar.set_position(0);
            }
        }
        Progress::Steps { done, total } => {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
        }
        Progress::Finished => bar.finish_and_clear(),
    }
}

/// Prints a use case's warnings on stderr, one line each.
pub fn print_warnings(warnings: &[crate::workflow::Warning]) {
    for w in warnings {
        crate::cli::output::eprint_line(crate::cli::output::terminal_safe(&w.0));
    }
}
