//! `lipmap eval SESSION`: per-sentence, per-phoneme and per-viseme W/H/P RMSE tables and the
//! worst frames; `--compare F1,F2,…` for the landmark-set table with paired t-tests;
//! `--head-p render --render-pitch DEG` measures the head's P on side renders.

use crate::cli::new::session_path;
use crate::cli::output::{FormatArgs, write_tables};
use crate::eval::{Configuration, RowKey, Utterance, compare_configurations};
use crate::fit::FitSettings;
use crate::landmarks::LandmarkSet;
use crate::measure::MeshMeasureOptions;
use crate::session::Session;
use crate::workflow::{self, HeadP, Normalisation, Resources};
use anyhow::{Result, bail};
use std::io::Write;

/// Evaluate how faithfully the fitted head's lips follow the video.
#[derive(clap::Args, Debug)]
pub struct EvalArgs {
    /// Session file or name.
    pub session: String,
    /// Compare landmark sets (fits each clip with each), e.g. F1,F2,F3,F4,F5; the first is
    /// the baseline of the t-tests.
    #[arg(long, value_delimiter = ',')]
    pub compare: Vec<LandmarkSet>,
    /// How video and head trajectories are put on one scale before comparing.
    #[arg(long, value_enum, default_value_t = Normalisation::MinMax)]
    pub normalise: Normalisation,
    /// Number of worst frames to list.
    #[arg(long, default_value_t = 10)]
    pub worst: usize,
    /// Only this clip.
    #[arg(long)]
    pub clip: Option<String>,
    /// Fit the clips onto several heads and compare them (the first is the t-tests'
    /// baseline), with each head's speaker-head index match. Each head is a session file
    /// (its model, map and head mesh) or a folder with a model (lipmap model file such as
    /// model.lmm, eos .bin, .npz, mean.npy or poses/ of OBJs), a landmark map (its .toml, or
    /// ibug_to_*.txt) and optionally head.obj: what `lipmap demo` writes is one.
    #[arg(long, value_delimiter = ',', conflicts_with = "compare")]
    pub heads: Vec<std::path::PathBuf>,
    /// How the fitted head's P is measured: on the mesh (the foremost upper-lip vertex; the
    /// whole upper lip for clips with a side view) or on side renders of the fitted head,
    /// measured like the side video.
    #[arg(long, value_enum, default_value_t = HeadPArg::Mesh, conflicts_with = "heads")]
    pub head_p: HeadPArg,
    /// Pitch in degrees of the virtual side camera for `--head-p render` (a nod about the
    /// head's ear-to-ear axis): set it to match the real side camera's pitch.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub render_pitch: f64,
    #[command(flatten)]
    pub output: FormatArgs,
}

/// Where the head's P comes from (`--head-p`).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum HeadPArg {
    #[default]
    Mesh,
    Render,
}

impl EvalArgs {
    /// The head-P choice of the flags.
    ///
    /// # Errors
    /// A non-finite or implausible (beyond ±60°) render pitch.
    pub fn head_p(&self) -> Result<HeadP> {
        let pitch = self.render_pitch;
        if !(pitch.is_finite() && pitch.abs() <= 60.0) {
            bail!("--render-pitch must be a pitch in degrees within ±60, got {pitch}");
        }
        Ok(match self.head_p {
            HeadPArg::Mesh => HeadP::Mesh,
            HeadPArg::Render => HeadP::Render { pitch_deg: pitch },
        })
    }
}

/// Each clip's name and fits, in clip order.
pub type NamedFits = Vec<(String, Vec<crate::fit::FrameFit>)>;

/// Fits (from cache where valid) and evaluates the selected clips of a session with
/// `settings`; returns the utterances and each clip's fits.
pub fn utterances_with(
    session: &mut Session,
    res: &Resources,
    clips: &[usize],
    settings: &FitSettings,
) -> Result<(Vec<Utterance>, NamedFits)> {
    utterances_with_head_p(session, res, clips, settings, HeadP::Mesh)
}

/// As [`utterances_with`], the head's P measured as `head_p` says.
pub fn utterances_with_head_p(
    session: &mut Session,
    res: &Resources,
    clips: &[usize],
    settings: &FitSettings,
    head_p: HeadP,
) -> Result<(Vec<Utterance>, NamedFits)> {
    let mut utterances = Vec::new();
    let mut fits = Vec::new();
    let bar = crate::cli::progress::frames_bar(0, "fitting");
    for &c in clips {
        let name = session.clip(c)?.name.clone();
        bar.set_message(format!("fitting {name} ({})", settings.set));
        let progress = |done: usize, total: usize| {
            bar.set_length(total as u64);
            bar.set_position(done as u64);
        };
        let clip_fits = workflow::fit_clip_cached(session, res, c, settings, Some(&progress))?;
        let mut u = workflow::utterance_of_clip(
            session,
            res,
            c,
            &clip_fits.fits,
            &MeshMeasureOptions::default(),
        )?;
        if let HeadP::Render { pitch_deg } = head_p {
            bar.set_message(format!("rendering {name} from the side"));
            let n = u.head.p.len();
            let r =
                workflow::head_p_of_clip_by_render(session, res, c, &clip_fits.fits, n, pitch_deg)?;
            u.head.p = r.p;
        }
        utterances.push(u);
        fits.push((name, clip_fits.fits));
    }
    bar.finish_and_clear();
    Ok((utterances, fits))
}

/// The clips selected by `--clip` (all when absent).
pub fn select_clips(session: &Session, name: Option<&str>) -> Result<Vec<usize>> {
    match name {
        Some(n) => match session.clip_index(n) {
            Some(i) => Ok(vec![i]),
            None => bail!(
                "no clip `{n}` in the session (clips: {})",
                session.clips.iter().map(|c| c.name.as_str()).collect::<Vec<_>>().join(", ")
            ),
        },
        None => Ok((0..session.clips.len()).collect()),
    }
}

pub fn run(a: &EvalArgs, out: &mut dyn Write) -> Result<()> {
    let path = session_path(&a.session);
    if !a.heads.is_empty() {
        let clip = a.clip.as_deref();
        return crate::cli::heads::run_heads(&path, &a.heads, clip, a.normalise, &a.output, out);
    }
    // Evaluation fits what the cache lacks and stores it, under the lock; beside an open
    // editor it runs read-only (fits in memory, nothing saved).
    let (path, lock, mut session) = crate::cli::new::open_for_read(&a.session)?;
    let res = crate::cli::new::load_resources(&session, &path)?;
    let clips = select_clips(&session, a.clip.as_deref())?;
    if clips.iter().all(|&c| session.clips[c].alignment.is_none()) {
        eprintln!(
            "lipmap: warning: no clip has a phone alignment; per-phoneme tables will be empty"
        );
    }
    let base = session.fit_settings.clone();
    let head_p = a.head_p()?;
    if a.compare.is_empty() {
        let (utterances, fits) = utterances_with_head_p(&mut session, &res, &clips, &base, head_p)?;
        crate::cli::new::save_if_locked(&session, &path, lock.as_ref())?;
        crate::cli::output::require_some_fit(&fits)?;
        let fit_refs: Vec<(&str, &[crate::fit::FrameFit])> =
            fits.iter().map(|(n, f)| (n.as_str(), f.as_slice())).collect();
        let report = workflow::evaluate(&utterances, &fit_refs, a.normalise, a.worst);
        write_tables(&report.tables(), a.output.format(), out)?;
        return Ok(());
    }
    let mut configs = Vec::new();
    for &set in &a.compare {
        let settings = FitSettings { set, ..base.clone() };
        let (utterances, _) =
            utterances_with_head_p(&mut session, &res, &clips, &settings, head_p)?;
        let utterances = match a.normalise {
            Normalisation::MinMax => utterances.iter().map(Utterance::min_max_normalised).collect(),
            Normalisation::None => utterances,
        };
        configs.push(Configuration { name: set.to_string(), utterances });
    }
    crate::cli::new::save_if_locked(&session, &path, lock.as_ref())?;
    let comparison = compare_configurations(&configs, 0, RowKey::Sentence)?;
    write_tables(&[&comparison.to_table()], a.output.format(), out)?;
    Ok(())
}
