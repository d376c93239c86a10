//! Exit codes, in one place (documented in README): 0 ok, 1 some frames skipped or failed,
//! 2 usage or fatal error. A closed stdout pipe is not an error.

use std::process::ExitCode;

/// How a command ended when it did not fail outright.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Outcome {
    /// Everything asked for was done.
    Ok,
    /// The command finished but skipped or flagged some frames.
    Partial,
}

pub const EXIT_OK: u8 = 0;
pub const EXIT_PARTIAL: u8 = 1;
pub const EXIT_FATAL: u8 = 2;

impl From<Outcome> for ExitCode {
    fn from(o: Outcome) -> Self {
        ExitCode::from(match o {
            Outcome::Ok => EXIT_OK,
            Outcome::Partial => EXIT_PARTIAL,
        })
    }
}

/// True when the error chain ends in a broken pipe (e.g. `lipmap phones f | head`).
pub fn is_broken_pipe(err: &anyhow::Error) -> bool {
    err.chain().any(|e| {
        e.downcast_ref::<std::io::Error>()
            .is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)
    })
}
