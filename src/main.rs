//! The `lipmap` binary: parse the command line, run the command, map the outcome to an exit
//! code (0 ok, 1 some frames skipped or failed, 2 usage or fatal error; see README).

use clap::Parser;
use lipmap::cli::{Cli, exit};
use std::process::ExitCode;

fn main() -> ExitCode {
    let cli = Cli::parse();
    match lipmap::cli::run(cli) {
        Ok(outcome) => outcome.into(),
        Err(err) if exit::is_broken_pipe(&err) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("lipmap: {}", one_line(&err));
            ExitCode::from(exit::EXIT_FATAL)
        }
    }
}

/// The error and its causes on one line, without repeating a cause already in the message.
fn one_line(err: &anyhow::Error) -> String {
    let mut msg = err.to_string();
    for cause in err.chain().skip(1) {
        let c = cause.to_string();
        if !msg.contains(&c) {
            msg.push_str(": ");
            msg.push_str(&c);
        }
    }
    msg.replace('\n', " ")
}
