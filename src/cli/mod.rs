//! The command line: clap definitions and one module per subcommand, each a thin front over
//! the core. `main.rs` parses, calls `run`, and maps the outcome to an exit code.

pub mod convert;
pub mod demo_cmd;
pub mod eval_cmd;
pub mod exit;
pub mod export;
pub mod fit_cmd;
pub mod fit_files;
pub mod help_cmd;
pub mod indices;
pub mod map_cmd;
pub mod model_cmd;
pub mod new;
pub mod output;
pub mod phones;
pub mod profile_cmd;
pub mod progress;
pub mod saqp_cmd;
pub mod speech_cmd;
pub mod tables_cmd;
pub mod track_cmd;
pub mod transfer_cmd;
pub mod tui_cmd;
pub mod validate;

pub use exit::Outcome;
pub use tui_cmd::OpenTui;

use anyhow::Result;
use clap::{Parser, Subcommand};
use std::io::Write;

/// lipmap: map a speaker's tracked lip motion onto a 3D head and measure how well it follows.
#[derive(Parser, Debug)]
#[command(name = "lipmap", version, about, long_about = None, disable_help_subcommand = true)]
pub struct Cli {
    /// A folder of reference tables replacing the built-in ones: any of visemes.toml,
    /// facial_index_bounds.csv, ibug68.csv, keymap.toml (`lipmap tables --out DIR` writes them
    /// to edit). Default: $LIPMAP_DATA.
    #[arg(long, global = true, value_name = "DIR")]
    pub data: Option<std::path::PathBuf>,
    #[command(subcommand)]
    pub command: Command,
}

#[derive(Subcommand, Debug)]
pub enum Command {
    /// Generate the built-in synthetic speaker, fit and evaluate it, open the TUI.
    Demo(demo_cmd::DemoArgs),
    /// Open a session in the terminal UI.
    Tui(tui_cmd::TuiArgs),
    /// Create a session from frames, landmarks, an alignment, a head, a model and
    /// optionally a landmark map (or label the head in the TUI later).
    #[command(
        mut_arg("frames", |a| a.required(true)),
        mut_arg("landmarks", |a| a.required_unless_present("track"))
    )]
    New(new::NewArgs),
    /// Add a clip to a session, and/or set its landmark map (--mapping FILE).
    Import(new::ImportArgs),
    /// Fit a session's clips (cached), or landmark files with a model.
    Fit(fit_cmd::FitArgs),
    /// Per-sentence and per-phoneme W/H/P error tables (fits what is not cached).
    Eval(eval_cmd::EvalArgs),
    /// The 12 facial indices of a landmark file, or of a session's speaker and head with the
    /// matching verdict; class bounds from a corpus (--compute-bounds).
    Indices(indices::IndicesArgs),
    /// Export a session's landmarks, fitted meshes (OBJ), tables (CSV) and plots (PNG).
    Export(export::ExportArgs),
    /// Convert landmark files or phone alignments between formats.
    Convert(convert::ConvertArgs),
    /// Side-view lip protrusion: set a clip's crop and reference line, print P per frame.
    Profile(profile_cmd::ProfileArgs),
    /// Print a phone alignment as start,end,phone CSV.
    Phones(phones::PhonesArgs),
    /// Check that files parse; prints `ok` or the error for each.
    Validate(validate::ValidateArgs),
    /// Drive another head (OBJ + landmark map) with a session's fitted motion.
    Transfer(transfer_cmd::TransferArgs),
    /// Build a 3DMM from pose OBJs, or describe a model.
    #[command(subcommand)]
    Model(model_cmd::ModelCommand),
    /// Write the built-in reference tables (visemes, index bounds, point names, keys) to edit.
    Tables(tables_cmd::TablesArgs),
    /// Suggest a session's landmark map from a few labels, or check it against anatomy.
    #[command(subcommand)]
    Map(map_cmd::MapCommand),
    /// Speech-driven mouth motion: train on sessions with audio, evaluate, animate from a WAV.
    #[command(subcommand)]
    Speech(speech_cmd::SpeechCommand),
    /// Track iBUG-68 landmarks through frames with dlib's shape predictor (read by lipmap).
    Track(track_cmd::TrackArgs),
    /// Re-align a corrected frame from its corrected points, and the frames after it until
    /// the tracker agrees again.
    Propagate(track_cmd::PropagateArgs),
    /// Quality of synthesized speech animation (SAQP): cross-validate, train a predictor,
    /// predict a phone sequence's quality.
    #[command(subcommand)]
    Saqp(saqp_cmd::SaqpCommand),
    /// A command's options, or what a term lipmap prints means (`lipmap help omega_m`,
    /// `lipmap help terms`).
    Help(help_cmd::HelpArgs),
}

/// What the binary does once a command has run: exit, or open a session in the TUI (the
/// binary does that, so the command line and the TUI need not know each other).
#[derive(Debug)]
pub enum Next {
    Exit(Outcome),
    /// Open the TUI; exit with `Outcome` when it closes.
    OpenTui(OpenTui, Outcome),
}

/// Runs one parsed command.
pub fn run(cli: Cli) -> Result<Next> {
    let data_keymap = tables_cmd::install_data_folder(cli.data.as_deref())?;
    let command = cli.command;
    let next = match &command {
        Command::Tui(args) => Next::OpenTui(OpenTui::of(args), Outcome::Ok),
        Command::Demo(args) => {
            let stdout = std::io::stdout();
            demo_cmd::run(args, &mut output::TerminalSafe::new(stdout.lock()))?
        }
        _ => return run_command(command).map(Next::Exit),
    };
    Ok(match next {
        // `--keymap` names the keys to change for this run; the data folder's are the default.
        Next::OpenTui(mut open, outcome) => {
            open.keymap = open.keymap.or(data_keymap);
            Next::OpenTui(open, outcome)
        }
        exit => exit,
    })
}

fn run_command(command: Command) -> Result<Outcome> {
    let stdout = std::io::stdout();
    // Names from files (clips, phones, paths) reach the terminal with control characters escaped.
    let mut out = output::TerminalSafe::new(stdout.lock());
    match command {
        Command::Convert(args) => {
            let msg = convert::run(&args)?;
            writeln!(out, "{msg}")?;
            Ok(Outcome::Ok)
        }
        Command::Demo(_) | Command::Tui(_) => unreachable!("dispatched by `run`"),
        Command::New(args) => {
            writeln!(out, "{}", new::run_new(&args)?)?;
            Ok(Outcome::Ok)
        }
        Command::Import(args) => {
            writeln!(out, "{}", new::run_import(&args)?)?;
            Ok(Outcome::Ok)
        }
        Command::Fit(args) => fit_cmd::run(&args, &mut out),
        Command::Export(args) => export::run(&args, &mut out),
        Command::Eval(args) => {
            eval_cmd::run(&args, &mut out)?;
            Ok(Outcome::Ok)
        }
        Command::Indices(args) => {
            indices::run(&args, &mut out)?;
            Ok(Outcome::Ok)
        }
        Command::Profile(args) => {
            profile_cmd::run(&args, &mut out)?;
            Ok(Outcome::Ok)
        }
        Command::Phones(args) => {
            phones::run(&args, &mut out)?;
            Ok(Outcome::Ok)
        }
        Command::Transfer(args) => {
            transfer_cmd::run(&args, &mut out)?;
            Ok(Outcome::Ok)
        }
        Command::Model(cmd) => {
            model_cmd::run(&cmd, &mut out)?;
            Ok(Outcome::Ok)
        }
        Command::Map(cmd) => match map_cmd::run(&cmd, &mut out)? {
            true => Ok(Outcome::Ok),
            false => anyhow::bail!("the landmark map has problems"),
        },
        Command::Speech(cmd) => {
            speech_cmd::run(&cmd, &mut out)?;
            Ok(Outcome::Ok)
        }
        Command::Saqp(cmd) => {
            saqp_cmd::run(&cmd, &mut out)?;
            Ok(Outcome::Ok)
        }
        Command::Track(args) => track_cmd::run_track(&args, &mut out),
        Command::Propagate(args) => {
            track_cmd::run_propagate(&args, &mut out)?;
            Ok(Outcome::Ok)
        }
        Command::Tables(args) => {
            tables_cmd::run(&args, &mut out)?;
            Ok(Outcome::Ok)
        }
        Command::Help(args) => {
            help_cmd::run(&args, &mut out)?;
            Ok(Outcome::Ok)
        }
        Command::Validate(args) => {
            let bad = validate::run(&args, &mut out)?;
            if bad > 0 {
                anyhow::bail!(
                    "{bad} of {} failed validation",
                    output::plural(args.files.len(), "file")
                );
            }
            Ok(Outcome::Ok)
        }
    }
}
