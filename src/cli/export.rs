//! `lipmap export SESSION --out DIR`: a session's effective landmarks, evaluation tables (CSV)
//! and trajectory charts (PNG) as plain files; fitted meshes (OBJ sequences) when asked for.

use crate::cli::exit::Outcome;
use crate::cli::output::{NormaliseArg, failure_lines, plural};
use crate::cli::progress::{frames_bar, print_warnings, show_on};
use crate::eval::Utterance;
use crate::fit::{FrameFit, fitted_shape};
use crate::io::landmark_format::{LandmarkFormat, write_track};
use crate::io::obj;
use crate::measure::Measure;
use crate::model::Mesh;
use crate::plot::{Panel, Series, TrajectoryPlot, draw_trajectories};
use crate::workflow::{self, HeadP, Normalisation, Resources, select_clips};
use anyhow::{Context, Result, bail};
use std::io::Write;
use std::path::{Path, PathBuf};

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
    #[arg(long, default_value_t = 10)]
    pub worst: usize,
    /// Width of the charts in pixels.
    #[arg(long, default_value_t = 1200, value_parser = clap::value_parser!(u32).range(200..=8000))]
    pub plot_width: u32,
}

/// Landmark formats that hold a whole track (a single `.pts` holds one frame).
fn parse_track_format(s: &str) -> std::result::Result<LandmarkFormat, String> {
    match s.parse::<LandmarkFormat>()? {
        LandmarkFormat::Pts => Err("a .pts file holds one frame; use pts-dir".into()),
        f => Ok(f),
    }
}

/// What one run exports, after `--all` and the defaults are applied.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ExportPlan {
    pub landmarks: Option<LandmarkFormat>,
    pub meshes: bool,
    pub tables: bool,
    pub plots: bool,
}

impl ExportPlan {
    /// The plan of `a`: landmarks, tables and plots when no kind is asked for, or with
    /// `--all`; meshes only with `--meshes` (an OBJ per frame of the whole model is hundreds
    /// of megabytes for a few seconds of video).
    pub fn of(a: &ExportArgs) -> Self {
        let none = a.landmarks.is_none() && !a.meshes && !a.tables && !a.plots;
        let all = a.all || none;
        Self {
            landmarks: a.landmarks.or(all.then_some(LandmarkFormat::LipmapCsv)),
            meshes: a.meshes,
            tables: a.tables || all,
            plots: a.plots || all,
        }
    }

    /// Whether anything needs fits (and so the model).
    fn needs_fits(&self) -> bool {
        self.meshes || self.tables || self.plots
    }
}

/// The path of a clip's exported landmarks inside `out` for `format`.
pub fn landmarks_path(out: &Path, clip: &str, format: LandmarkFormat) -> PathBuf {
    let dir = out.join("landmarks");
    match format {
        LandmarkFormat::Pts | LandmarkFormat::PtsFolder => dir.join(clip),
        LandmarkFormat::OpenFace => dir.join(format!("{clip}.openface.csv")),
        LandmarkFormat::DlibXml => dir.join(format!("{clip}.xml")),
        LandmarkFormat::LipmapCsv => dir.join(format!("{clip}.csv")),
    }
}

/// The OBJ of frame `frame` of `clip` inside `out`.
pub fn mesh_path(out: &Path, clip: &str, frame: usize) -> PathBuf {
    out.join("meshes").join(clip).join(format!("frame_{frame:06}.obj"))
}

/// The trajectory chart of `clip` inside `out`.
pub fn plot_path(out: &Path, clip: &str) -> PathBuf {
    out.join("plots").join(format!("{clip}.png"))
}

/// File names of the evaluation tables, in `EvalReport::tables` order.
pub const TABLE_FILES: [&str; 5] =
    ["sentences.csv", "phonemes.csv", "visemes.csv", "worst_frames.csv", "worst_fits.csv"];

/// Runs the export. The session changes only by storing fits the cache lacked.
///
/// # Errors
/// Unknown session or clip, a missing model or map when fits are needed, any write failure.
pub fn run(a: &ExportArgs, out: &mut dyn Write) -> Result<Outcome> {
    let plan = ExportPlan::of(a);
    check_out_dir(&a.out)?;
    // New fits are stored in the session's cache under the lock, as `eval` does; beside an
    // open editor the export runs read-only.
    let mut opened = workflow::open_for_read(&a.session)?;
    print_warnings(opened.notice.as_slice());
    let clips = select_clips(&opened.session, a.clip.as_deref())?;
    std::fs::create_dir_all(&a.out).with_context(|| format!("{}", a.out.display()))?;
    let mut outcome = Outcome::Ok;

    if let Some(format) = plan.landmarks {
        let mut files = 0;
        for &c in &clips {
            let name = opened.session.clip(c)?.name.clone();
            let track = rounded_track(opened.session.effective_track(c)?);
            let target = landmarks_path(&a.out, &name, format);
            if let Some(parent) = target.parent() {
                std::fs::create_dir_all(parent).with_context(|| format!("{}", parent.display()))?;
            }
            write_track(&track, &target, format)?;
            files += if format == LandmarkFormat::PtsFolder { track.frames.len() } else { 1 };
        }
        writeln!(
            out,
            "landmarks ({format}): {} in {}",
            plural(files, "file"),
            a.out.join("landmarks").display()
        )?;
    }
    if !plan.needs_fits() {
        return Ok(outcome);
    }

    let (res, warnings) = workflow::load_resources(&opened.session, &opened.path)?;
    print_warnings(&warnings);
    let settings = opened.session.fit_settings.clone();
    // Save only when something is fitted now: an up-to-date session stays untouched.
    let any_stale =
        clips.iter().any(|&c| !opened.session.stale_frames_with(c, &settings).is_empty());
    let bar = frames_bar(0, "fitting");
    let done = workflow::utterances_with(
        &mut opened.session,
        &res,
        &clips,
        &settings,
        HeadP::Mesh,
        &show_on(&bar),
    )?;
    print_warnings(&done.warnings);
    if any_stale {
        opened.save_if_locked()?;
    }
    let (utterances, fits) = (&done.utterances, &done.fits);
    let normalise: Normalisation = a.normalise.into();

    if plan.meshes {
        let (written, failed) = export_meshes(&res, fits, &a.out)?;
        writeln!(
            out,
            "meshes: {} in {}",
            plural(written, "OBJ file"),
            a.out.join("meshes").display()
        )?;
        if failed > 0 {
            outcome = Outcome::Partial;
        }
    }
    if plan.tables {
        let report = workflow::evaluate(utterances, &done.fit_refs(), normalise, a.worst);
        let dir = a.out.join("tables");
        std::fs::create_dir_all(&dir).with_context(|| format!("{}", dir.display()))?;
        for (table, file) in report.tables().iter().zip(TABLE_FILES) {
            let p = dir.join(file);
            let mut w = std::io::BufWriter::new(
                std::fs::File::create(&p).with_context(|| format!("{}", p.display()))?,
            );
            table.write_csv(&mut w).with_context(|| format!("{}", p.display()))?;
            w.flush().with_context(|| format!("{}", p.display()))?;
        }
        writeln!(out, "tables: {} in {}", plural(TABLE_FILES.len(), "CSV file"), dir.display())?;
    }
    if plan.plots {
        for u in utterances {
            let img = trajectory_chart(u, normalise, a.plot_width);
            let p = plot_path(&a.out, &u.name);
            if let Some(parent) = p.parent() {
                std::fs::create_dir_all(parent).with_context(|| format!("{}", parent.display()))?;
            }
            img.save_with_format(&p, image::ImageFormat::Png)
                .with_context(|| format!("{}", p.display()))?;
        }
        writeln!(
            out,
            "plots: {} in {}",
            plural(utterances.len(), "PNG file"),
            a.out.join("plots").display()
        )?;
    }
    Ok(outcome)
}

/// Decimals kept in exported landmark coordinates: 1/10,000 px is far below any tracker's or
/// hand correction's precision, and drops float noise such as `41.28538095238095`.
pub const LANDMARK_DECIMALS: i32 = 4;

/// `track` with every coordinate rounded to [`LANDMARK_DECIMALS`] decimals.
pub fn rounded_track(mut track: crate::landmarks::Track) -> crate::landmarks::Track {
    let k = 10f64.powi(LANDMARK_DECIMALS);
    for f in &mut track.frames {
        for p in &mut f.points {
            p.x = (p.x * k).round() / k;
            p.y = (p.y * k).round() / k;
        }
    }
    track
}

/// Writes one OBJ per successful fit; a failed fit is skipped with one stderr line.
/// Returns (files written, fits skipped).
fn export_meshes(
    res: &Resources,
    fits: &[(String, Vec<FrameFit>)],
    out: &Path,
) -> Result<(usize, usize)> {
    let faces = mesh_faces(res);
    let total: usize = fits.iter().map(|(_, f)| f.len()).sum();
    let bar = frames_bar(total as u64, "writing meshes");
    let (mut written, mut failed) = (0, 0);
    for (clip, clip_fits) in fits {
        let dir = out.join("meshes").join(clip);
        std::fs::create_dir_all(&dir).with_context(|| format!("{}", dir.display()))?;
        for fit in clip_fits {
            bar.inc(1);
            if fit.failed.is_some() {
                failed += 1;
                continue;
            }
            let shape = fitted_shape(&res.model, fit);
            let mesh = Mesh::from_flat(shape.as_slice(), faces.clone());
            obj::write_obj(&mesh_path(out, clip, fit.frame), &mesh)?;
            written += 1;
        }
    }
    bar.finish_and_clear();
    // One line per distinct reason, not one per frame.
    for (clip, clip_fits) in fits {
        for line in failure_lines(clip, clip_fits) {
            eprintln!("lipmap: {line} (no mesh written)");
        }
    }
    Ok((written, failed))
}

/// The faces written with every fitted shape: the model's triangles, else the head mesh's
/// polygons when the head has the model's vertices (a model from pose OBJs may carry none).
fn mesh_faces(res: &Resources) -> Vec<Vec<u32>> {
    if !res.model.triangles.is_empty() {
        return res.model.triangles.iter().map(|t| t.to_vec()).collect();
    }
    match &res.head {
        Some(h) if h.num_vertices() == res.model.num_vertices() => h.faces.clone(),
        _ => Vec::new(),
    }
}

/// The W/H/P chart of one clip: video (blue) against the fitted head (orange), on the scale
/// the evaluation compares them with, phone boundaries from the clip's alignment.
pub fn trajectory_chart(
    u: &Utterance,
    normalisation: Normalisation,
    width: u32,
) -> image::RgbImage {
    let compared = normalisation.apply(std::slice::from_ref(u)).remove(0);
    let measures: Vec<Measure> = Measure::ALL
        .into_iter()
        .filter(|&m| m != Measure::P || compared.head.has_p() || compared.video.has_p())
        .collect();
    let panels = measures
        .into_iter()
        .map(|m| Panel {
            label: m.as_str().to_string(),
            series: vec![
                Series {
                    name: "video".into(),
                    colour: [31, 119, 180],
                    values: compared.video.series(m).to_vec(),
                },
                Series {
                    name: "3D head".into(),
                    colour: [255, 127, 14],
                    values: compared.head.series(m).to_vec(),
                },
            ],
        })
        .collect();
    let alignment = (!compared.alignment.phones.is_empty()).then_some(&compared.alignment);
    draw_trajectories(&TrajectoryPlot {
        title: u.name.clone(),
        fps: u.fps,
        alignment,
        panels,
        width,
        panel_height: 160,
    })
}

/// Checks a plan can be carried out before anything is written: a nonexistent `--out` parent
/// is fine (it is created), but `--out` must not be a file.
pub fn check_out_dir(out: &Path) -> Result<()> {
    if out.is_file() {
        bail!("{}: --out must be a folder, not a file", out.display());
    }
    Ok(())
}
