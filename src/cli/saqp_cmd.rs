//! `lipmap saqp cv|train|predict|markers`: quality prediction of synthesized speech
//! animation (Ma & Deng's SAQP, `crate::saqp`) on the fitted clips of sessions.

use crate::cli::output::{FormatArgs, plural, write_tables};
use crate::cli::progress::{frames_bar, print_warnings, show_on};
use crate::eval::{Cell, Table};
use crate::glossary::names::{FILLED_FRAMES, MOUTH_WEIGHT, SATF_ERROR, SMOOTHING_WEIGHT};
use crate::saqp::{CvOptions, SatfParams, SynthKind};
use crate::workflow::saqp::{
    CorpusOptions, SaqpSettings, cross_validate_corpus, held_out_table, load_predictor,
    marker_vertices, models_table, omega_table, predict_quality, regions_table, save_predictor,
    session_corpus, synths_table, train_predictor, write_quality_chart,
};
use anyhow::Result;
use std::io::Write;
use std::path::PathBuf;

#[derive(clap::Subcommand, Debug)]
pub enum SaqpCommand {
    /// Cross-validate quality prediction on the sessions' clips with phone alignments:
    /// how well predicted quality follows the ground truth on held-out sentences.
    Cv(CvArgs),
    /// Train a quality predictor for one synthesizer and save it.
    Train(TrainArgs),
    /// Predict the quality a trained predictor gives a phone sequence.
    Predict(PredictArgs),
    /// The model vertices (markers) whose motion measures quality: the vertices a
    /// --synth-files CSV must give.
    Markers(MarkersArgs),
}

/// A synthesizer to learn quality for.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum SynthArg {
    /// Key shapes at phone centres, interpolated.
    Keyframe,
    /// Per-phone trajectory models smoothed by the corpus's motion statistics.
    Trajectory,
    /// Real motion units of the corpus joined at phone boundaries.
    Concat,
    /// Your own synthesizer's motion from --synth-files.
    External,
}

impl From<SynthArg> for SynthKind {
    fn from(s: SynthArg) -> Self {
        match s {
            SynthArg::Keyframe => SynthKind::Keyframe,
            SynthArg::Trajectory => SynthKind::Trajectory,
            SynthArg::Concat => SynthKind::Concatenative,
            SynthArg::External => SynthKind::External,
        }
    }
}

/// What the cross-validation learns and how.
#[derive(clap::Args, Debug)]
pub struct LearnArgs {
    /// Session files or names (one model and landmark map for all).
    #[arg(required = true)]
    pub sessions: Vec<String>,
    /// Your synthesizer's motion: DIR/CLIP.csv (frame,vertex,x,y,z for the vertices of
    /// `lipmap saqp markers`) or DIR/CLIP/ of OBJs in the model's vertex order, one per frame.
    #[arg(long, value_name = "DIR")]
    pub synth_files: Option<PathBuf>,
    /// Random seed of the held-out split and sub-corpora.
    #[arg(long, default_value_t = CvOptions::default().seed)]
    pub seed: u64,
    /// Fraction of sentences held out for testing.
    #[arg(long, default_value_t = CvOptions::default().test_fraction)]
    pub test_fraction: f64,
    /// SATF smoothing λ; with --order, fixes what cross-validation would choose.
    #[arg(long, requires = "order")]
    pub lambda: Option<f64>,
    /// SATF smoothing order (1 or 2); needs --lambda.
    #[arg(long, requires = "lambda")]
    pub order: Option<usize>,
    /// ω_m, the weight of the mouth markers; default: chosen by cross-validation.
    #[arg(long)]
    pub omega_m: Option<f64>,
    /// Take frames flagged as mis-tracked (crossed lips, a broken lip shape, a high fit
    /// residual) as ground truth as they are (default: bridge them from their neighbours,
    /// so a tracker's gross error is not scored as the truth).
    #[arg(long)]
    pub keep_flagged: bool,
}

impl LearnArgs {
    fn settings(&self, synths: Vec<SynthKind>) -> Result<SaqpSettings> {
        if !(self.test_fraction > 0.0 && self.test_fraction < 1.0) {
            anyhow::bail!("--test-fraction {}: must be between 0 and 1", self.test_fraction);
        }
        if let Some(w) = self.omega_m.filter(|w| !(w.is_finite() && *w > 0.0)) {
            anyhow::bail!("--omega-m {w}: must be a positive number");
        }
        let satf = match (self.lambda, self.order) {
            (Some(lambda), Some(order)) => {
                let satf = SatfParams { lambda, order };
                satf.check().map_err(|m| anyhow::anyhow!("--{m}"))?;
                Some(satf)
            }
            _ => None,
        };
        let cv = CvOptions {
            seed: self.seed,
            test_fraction: self.test_fraction,
            satf,
            omega_m: self.omega_m,
            synths,
            ..CvOptions::default()
        };
        Ok(SaqpSettings {
            corpus: CorpusOptions { keep_flagged: self.keep_flagged },
            cv,
            synth_files: self.synth_files.clone(),
        })
    }
}

#[derive(clap::Args, Debug)]
pub struct CvArgs {
    #[command(flatten)]
    pub learn: LearnArgs,
    /// Synthesizers to learn (comma-separated); default: the three built-in ones, and
    /// `external` with --synth-files.
    #[arg(long, value_enum, value_delimiter = ',')]
    pub synth: Vec<SynthArg>,
    /// Also list every held-out sentence.
    #[arg(long)]
    pub sentences: bool,
    /// Write the paper's Fig. 8 (held-out ground truth and prediction ± σ) as a PNG.
    #[arg(long, value_name = "PNG")]
    pub plot: Option<PathBuf>,
    #[command(flatten)]
    pub output: FormatArgs,
}

#[derive(clap::Args, Debug)]
pub struct TrainArgs {
    #[command(flatten)]
    pub learn: LearnArgs,
    /// The synthesizer whose quality the predictor scores.
    #[arg(long, value_enum, default_value_t = SynthArg::Trajectory)]
    pub synth: SynthArg,
    /// The predictor file to write.
    #[arg(long)]
    pub out: PathBuf,
    /// Save the predictor even when it shows no skill on the held-out sentences (its
    /// scores would say no more than the training mean).
    #[arg(long)]
    pub allow_no_skill: bool,
}

#[derive(clap::Args, Debug)]
pub struct PredictArgs {
    /// A predictor from `lipmap saqp train`.
    pub model: PathBuf,
    /// Timed phones to score (TextGrid, HTK .lab or start,end,phone CSV).
    #[arg(long, required = true, num_args = 1..)]
    pub phones: Vec<PathBuf>,
    #[command(flatten)]
    pub output: FormatArgs,
}

#[derive(clap::Args, Debug)]
pub struct MarkersArgs {
    /// Session files or names, as given to `lipmap saqp cv`.
    #[arg(required = true)]
    pub sessions: Vec<String>,
    #[command(flatten)]
    pub output: FormatArgs,
}

pub fn run(cmd: &SaqpCommand, out: &mut dyn Write) -> Result<()> {
    match cmd {
        SaqpCommand::Cv(a) => cv(a, out),
        SaqpCommand::Train(a) => train(a, out),
        SaqpCommand::Predict(a) => predict(a, out),
        SaqpCommand::Markers(a) => markers(a, out),
    }
}

/// The synthesizers `cv` learns: those named, else the built-in three and the external one
/// when its files are given.
fn chosen_synths(a: &CvArgs) -> Vec<SynthKind> {
    if !a.synth.is_empty() {
        let mut v: Vec<SynthKind> = a.synth.iter().map(|&s| s.into()).collect();
        v.dedup();
        return v;
    }
    let mut v = SynthKind::BUILT_IN.to_vec();
    if a.learn.synth_files.is_some() {
        v.push(SynthKind::External);
    }
    v
}

fn cv(a: &CvArgs, out: &mut dyn Write) -> Result<()> {
    let settings = a.learn.settings(chosen_synths(a))?;
    let bar = frames_bar(0, "fitting");
    let sc = session_corpus(&a.learn.sessions, &settings.corpus, &show_on(&bar))?;
    bar.finish_and_clear();
    crate::cli::output::eprint_line(format_args!(
        "cross-validating on {} ({} frames, {} {FILLED_FRAMES}{}; {})…",
        plural(sc.corpus.sentences.len(), "sentence"),
        sc.frames,
        sc.bridged,
        if a.learn.keep_flagged { ": failed fits" } else { ": failed fits and mis-tracked frames" },
        plural(settings.cv.synths.len(), "synthesizer")
    ));
    let start = std::time::Instant::now();
    let result = cross_validate_corpus(sc, &settings)?;
    print_warnings(&result.warnings);
    let report = &result.report;
    let regions = regions_table(report);
    let mut synths = synths_table(report);
    synths.notes.push(format!(
        "{} sentences, seed {}, {:.1} s",
        result.sentences,
        settings.cv.seed,
        start.elapsed().as_secs_f64()
    ));
    let (models, omega, held) = (models_table(report), omega_table(report), held_out_table(report));
    let mut tables = vec![&synths, &models, &omega, &regions];
    if a.sentences {
        tables.push(&held);
    }
    write_tables(&tables, a.output.format(), out)?;
    if let Some(png) = &a.plot {
        write_quality_chart(png, report)?;
        crate::cli::output::eprint_line(format_args!("wrote {}", png.display()));
    }
    Ok(())
}

fn train(a: &TrainArgs, out: &mut dyn Write) -> Result<()> {
    let synth: SynthKind = a.synth.into();
    if synth == SynthKind::External && a.learn.synth_files.is_none() {
        anyhow::bail!("--synth external needs --synth-files DIR (your synthesizer's motion)");
    }
    let settings = a.learn.settings(vec![synth])?;
    let bar = frames_bar(0, "fitting");
    let trained = train_predictor(&a.learn.sessions, &settings, synth, &show_on(&bar))?;
    bar.finish_and_clear();
    print_warnings(&trained.warnings);
    let p = &trained.file.predictor;
    if !p.skill.has_skill() && !a.allow_no_skill {
        anyhow::bail!(
            "the {} quality predictor has no skill: {}; not saved (--allow-no-skill saves it anyway)",
            synth.name(),
            p.skill.describe()
        );
    }
    save_predictor(&a.out, &trained.file)?;
    writeln!(
        out,
        "trained the {} quality predictor on {} sentences ({} kept; r {:.3}, {}); {SMOOTHING_WEIGHT} {} order {}, {MOUTH_WEIGHT} {}; wrote {}",
        synth.name(),
        trained.file.sentences,
        p.calibration.name(),
        p.skill.pearson_r,
        p.skill.describe(),
        p.satf.lambda,
        p.satf.order,
        p.omega_m,
        a.out.display()
    )?;
    Ok(())
}

fn predict(a: &PredictArgs, out: &mut dyn Write) -> Result<()> {
    let model = load_predictor(&a.model)?;
    let headers =
        ["phones", "E", "coverage", "predicted", "sigma", "unseen phones", "extrapolated"]
            .map(String::from)
            .to_vec();
    let mut t = Table::new(
        format!(
            "Predicted quality (Likert 1 worst - 5 best) of {} motion",
            model.predictor.synth.name()
        ),
        headers,
    )
    .keyed("predictions")
    .labelled("E", SATF_ERROR)
    .labelled("predicted", "predicted (Likert)")
    .labelled("sigma", "σ");
    let (mut any_unseen, mut any_extrapolated) = (false, false);
    for file in &a.phones {
        let q = predict_quality(&model, file)?;
        any_unseen |= !q.unseen.is_empty();
        any_extrapolated |= !q.extrapolated.is_empty();
        t.push_row(vec![
            Cell::Text(file.display().to_string()),
            Cell::Num(q.e),
            Cell::Num(q.coverage),
            Cell::Num(q.prediction.mean),
            Cell::Num(q.prediction.std()),
            Cell::Text(q.unseen.join(" ")),
            Cell::Text(q.extrapolated.join(" ")),
        ]);
    }
    t.notes.push(format!(
        "{SATF_ERROR}: how poorly the training corpus of {} sentences fits the sequence's phones; coverage: how well their recorded phones match its contexts (0–1); σ: the prediction's standard deviation (Likert points)",
        model.sentences
    ));
    let skill = &model.predictor.skill;
    t.notes.push(if skill.has_skill() {
        format!("this predictor ({}) has skill: {}", model.predictor.calibration.name(), skill.describe())
    } else {
        format!(
            "this predictor has NO skill ({}): its scores say no more than the training mean, {:.2}",
            skill.describe(),
            model.predictor.gp.target_mean
        )
    });
    if any_extrapolated {
        let p = &model.predictor;
        let ((e0, e1), (c0, c1)) = (p.input_range(0), p.input_range(1));
        t.notes.push(format!(
            "extrapolated: an input outside those of the training sentences (E {e0:.1}–{e1:.1}, coverage {c0:.2}–{c1:.2}): the score is less sure than sigma says"
        ));
    }
    if any_unseen {
        t.notes.push(
            "unseen phones have no statistics of their own in the training corpus (another phone set?): they are fitted loosely, so E is low and the prediction too kind"
                .into(),
        );
    }
    write_tables(&[&t], a.output.format(), out)
}

fn markers(a: &MarkersArgs, out: &mut dyn Write) -> Result<()> {
    let bar = frames_bar(0, "fitting");
    let sc = session_corpus(&a.sessions, &CorpusOptions::default(), &show_on(&bar))?;
    bar.finish_and_clear();
    print_warnings(&sc.warnings);
    let markers = marker_vertices(&sc.corpus)?;
    let headers = ["vertex", "mouth"].map(String::from).to_vec();
    let mut t =
        Table::new("Marker vertices (0-based, the model's vertex order)", headers).keyed("markers");
    for (v, mouth) in &markers {
        t.push_row(vec![
            Cell::Int(*v as i64),
            Cell::Text(if *mouth { "yes" } else { "no" }.into()),
        ]);
    }
    let mouth = markers.iter().filter(|m| m.1).count();
    t.notes.push(format!(
        "{} markers, {mouth} on the mouth (weighted by the {MOUTH_WEIGHT}); a --synth-files CSV gives these vertices per frame",
        markers.len()
    ));
    write_tables(&[&t], a.output.format(), out)
}
