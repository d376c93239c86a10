//! `lipmap eval SESSION`: per-sentence, per-phoneme and per-viseme W/H/P RMSE tables and the
//! worst frames; `--compare F1,F2,…` for the landmark-set table with paired t-tests;
//! `--head-p render --render-pitch DEG` measures the head's P on side renders; `--heads`
//! compares several heads, plain OBJ heads through transfer.

use crate::cli::output::{FormatArgs, NormaliseArg, write_tables};
use crate::cli::progress::{frames_bar, print_warnings, show_on};
use crate::cli::transfer_cmd::ModeArg;
use crate::landmarks::LandmarkSet;
use crate::measure::PoseComparison;
use crate::workflow::{self, HeadP, session_path};
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
    #[arg(long, value_enum, default_value_t = NormaliseArg::MinMax)]
    pub normalise: NormaliseArg,
    /// Number of worst frames to list.
    #[arg(long, default_value_t = workflow::DEFAULT_WORST_ROWS)]
    pub worst: usize,
    /// Only this clip.
    #[arg(long)]
    pub clip: Option<String>,
    /// Fit the clips onto several heads and compare them (the first is the t-tests'
    /// baseline), with each head's speaker-head index match. Each head is a session file
    /// (its model, map and head mesh), a folder with a model (lipmap model file such as
    /// model.lmm, eos .bin, .npz, mean.npy or poses/ of OBJs), a landmark map (its .toml, or
    /// ibug_to_*.txt) and optionally head.obj (what `lipmap demo` writes is one), or a plain
    /// OBJ head with a landmark map: the session's fitted motion is transferred onto it, as
    /// `lipmap transfer` does.
    #[arg(long, value_delimiter = ',', conflicts_with = "compare")]
    pub heads: Vec<std::path::PathBuf>,
    /// Landmark maps of the OBJ heads of `--heads`, in their order (eos TOML, 1-based iBUG
    /// ids); an OBJ head without one takes HEAD.toml or HEAD_map.toml beside it.
    #[arg(long, value_delimiter = ',', requires = "heads")]
    pub mapping: Vec<std::path::PathBuf>,
    /// How the OBJ heads of `--heads` follow the transferred control points.
    #[arg(long, value_enum, default_value_t = ModeArg::Biharmonic, requires = "heads")]
    pub transfer_mode: ModeArg,
    /// How the fitted head's P is measured: on the mesh (the foremost upper-lip vertex; the
    /// whole upper lip for clips with a side view) or on side renders of the fitted head,
    /// measured like the side video.
    #[arg(long, value_enum, default_value_t = HeadPArg::Mesh, conflicts_with = "heads")]
    pub head_p: HeadPArg,
    /// Pitch in degrees of the virtual side camera for `--head-p render` (a nod about the
    /// head's ear-to-ear axis): set it to match the real side camera's pitch.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub render_pitch: f64,
    /// Sealed lips: `seal` or `off` (as `lipmap fit --closure`; refits the frames it changes
    /// and becomes the session's setting when it is saved).
    #[arg(long, value_enum)]
    pub closure: Option<crate::cli::fit_cmd::ClosureArg>,
    #[command(flatten)]
    pub pose: PoseArgs,
    #[command(flatten)]
    pub output: FormatArgs,
}

/// How W and H of video and head are compared when the head turns (`--pose`,
/// `--pose-limit`), shared by `eval` and `export`.
#[derive(clap::Args, Debug, Clone, Copy)]
pub struct PoseArgs {
    /// `frontal`: the head's own mouth against the video on frames whose fitted |yaw| and
    /// |pitch| are within --pose-limit (the others left out and counted); `image-plane`: the
    /// head's mouth points projected with each frame's fitted camera, measured like the
    /// video's, on every frame.
    #[arg(long, value_enum, default_value_t = PoseArg::Frontal)]
    pub pose: PoseArg,
    /// Largest |yaw| or |pitch| in degrees a frame may have in the frontal comparison.
    #[arg(long, default_value_t = PoseComparison::DEFAULT_LIMIT_DEG)]
    pub pose_limit: f64,
}

/// `--pose` values.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum PoseArg {
    #[default]
    Frontal,
    ImagePlane,
}

impl PoseArgs {
    /// The comparison the flags ask for.
    ///
    /// # Errors
    /// A limit that is not an angle in (0, 90].
    pub fn comparison(&self) -> Result<PoseComparison> {
        let limit = self.pose_limit;
        if !(limit.is_finite() && limit > 0.0 && limit <= 90.0) {
            bail!("--pose-limit must be an angle in degrees in (0, 90], got {limit}");
        }
        Ok(match self.pose {
            PoseArg::Frontal => PoseComparison::Frontal { limit_deg: limit },
            PoseArg::ImagePlane => PoseComparison::ImagePlane,
        })
    }
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

pub fn run(a: &EvalArgs, out: &mut dyn Write) -> Result<()> {
    let normalise = a.normalise.into();
    if !a.heads.is_empty() {
        let path = session_path(&a.session);
        let clip = a.clip.as_deref();
        // The session's own head takes its head map when no map is named for it.
        let session = workflow::read_session(&path)?.session;
        let heads = workflow::heads::load_heads(
            &a.heads,
            &a.mapping,
            a.transfer_mode.into(),
            Some(&session),
        )?;
        return run_heads(&path, &heads, clip, normalise, a.pose.comparison()?, &a.output, out);
    }
    // Evaluation fits what the cache lacks and stores it, under the lock; beside an open
    // editor it runs read-only (fits in memory, nothing saved).
    let mut opened = workflow::open_for_read(&a.session)?;
    print_warnings(&opened.notices);
    let req = workflow::EvalRequest {
        clip: a.clip.clone(),
        closure: a.closure.map(Into::into),
        head_p: a.head_p()?,
        pose: a.pose.comparison()?,
        normalisation: normalise,
        worst: a.worst,
    };
    let bar = frames_bar(0, "fitting");
    let progress = show_on(&bar);
    if !a.compare.is_empty() {
        let (comparison, warnings) =
            workflow::evaluate::compare_sets(&mut opened, &req, &a.compare, &progress)?;
        print_warnings(&warnings);
        return write_tables(&[&comparison.to_table()], a.output.format(), out);
    }
    // Each clip's flags are printed as it is measured (above the bar), not kept to the end.
    let mut flags = |lines: &[String]| {
        bar.suspend(|| {
            for line in lines {
                crate::cli::output::eprint_line(crate::cli::output::terminal_safe(line));
            }
        })
    };
    let evaluated = workflow::evaluate_session(&mut opened, &req, &progress, &mut flags)?;
    print_warnings(&evaluated.warnings);
    write_tables(&evaluated.tables(), a.output.format(), out)
}

/// `--heads`: fits the session's clips (`clip` only, when given) onto each head and prints
/// the comparison ([`workflow::heads::compare_heads`]).
fn run_heads(
    session_path: &std::path::Path,
    heads: &[workflow::heads::Head],
    clip: Option<&str>,
    normalise: workflow::Normalisation,
    pose: PoseComparison,
    output: &FormatArgs,
    out: &mut dyn Write,
) -> Result<()> {
    let read = workflow::read_session(session_path)?;
    print_warnings(&read.notices);
    let session = read.session;
    let clips = workflow::select_clips(&session, clip)?;
    let bar = frames_bar(0, "fitting");
    let report =
        workflow::heads::compare_heads(&session, heads, &clips, normalise, pose, &show_on(&bar))
            .map_err(|e| match e {
                workflow::Error::NoClips => {
                    anyhow::Error::new(e).context(session_path.display().to_string())
                }
                e => e.into(),
            })?;
    print_warnings(&report.warnings);
    let refs: Vec<&crate::eval::Table> = report.tables.iter().collect();
    write_tables(&refs, output.format(), out)
}
