//! `lipmap export SESSION --out DIR`: a session's effective landmarks, evaluation tables (CSV)
//! and trajectory charts (PNG) as plain files; fitted meshes (OBJ sequences) when asked for.
//! The use case is `workflow::export`; this module parses the flags and prints what it wrote.

use crate::cli::exit::Outcome;
use crate::cli::output::{NormaliseArg, failure_lines, plural, terminal_safe};
use crate::cli::progress::{frames_bar, print_warnings, show_on};
use crate::io::landmark_format::LandmarkFormat;
use crate::workflow::export::{ExportPlan, ExportRequest, Written, check_out_dir, export};
use crate::workflow::{self, Normalisation};
use anyhow::Result;
use std::io::Write;
use std::path::PathBuf;

/// Export a session's landmarks, fitted meshes, tables and plots into a folder.
#[derive(clap::Args, Debug, Clone)]
pub struct ExportArgs {
    /// Session file or name.
    pub session: String,
    /// Output folder (created if needed; existing files of the same names are replaced).
    #[arg(long)]
    pub out: PathBuf,
    /// Export the effective landmarks (tracked + corrections) per clip in this format:
    /// pts-dir, openface, dlib or csv.
    #[arg(long, value_parser = parse_track_format)]
    pub landmarks: Option<LandmarkFormat>,
    /// Export the fitted meshes, one OBJ per frame per clip, in the model's vertex order
    /// (large: the whole model mesh per frame, so only when asked for, even with --all).
    #[arg(long)]
    pub meshes: bool,
    /// Export the evaluation tables as CSV.
    #[arg(long)]
    pub tables: bool,
    /// Export one W/H/P trajectory chart (PNG) per clip, with phone boundaries.
    #[arg(long)]
    pub plots: bool,
    /// Landmarks, tables and plots (the default when nothing is asked for); landmarks as csv
    /// unless --landmarks says otherwise. Meshes need --meshes.
    #[arg(long)]
    pub all: bool,
    /// Only this clip.
    #[arg(long)]
    pub clip: Option<String>,
    /// How video and head trajectories are put on one scale (tables and plots).
    #[arg(long, value_enum, default_value_t = NormaliseArg::MinMax)]
    pub normalise: NormaliseArg,
    /// Rows of the worst-frames tables.
    #[arg(long, default_value_t = workflow::DEFAULT_WORST_ROWS)]
    pub worst: usize,
    /// Width of the charts in pixels.
    #[arg(long, default_value_t = 1200, value_parser = clap::value_parser!(u32).range(200..=8000))]
    pub plot_width: u32,
    #[command(flatten)]
    pub pose: crate::cli::eval_cmd::PoseArgs,
}

/// Landmark formats that hold a whole track (a single `.pts` holds one frame).
fn parse_track_format(s: &str) -> std::result::Result<LandmarkFormat, String> {
    match s.parse::<LandmarkFormat>()? {
        LandmarkFormat::Pts => Err("a .pts file holds one frame; use pts-dir".into()),
        f => Ok(f),
    }
}

/// The plan of `a` (see [`ExportPlan::of`]).
pub fn plan_of(a: &ExportArgs) -> ExportPlan {
    ExportPlan::of(a.landmarks, a.meshes, a.tables, a.plots, a.all)
}

/// Runs the export and prints one line per kind written.
///
/// # Errors
/// Unknown session or clip, a missing model or map when fits are needed, any write failure.
pub fn run(a: &ExportArgs, out: &mut dyn Write) -> Result<Outcome> {
    check_out_dir(&a.out)?;
    // New fits are stored in the session's cache under the lock, as `eval` does; beside an
    // open editor the export runs read-only.
    let mut opened = workflow::open_for_read(&a.session)?;
    print_warnings(&opened.notices);
    let normalisation: Normalisation = a.normalise.into();
    let req = ExportRequest {
        out: a.out.clone(),
        plan: plan_of(a),
        clip: a.clip.clone(),
        normalisation,
        worst: a.worst,
        plot_width: a.plot_width,
        pose: a.pose.comparison()?,
    };
    let bar = frames_bar(0, "fitting");
    let report = export(&mut opened, &req, &show_on(&bar))?;
    bar.finish_and_clear();
    print_warnings(&report.warnings);
    let line = |out: &mut dyn Write, what: &str, w: &Written, noun: &str| {
        let dir = w.dir.display().to_string();
        writeln!(out, "{what}: {} in {}", plural(w.files, noun), terminal_safe(&dir))
    };
    if let (Some(w), Some(format)) = (&report.landmarks, req.plan.landmarks) {
        line(&mut *out, &format!("landmarks ({format})"), w, "file")?;
    }
    if let Some(w) = &report.meshes {
        line(&mut *out, "meshes", w, "OBJ file")?;
    }
    if let Some(w) = &report.tables {
        line(&mut *out, "tables", w, "CSV file")?;
    }
    if let Some(w) = &report.plots {
        line(&mut *out, "plots", w, "PNG file")?;
    }
    if !req.plan.meshes {
        return Ok(Outcome::Ok);
    }
    // One line per distinct reason, not one per frame.
    for (clip, failed) in &report.failed_fits {
        for l in failure_lines(clip, failed) {
            crate::cli::output::eprint_line(format_args!(
                "lipmap: {} (no mesh written)",
                terminal_safe(&l)
            ));
        }
    }
    Ok(if report.failed_fits.is_empty() { Outcome::Ok } else { Outcome::Partial })
}
