//! The command line: clap definitions and one module per subcommand, each a thin front over
//! the core. `main.rs` parses, calls `run`, and maps the outcome to an exit code.

pub mod exit;
pub mod fit_files;

pub use exit::Outcome;
