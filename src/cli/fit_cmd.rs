//! `lipmap fit`: fit every clip of a session (caching results keyed by the settings), or, with
//! `--model/--mapping/--landmarks/--image-size/--out` and no session, fit files to files.

use crate::cli::exit::Outcome;
use crate::cli::fit_files::{FitFilesArgs, parse_image_size};
use crate::cli::output::{failure_lines, median_reprojection, plural, rms_text, terminal_safe};
use crate::cli::progress::{frames_bar, print_warnings, show_on};
use crate::fit::FitSettings;
use crate::landmarks::LandmarkSet;
use crate::landmarks::closure::Closure;
use crate::workflow::{self, open_for_edit};
use anyhow::{Result, bail};
use std::io::Write;
use std::path::PathBuf;

/// Fit a session's clips, or landmark files with a model (files mode).
#[derive(clap::Args, Debug)]
pub struct FitArgs {
    /// Session file or name. Without it, files mode: --model, --mapping, --landmarks,
    /// --image-size and --out are required.
    pub session: Option<String>,
    /// Model: eos .bin, .npz, folder of .npy parts, lipmap model file or folder of pose OBJs.
    #[arg(long)]
    pub model: Option<PathBuf>,
    /// Expression blendshapes to add to the model (eos .bin, .target/OBJ folder).
    #[arg(long)]
    pub blendshapes: Option<PathBuf>,
    /// Landmark map: eos TOML (1-based iBUG ids) or eos's landmarks_and_contours.json.
    #[arg(long)]
    pub mapping: Option<PathBuf>,
    /// Landmarks in any format lipmap reads: lipmap CSV (frame,point,x,y,…), eos's CSV
    /// (frame,ibug_id,u,v), .pts, OpenFace, dlib XML (pixels, y down).
    #[arg(long)]
    pub landmarks: Option<PathBuf>,
    /// Image size in pixels, WxH.
    #[arg(long, value_parser = parse_image_size)]
    pub image_size: Option<(u32, u32)>,
    /// Output folder for fit.csv and shapes.npy (files mode).
    #[arg(long)]
    pub out: Option<PathBuf>,
    #[command(flatten)]
    pub settings: FitSettingArgs,
    /// Session mode: only this clip.
    #[arg(long)]
    pub only: Option<String>,
    /// Session mode: fit even when the model map fails `lipmap map check` (the problems
    /// are then printed as warnings).
    #[arg(long)]
    pub accept_map_warnings: bool,
}

/// `--closure`: `seal` closes the inner lips on the frames in the clip's sealed mode of the
/// tracked gap before fitting and measuring (docs/closure.md); `off` keeps them as tracked.
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ClosureArg {
    Seal,
    Off,
}

impl From<ClosureArg> for Closure {
    fn from(a: ClosureArg) -> Self {
        match a {
            ClosureArg::Seal => Self::Seal,
            ClosureArg::Off => Self::Off,
        }
    }
}

/// The fit-setting flags of both modes; in session mode they become the session's settings.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct FitSettingArgs {
    /// Landmark set driving the fit (F1 lips … F5 all 68). In session mode it becomes the
    /// session's setting.
    #[arg(long)]
    pub set: Option<LandmarkSet>,
    /// Identity prior weight λ.
    #[arg(long)]
    pub lambda: Option<f64>,
    /// Expression prior weight (default 3). Lower it when a blendshape model's expressions
    /// come out too weak (e.g. a mouth that barely opens); in session mode it becomes the
    /// session's setting.
    #[arg(long)]
    pub lambda_expression: Option<f64>,
    /// Camera/shape iterations.
    #[arg(long)]
    pub iterations: Option<usize>,
    /// Fit each clip as one person: one identity, pose and expression per frame.
    #[arg(long)]
    pub clip: bool,
    /// Fit each frame alone (undoes a session's --clip setting).
    #[arg(long, conflicts_with = "clip")]
    pub per_frame: bool,
    /// Sealed lips: `seal` (default) closes the inner lips on frames in the clip's sealed
    /// mode of the tracked gap, `off` fits them as tracked (docs/closure.md).
    #[arg(long, value_enum)]
    pub closure: Option<ClosureArg>,
}

impl FitSettingArgs {
    /// `base` with the flags given laid over it.
    ///
    /// # Errors
    /// A prior weight that is not a finite number ≥ 0.
    pub fn apply(&self, base: &FitSettings) -> Result<FitSettings> {
        let mut settings = base.clone();
        if let Some(set) = self.set {
            settings.set = set;
        }
        for (flag, value, target) in [
            ("--lambda", self.lambda, &mut settings.lambda),
            ("--lambda-expression", self.lambda_expression, &mut settings.lambda_expression),
        ] {
            if let Some(l) = value {
                if !(l.is_finite() && l >= 0.0) {
                    bail!("{flag} must be a finite number >= 0, got {l}");
                }
                *target = l;
            }
        }
        if let Some(n) = self.iterations {
            settings.iterations = n;
        }
        if self.clip {
            settings.clip = true;
        }
        if self.per_frame {
            settings.clip = false;
        }
        if let Some(c) = self.closure {
            settings.closure = c.into();
        }
        Ok(settings)
    }
}

pub fn run(a: &FitArgs, out: &mut dyn Write) -> Result<Outcome> {
    match &a.session {
        None => run_files(a),
        Some(s) => run_session(a, s, out),
    }
}

fn run_files(a: &FitArgs) -> Result<Outcome> {
    let missing: Vec<&str> = [
        ("--model", a.model.is_none()),
        ("--mapping", a.mapping.is_none()),
        ("--landmarks", a.landmarks.is_none()),
        ("--image-size", a.image_size.is_none()),
        ("--out", a.out.is_none()),
    ]
    .iter()
    .filter(|(_, m)| *m)
    .map(|(n, _)| *n)
    .collect();
    if !missing.is_empty() {
        bail!("give a SESSION, or fit files with {} (missing)", missing.join(", "));
    }
    let files = FitFilesArgs {
        model: a.model.clone().unwrap_or_default(),
        blendshapes: a.blendshapes.clone(),
        mapping: a.mapping.clone().unwrap_or_default(),
        landmarks: a.landmarks.clone().unwrap_or_default(),
        image_size: a.image_size.unwrap_or((1, 1)),
        settings: a.settings.clone(),
        out: a.out.clone().unwrap_or_default(),
    };
    crate::cli::fit_files::run_with_outcome(&files)
}

fn run_session(a: &FitArgs, s: &str, out: &mut dyn Write) -> Result<Outcome> {
    if a.model.is_some() || a.mapping.is_some() || a.landmarks.is_some() || a.out.is_some() {
        bail!("--model/--mapping/--landmarks/--out are for files mode; a session names its own");
    }
    let mut opened = open_for_edit(s)?;
    print_warnings(&opened.notices);
    let settings = a.settings.apply(&opened.session.fit_settings)?;
    let bar = frames_bar(0, "fitting");
    // Each clip is printed as it is fitted (above the bar): nothing of a corpus's fits is
    // kept for the end.
    let mut print = |step: workflow::FitStep| -> workflow::Result<()> {
        bar.suspend(|| match step {
            workflow::FitStep::Warning(w) => {
                print_warnings(std::slice::from_ref(&w));
                Ok(())
            }
            workflow::FitStep::Clip(clip) => {
                print_clip_fitted(&clip, out).map_err(|e| workflow::Error::io("standard output", e))
            }
        })
    };
    let fitted = workflow::fit::fit_session(
        &mut opened,
        &settings,
        a.only.as_deref(),
        a.accept_map_warnings,
        &show_on(&bar),
        &mut print,
    )
    .inspect_err(|e| {
        // The whole list, as `map check` prints it; the error line sums it up.
        if let workflow::Error::FitRefused(workflow::FitRefusal::Implausible { problems }) = e {
            bar.finish_and_clear();
            for p in problems {
                crate::cli::output::eprint_line(format_args!("model map: {p}"));
            }
        }
    })?;
    Ok(if fitted.any_failed() { Outcome::Partial } else { Outcome::Ok })
}

/// One fitted clip's summary line and flag count (stdout), its failures and flagged frames
/// (stderr).
fn print_clip_fitted(clip: &workflow::ClipFitted, out: &mut dyn Write) -> std::io::Result<()> {
    let (name, fits) = (&clip.name, &clip.fits);
    let median = rms_text(median_reprojection(&fits.fits));
    writeln!(
        out,
        "{name}: {} ({} refitted, {} from cache), {} failed, median reprojection RMS {median}",
        plural(fits.fits.len(), "frame"),
        fits.refitted,
        fits.fits.len() - fits.refitted,
        fits.failed()
    )?;
    for line in failure_lines(name, &fits.fits) {
        crate::cli::output::eprint_line(terminal_safe(&line));
    }
    if let Some((count, frames)) = clip.flag_lines.split_first() {
        writeln!(out, "{}", terminal_safe(count))?;
        for line in frames {
            crate::cli::output::eprint_line(terminal_safe(line));
        }
    }
    Ok(())
}
