//! `lipmap speech train|eval|animate`: speech-driven mouth motion (the AV-HMM of
//! `crate::speech`) trained on sessions with audio, scored on a session, and animating the
//! session's model (and optionally another head) from a WAV file.

use crate::cli::output::{FormatArgs, NormaliseArg, write_tables};
use crate::cli::progress::print_warnings;
use crate::eval::{Cell, Table};
use crate::workflow::speech::{
    AnimateOutputs, SpeakerAdaptationChoice, SpeechEvaluation, SpeechTrainSettings, TransferHead,
    animate_speech, evaluate_speech, load_speech_model, save_speech_model, train_speech,
};
use crate::workflow::speech_session::record_speech_model;
use anyhow::Result;
use indicatif::{ProgressBar, ProgressDrawTarget, ProgressStyle};
use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};

#[derive(clap::Subcommand, Debug)]
pub enum SpeechCommand {
    /// Train a speech model on every clip with audio of the sessions (fits what is not cached).
    Train(TrainArgs),
    /// AMSE and ACC of a speech model on a session's clips with audio, against the linear
    /// baseline, and the W/H/P tables of the speech-driven head against the video.
    Eval(EvalArgs),
    /// Per-frame coefficients and mouth of the model's head (and whole meshes, or another
    /// head's) driven by a WAV file.
    Animate(AnimateArgs),
}

#[derive(clap::Args, Debug)]
pub struct TrainArgs {
    /// Session files or names.
    #[arg(required = true)]
    pub sessions: Vec<String>,
    /// N, ergodic HMM states.
    #[arg(long, default_value_t = SpeechTrainSettings::default().states)]
    pub states: usize,
    /// M, full-covariance Gaussians per state.
    #[arg(long, default_value_t = SpeechTrainSettings::default().mixtures)]
    pub mixtures: usize,
    /// t_c, audio frames of context on each side.
    #[arg(long, default_value_t = SpeechTrainSettings::default().context)]
    pub context: usize,
    /// The model file to write.
    #[arg(long)]
    pub out: PathBuf,
}

#[derive(clap::Args, Debug)]
pub struct EvalArgs {
    /// A model from `lipmap speech train`.
    pub model: PathBuf,
    /// Session file or name (its clips with audio are scored).
    pub session: String,
    /// How video and head trajectories are put on one scale before comparing.
    #[arg(long, value_enum, default_value_t = NormaliseArg::MinMax)]
    pub normalise: NormaliseArg,
    /// Also print the per-sentence tables.
    #[arg(long)]
    pub sentences: bool,
    /// Score the estimates as the model makes them, without adapting them to the session's
    /// speaker (by default each clip's estimate is adapted to the visual statistics of the
    /// speaker's other clips; docs/speech.md).
    #[arg(long)]
    pub no_speaker_adaptation: bool,
    #[command(flatten)]
    pub output: FormatArgs,
}

#[derive(clap::Args, Debug)]
pub struct AnimateArgs {
    /// A model from `lipmap speech train`.
    pub model: PathBuf,
    /// The speech to animate (WAV, at the model's sample rate or faster).
    #[arg(long)]
    pub audio: PathBuf,
    /// Output folder: coefficients.npy (frames × coefficients) and mouth.npy (frames × 3 per
    /// mouth vertex); shapes.npy with --shapes, head_shapes.npy with --head.
    #[arg(long)]
    pub out: PathBuf,
    /// Also write every frame's whole mesh, shapes.npy (frames × 3N, the model's vertices
    /// x y z): 85 KB a frame on the demo head, 7 GB for an hour.
    #[arg(long)]
    pub shapes: bool,
    /// Another head (OBJ) to carry the motion to; needs --mapping.
    #[arg(long, requires = "mapping")]
    pub head: Option<PathBuf>,
    /// The head's landmark map (eos TOML).
    #[arg(long, requires = "head")]
    pub mapping: Option<PathBuf>,
}

pub fn run(cmd: &SpeechCommand, out: &mut dyn Write) -> Result<()> {
    match cmd {
        SpeechCommand::Train(a) => train(a, out),
        SpeechCommand::Eval(a) => eval(a, out),
        SpeechCommand::Animate(a) => animate(a, out),
    }
}

/// A bar of steps whose unit the stage message names, on stderr when it is a terminal.
fn steps_bar() -> ProgressBar {
    let bar = ProgressBar::new(0);
    if !std::io::stderr().is_terminal() {
        bar.set_draw_target(ProgressDrawTarget::hidden());
    }
    bar.set_style(
        ProgressStyle::with_template("{msg:48} [{bar:30}] {pos}/{len} eta {eta}")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> "),
    );
    bar
}

fn train(a: &TrainArgs, out: &mut dyn Write) -> Result<()> {
    let settings =
        SpeechTrainSettings { states: a.states, mixtures: a.mixtures, context: a.context };
    let bar = steps_bar();
    let progress = crate::cli::progress::show_on(&bar);
    let start = std::time::Instant::now();
    let trained = train_speech(&a.sessions, &settings, &progress)?;
    bar.finish_and_clear();
    print_warnings(&trained.warnings);
    save_speech_model(&a.out, &trained.file)?;
    print_warnings(&record_speech_model(&a.sessions, &a.out));
    let report = &trained.file.speech.report;
    writeln!(
        out,
        "trained on {} clips ({} frames) in {:.1} s: {} states × {} mixtures; wrote {}",
        trained.clips,
        trained.frames,
        start.elapsed().as_secs_f64(),
        trained.file.speech.hmm.n_states(),
        trained.file.speech.hmm.n_mixtures(),
        a.out.display()
    )?;
    match &trained.kept_run {
        Some(k) => {
            writeln!(
                out,
                "Baum-Welch from k-means on the {} clips kept for the held-out estimate: {}",
                k.clips,
                stopping_reason(&k.report)
            )?;
            writeln!(
                out,
                "then on all {} clips, continuing from that model: {}",
                trained.clips,
                stopping_reason(report)
            )?;
        }
        None => writeln!(out, "Baum-Welch from k-means: {}", stopping_reason(report))?,
    }
    match &trained.file.held_out {
        Some(h) => {
            writeln!(
                out,
                "held out ({} clips, {} frames, not trained on): AV-HMM ACC {:.3} AMSE {:.3}; linear baseline ACC {:.3} AMSE {:.3}",
                h.clips, h.frames, h.hmm.acc, h.hmm.amse, h.linear.acc, h.linear.amse
            )?;
            writeln!(
                out,
                "training fit ({} trained clips, same model): AV-HMM ACC {:.3} AMSE {:.3}; linear baseline ACC {:.3} AMSE {:.3}",
                h.training_clips,
                h.training_hmm.acc,
                h.training_hmm.amse,
                h.training_linear.acc,
                h.training_linear.amse
            )?;
            if h.hmm.acc <= h.linear.acc {
                writeln!(
                    out,
                    "note: on held-out clips the AV-HMM does not beat the linear baseline; more sentences (or fewer --states) help"
                )?;
            }
        }
        None => writeln!(
            out,
            "no held-out estimate: fewer than 10 clips (every fifth clip is held out to score a model trained on the rest); score another session with `lipmap speech eval`"
        )?,
    }
    Ok(())
}

/// Why Baum–Welch stopped, from its log-likelihoods per frame (the initial model's first);
/// a run of at most two iterations says what that means.
fn stopping_reason(report: &crate::speech::TrainReport) -> String {
    let ll = &report.log_likelihood_per_frame;
    let iterations = ll.len().saturating_sub(1);
    let gain = match ll.as_slice() {
        [.., a, b] => b - a,
        _ => 0.0,
    };
    let first = ll.first().copied().unwrap_or(0.0);
    let last = ll.last().copied().unwrap_or(0.0);
    if report.converged {
        format!(
            "stopped after {iterations} iteration{}: the last raised the log-likelihood by {gain:.3} nats/frame, below the tolerance {} ({first:.2} → {last:.2} nats/frame){}",
            if iterations == 1 { "" } else { "s" },
            crate::speech::TrainOptions::default().tolerance,
            if iterations <= 2 {
                "; the start was already close to a local optimum, so more iterations would change the model by less than that"
            } else {
                ""
            }
        )
    } else {
        format!("stopped at the cap of {iterations} iterations ({first:.2} → {last:.2} nats/frame)")
    }
}

fn eval(a: &EvalArgs, out: &mut dyn Write) -> Result<()> {
    let model = load_speech_model(&a.model)?;
    let bar = crate::cli::progress::frames_bar(0, "fitting");
    let progress = crate::cli::progress::show_on(&bar);
    let adaptation = if a.no_speaker_adaptation {
        SpeakerAdaptationChoice::Off
    } else {
        SpeakerAdaptationChoice::OtherClips
    };
    let e = evaluate_speech(&model, &a.session, a.normalise.into(), adaptation, &progress)?;
    bar.finish_and_clear();
    print_warnings(&e.warnings);
    print_warnings(&record_speech_model(std::slice::from_ref(&a.session), &a.model));
    let o = e.overlap;
    if o.trained_on > 0 {
        crate::cli::output::eprint_line(format_args!(
            "lipmap: warning: {} of the {} clips scored were in the model's training set (the same audio): these are not held-out figures",
            o.trained_on, o.scored
        ));
    }
    let scores = scores_table(&e);
    let mut tables = vec![&scores];
    let titled = |t: &Table, key: &str, who: &str| {
        let mut t = t.clone().keyed(key);
        t.title = format!("{} — {who}", t.title);
        t
    };
    let phonemes = [
        titled(&e.report_hmm.phonemes, "phonemes_hmm", "head driven by the AV-HMM"),
        titled(&e.report_linear.phonemes, "phonemes_linear", "head driven by the linear baseline"),
        titled(&e.report_fitted.phonemes, "phonemes_fitted", "fitted head (from the video)"),
    ];
    let sentences = [
        titled(&e.report_hmm.sentences, "sentences_hmm", "head driven by the AV-HMM"),
        titled(
            &e.report_linear.sentences,
            "sentences_linear",
            "head driven by the linear baseline",
        ),
    ];
    if a.sentences {
        tables.extend(sentences.iter());
    }
    tables.extend(phonemes.iter());
    write_tables(&tables, a.output.format(), out)
}

fn scores_table(e: &SpeechEvaluation) -> Table {
    let headers = ["estimator", "AMSE", "ACC", "frames"].map(String::from).to_vec();
    let mut t = Table::new(
        format!("Visual parameters estimated from the audio of {} clips", e.clips),
        headers,
    )
    .keyed("scores");
    for (name, s) in [("AV-HMM", e.hmm), ("linear baseline", e.linear)] {
        t.rows.push(vec![
            Cell::Text(name.into()),
            Cell::Num(s.amse),
            Cell::Num(s.acc),
            Cell::Int(e.frames as i64),
        ]);
    }
    t.notes.push(
        "AMSE: mean square error over each parameter's variance (Terissi et al. eq. 6, lower is better); ACC: mean correlation (eq. 7, higher is better)"
            .into(),
    );
    t.notes.push(match e.adaptation {
        SpeakerAdaptationChoice::OtherClips => "each clip's estimates adapted to the session's speaker from the visual truth of its other clips (--no-speaker-adaptation: as the model makes them)".into(),
        SpeakerAdaptationChoice::Off => "estimates as the model makes them, not adapted to the session's speaker".into(),
    });
    let o = e.overlap;
    t.notes.push(if o.trained_on == 0 {
        format!("held out: none of the {} clips was in the model's training set", o.scored)
    } else {
        format!(
            "NOT held out: {} of the {} clips were in the model's training set",
            o.trained_on, o.scored
        )
    });
    t
}

fn animate(a: &AnimateArgs, out: &mut dyn Write) -> Result<()> {
    let model = load_speech_model(&a.model)?;
    let head =
        a.head.as_deref().zip(a.mapping.as_deref()).map(|(obj, map)| TransferHead { obj, map });
    let outputs = AnimateOutputs { shapes: a.shapes, head };
    let bar = steps_bar();
    let progress = crate::cli::progress::show_on(&bar);
    let files = animate_speech(&model, &a.audio, &outputs, &a.out, &progress)?;
    bar.finish_and_clear();
    let mut wrote =
        vec![files.coefficients.display().to_string(), files.mouth.display().to_string()];
    wrote.extend(files.shapes.as_ref().map(|p| p.display().to_string()));
    writeln!(
        out,
        "{} frames at {} fps from {}: wrote {}",
        files.frames,
        files.fps,
        a.audio.display(),
        wrote.join(", ")
    )?;
    if let Some(path) = &files.head_shapes {
        writeln!(out, "transferred to {}: wrote {}", display(a.head.as_deref()), path.display())?;
    }
    Ok(())
}

fn display(p: Option<&Path>) -> String {
    p.map_or_else(String::new, |p| p.display().to_string())
}
