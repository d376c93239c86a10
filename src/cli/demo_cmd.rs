//! `lipmap demo`: generate the built-in synthetic speaker, make a session of it, fit and
//! evaluate it headless, print the per-phoneme table, then open the TUI (unless `--no-tui`).

use crate::cli::exit::Outcome;
use crate::cli::output::{FormatArgs, NormaliseArg, write_tables};
use crate::demo::{self, DemoOptions};
use crate::workflow::{self, EvalRequest};
use anyhow::Result;
use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::time::Instant;

/// Generate the synthetic demo speaker and run the whole pipeline on it.
#[derive(clap::Args, Debug)]
pub struct DemoArgs {
    /// Output folder (its session file is DIR/demo.lipmap.json).
    #[arg(long, default_value = "sessions/demo")]
    pub out: PathBuf,
    /// Random seed (the default reproduces the documented figures).
    #[arg(long, default_value_t = demo::DEFAULT_SEED)]
    pub seed: u64,
    /// Speakers to make; speaker 0 is the head itself, the others fall in other classes of
    /// the vertical-mouth-height and mouth-width indices (one session each).
    #[arg(long, default_value_t = 1)]
    pub speakers: usize,
    /// GRID sentences per speaker.
    #[arg(long, default_value_t = 4)]
    pub sentences: usize,
    /// Skip rendering video frames (the landmarks, alignments and audio are still written):
    /// a large corpus for `lipmap saqp` or `lipmap speech` in a fraction of the time.
    #[arg(long)]
    pub no_frames: bool,
    /// Fraction of frames (0 to 1) given a gross tracker error, at least one per sentence.
    #[arg(long, value_name = "RATE", default_value_t = DemoOptions::default().gross_error_rate)]
    pub tracker_errors: f64,
    /// Run headless: print the tables and exit instead of opening the TUI.
    #[arg(long)]
    pub no_tui: bool,
    /// How video and head trajectories are compared in the printed tables.
    #[arg(long, value_enum, default_value_t = NormaliseArg::MinMax)]
    pub normalise: NormaliseArg,
    #[command(flatten)]
    pub output: FormatArgs,
}

pub fn run(a: &DemoArgs, out: &mut dyn Write) -> Result<crate::cli::Next> {
    let t0 = Instant::now();
    if !(0.0..=1.0).contains(&a.tracker_errors) {
        anyhow::bail!("--tracker-errors {}: must be a fraction between 0 and 1", a.tracker_errors);
    }
    let defaults = DemoOptions::default();
    let opts = DemoOptions {
        seed: a.seed,
        speakers: a.speakers.max(1),
        sentences: a.sentences.max(1),
        out_dir: a.out.clone(),
        write_frames: defaults.write_frames && !a.no_frames,
        side_view: defaults.side_view && !a.no_frames,
        gross_error_rate: a.tracker_errors,
        ..defaults
    };
    crate::cli::output::eprint_line(format_args!(
        "lipmap demo: generating the synthetic speaker into {} ...",
        a.out.display()
    ));
    let generated = demo::generate(&opts)?;
    let sessions = workflow::demo::write_demo_sessions(&generated)?;
    let t_gen = t0.elapsed();
    let mut any_failed = false;
    // JSON is one document for every speaker: their tables are gathered and written once.
    let json = a.output.format() == crate::cli::output::TableFormat::Json;
    let mut gathered: Vec<crate::eval::Table> = Vec::new();
    for (k, path) in sessions.iter().enumerate() {
        // Evaluated as `lipmap eval` does: under the lock, the new fits saved.
        let mut opened = workflow::open_for_read_at(path)?;
        crate::cli::progress::print_warnings(&opened.notices);
        let req = EvalRequest { normalisation: a.normalise.into(), ..EvalRequest::default() };
        let bar = crate::cli::progress::frames_bar(0, "fitting");
        // The demo prints its tables; each clip's flags are for `lipmap eval`.
        let evaluated = workflow::evaluate_session(
            &mut opened,
            &req,
            &crate::cli::progress::show_on(&bar),
            &mut |_| {},
        )?;
        crate::cli::progress::print_warnings(&evaluated.warnings);
        any_failed |= evaluated.any_failed();
        let report = &evaluated.report;
        if json {
            let speaker = format!("speaker {k}");
            gathered.push(report.sentences.clone().for_item(&speaker));
            gathered.push(report.phonemes.clone().for_item(&speaker));
            continue;
        }
        if sessions.len() > 1 {
            writeln!(out, "== speaker {k}: {}", path.display())?;
        }
        write_tables(&[&report.sentences, &report.phonemes], a.output.format(), out)?;
    }
    if json {
        write_tables(&gathered.iter().collect::<Vec<_>>(), a.output.format(), out)?;
    }
    crate::cli::output::eprint_line(format_args!(
        "lipmap demo: generated in {:.1} s, fitted and evaluated in {:.1} s; session {}",
        t_gen.as_secs_f64(),
        (t0.elapsed() - t_gen).as_secs_f64(),
        sessions[0].display()
    ));
    let interactive = std::io::stdin().is_terminal() && std::io::stdout().is_terminal();
    let outcome = if any_failed { Outcome::Partial } else { Outcome::Ok };
    if !a.no_tui {
        if interactive {
            let open = crate::cli::OpenTui {
                session: sessions[0].clone(),
                keymap: None,
                graphics: None,
                clip: None,
                tracker: Default::default(),
            };
            return Ok(crate::cli::Next::OpenTui(open, outcome));
        }
        crate::cli::output::eprint_line(format_args!(
            "lipmap demo: not a terminal, so the TUI is not opened; run `lipmap tui {}`",
            sessions[0].display()
        ));
    }
    Ok(crate::cli::Next::Exit(outcome))
}
