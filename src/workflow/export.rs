//! Exporting a session as plain files: effective landmarks per clip, the evaluation tables
//! (CSV), one W/H/P chart per clip (PNG) and, when asked for, one fitted mesh per frame (OBJ).
//!
//! Start with [`export`] and [`ExportPlan`]. Everything lands inside the folder the user named:
//! clip names become file names through [`safe_file_names`] (no separators, no `..`, no
//! control characters, collisions numbered), a symlink found where a folder is to be made is
//! replaced by a real folder (its target untouched), and every file is written atomically
//! (`io::atomic`), which replaces a symlink at a file's place instead of writing through it.

use super::error::{Error, Progress, ProgressFn, Result, Warning};
use super::evaluate::{ClipsToMeasure, Normalisation, evaluate, utterances_with};
use super::resources::{Resources, load_resources};
use super::session::{ReadSession, select_clips};
use super::side_view::HeadP;
use crate::eval::Utterance;
use crate::fit::{FrameFit, fitted_shape};
use crate::io::atomic::write_atomic;
use crate::io::landmark_format::{LandmarkFormat, write_track};
use crate::io::obj;
use crate::landmarks::Track;
use crate::measure::Measure;
use crate::model::Mesh;
use crate::plot::{Panel, Series, TrajectoryPlot, draw_trajectories};
use std::collections::HashSet;
use std::path::{Path, PathBuf};

/// What one run exports.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ExportPlan {
    pub landmarks: Option<LandmarkFormat>,
    pub meshes: bool,
    pub tables: bool,
    pub plots: bool,
}

impl ExportPlan {
    /// The plan of the kinds asked for: landmarks (as lipmap CSV unless a format is given),
    /// tables and plots when nothing is asked for or `all` is; meshes only when asked for
    /// (an OBJ per frame of the whole model is hundreds of megabytes for a few seconds).
    pub fn of(
        landmarks: Option<LandmarkFormat>,
        meshes: bool,
        tables: bool,
        plots: bool,
        all: bool,
    ) -> Self {
        let all = all || (landmarks.is_none() && !meshes && !tables && !plots);
        Self {
            landmarks: landmarks.or(all.then_some(LandmarkFormat::LipmapCsv)),
            meshes,
            tables: tables || all,
            plots: plots || all,
        }
    }

    /// Whether anything needs fits (and so the model).
    pub fn needs_fits(&self) -> bool {
        self.meshes || self.tables || self.plots
    }
}

/// One export: where, what, and the evaluation's settings.
#[derive(Clone, Debug)]
pub struct ExportRequest {
    pub out: PathBuf,
    pub plan: ExportPlan,
    /// Only this clip (by name).
    pub clip: Option<String>,
    pub normalisation: Normalisation,
    /// Rows of the worst-frames tables.
    pub worst: usize,
    /// Width of the charts in pixels.
    pub plot_width: u32,
    /// How W and H are compared under head pose (named in every table and chart).
    pub pose: crate::measure::PoseComparison,
}

/// Files written of one kind, and the folder they are in.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Written {
    pub files: usize,
    pub dir: PathBuf,
}

/// What an export wrote; each count is of files actually written.
#[derive(Clone, Debug, Default)]
pub struct ExportReport {
    pub landmarks: Option<Written>,
    pub meshes: Option<Written>,
    pub tables: Option<Written>,
    pub plots: Option<Written>,
    /// Failed fits per clip (no mesh was written for them).
    pub failed_fits: Vec<(String, Vec<FrameFit>)>,
    pub warnings: Vec<Warning>,
}

/// File names of the evaluation tables, in `EvalReport::tables` order.
pub const TABLE_FILES: [&str; 6] = [
    "sentences.csv",
    "phonemes.csv",
    "visemes.csv",
    "worst_frames.csv",
    "worst_fits.csv",
    "seals.csv",
];

/// Decimals kept in exported landmark coordinates: 1/10,000 px is far below any tracker's or
/// hand correction's precision, and drops float noise such as `41.28538095238095`.
pub const LANDMARK_DECIMALS: i32 = 4;

/// Longest file name made from a clip name, in bytes (file systems allow 255; room is left
/// for a collision number and an extension such as `.openface.csv`).
const MAX_NAME_BYTES: usize = 200;

/// One safe file name per clip name, in order: separators, control characters and characters
/// Windows forbids become `_`; `.`, `..` and empty names become `_`; over-long names are cut;
/// names that collide (also ignoring case, for case-insensitive file systems) get `-2`, `-3`…
///
/// ```
/// let names = ["../../evil", "/etc/passwd", "a", "A", "\u{1b}[2J"].map(String::from);
/// let safe = lipmap::workflow::export::safe_file_names(&names);
/// assert_eq!(safe, [".._.._evil", "_etc_passwd", "a", "A-2", "_[2J"]);
/// ```
pub fn safe_file_names(names: &[String]) -> Vec<String> {
    let mut taken: HashSet<String> = HashSet::new();
    names
        .iter()
        .map(|name| {
            let base = safe_file_name(name);
            let mut candidate = base.clone();
            let mut k = 2;
            while !taken.insert(candidate.to_lowercase()) {
                candidate = format!("{base}-{k}");
                k += 1;
            }
            candidate
        })
        .collect()
}

fn safe_file_name(name: &str) -> String {
    let mut s: String = name
        .chars()
        .map(|c| match c {
            '/' | '\\' | ':' | '*' | '?' | '"' | '<' | '>' | '|' => '_',
            c if c.is_control() => '_',
            c => c,
        })
        .collect();
    if s.len() > MAX_NAME_BYTES {
        let mut cut = MAX_NAME_BYTES;
        while !s.is_char_boundary(cut) {
            cut -= 1;
        }
        s.truncate(cut);
    }
    if s.is_empty() || s == "." || s == ".." { "_".to_string() } else { s }
}

/// The path of a clip's exported landmarks inside `out` for `format` (`file` is the clip's
/// safe file name).
pub fn landmarks_path(out: &Path, file: &str, format: LandmarkFormat) -> PathBuf {
    let dir = out.join("landmarks");
    match format {
        LandmarkFormat::Pts | LandmarkFormat::PtsFolder => dir.join(file),
        LandmarkFormat::OpenFace => dir.join(format!("{file}.openface.csv")),
        LandmarkFormat::DlibXml => dir.join(format!("{file}.xml")),
        LandmarkFormat::LipmapCsv => dir.join(format!("{file}.csv")),
        LandmarkFormat::EosCsv => dir.join(format!("{file}.eos.csv")),
    }
}

/// The OBJ of frame `frame` of a clip (by safe file name) inside `out`.
pub fn mesh_path(out: &Path, file: &str, frame: usize) -> PathBuf {
    out.join("meshes").join(file).join(format!("frame_{frame:06}.obj"))
}

/// The trajectory chart of a clip (by safe file name) inside `out`.
pub fn plot_path(out: &Path, file: &str) -> PathBuf {
    out.join("plots").join(format!("{file}.png"))
}

/// Makes `dir` a real folder: created when missing, a symlink in its place replaced by a
/// folder (the link's target is never touched or written through).
///
/// # Errors
/// A file in its place, or the folder cannot be made.
pub(crate) fn ensure_real_dir(dir: &Path) -> Result<()> {
    match std::fs::symlink_metadata(dir) {
        Ok(m) if m.file_type().is_symlink() => {
            std::fs::remove_file(dir).map_err(|e| Error::io(dir, e))?;
        }
        Ok(m) if m.is_dir() => return Ok(()),
        Ok(_) => {
            return Err(Error::Invalid(format!("{}: a file where a folder goes", dir.display())));
        }
        Err(_) => {}
    }
    std::fs::create_dir(dir).map_err(|e| Error::io(dir, e))
}

/// Checks `--out` can be used before anything is written: a missing folder is fine (it is
/// created), a file is not.
///
/// # Errors
/// `out` is a file.
pub fn check_out_dir(out: &Path) -> Result<()> {
    if out.is_file() {
        return Err(Error::Invalid(format!(
            "{}: --out must be a folder, not a file",
            out.display()
        )));
    }
    Ok(())
}

/// Runs an export of an opened session. The session changes only by storing fits its cache
/// lacked (saved when this process holds its lock). Progress: fitting, then writing meshes.
///
/// # Errors
/// Unknown clip, a missing model or map when fits are needed, any write failure (naming
/// the file).
pub fn export(
    opened: &mut ReadSession,
    req: &ExportRequest,
    progress: ProgressFn<'_>,
) -> Result<ExportReport> {
    check_out_dir(&req.out)?;
    let clips = select_clips(&opened.session, req.clip.as_deref())?;
    let all_names: Vec<String> = opened.session.clips.iter().map(|c| c.name.clone()).collect();
    // Safe names over all clips, so one clip's file name does not depend on --clip.
    let files = safe_file_names(&all_names);
    std::fs::create_dir_all(&req.out).map_err(|e| Error::io(&req.out, e))?;
    let mut report = ExportReport::default();

    if let Some(format) = req.plan.landmarks {
        let dir = req.out.join("landmarks");
        ensure_real_dir(&dir)?;
        let mut written = 0;
        for &c in &clips {
            let track = rounded_track(opened.session.effective_track(c)?);
            let target = landmarks_path(&req.out, &files[c], format);
            if format == LandmarkFormat::PtsFolder {
                ensure_real_dir(&target)?;
            }
            write_track(&track, &target, format)?;
            written += if format == LandmarkFormat::PtsFolder { track.frames.len() } else { 1 };
        }
        report.landmarks = Some(Written { files: written, dir });
    }
    if !req.plan.needs_fits() {
        return Ok(report);
    }

    let (res, warnings) = load_resources(&opened.session, &opened.path)?;
    report.warnings.extend(warnings);
    let settings = opened.session.fit_settings.clone();
    let which = ClipsToMeasure { clips: &clips, head_p: HeadP::Mesh, pose: req.pose };
    let done = utterances_with(&mut opened.session, &res, which, &settings, progress)?;
    report.warnings.extend(done.warnings.iter().cloned());
    // Save only when something is fitted now: an up-to-date session stays untouched.
    if done.refitted > 0 {
        opened.save_if_locked()?;
    }
    report.failed_fits = done
        .fits
        .iter()
        .map(|(clip, fits)| {
            (clip.clone(), fits.iter().filter(|f| !f.is_usable()).cloned().collect::<Vec<_>>())
        })
        .filter(|(_, failed)| !failed.is_empty())
        .collect();
    let file_of = |name: &str| -> String {
        all_names
            .iter()
            .position(|n| n == name)
            .map_or_else(|| name.to_string(), |i| files[i].clone())
    };

    if req.plan.meshes {
        let dir = req.out.join("meshes");
        ensure_real_dir(&dir)?;
        let mut written = 0;
        let total: usize = done.fits.iter().map(|(_, f)| f.len()).sum();
        progress(Progress::Stage { what: "writing meshes".into(), total });
        for (clip, fits) in &done.fits {
            written +=
                write_meshes(&res, fits, &req.out, &file_of(clip), written, total, progress)?;
        }
        progress(Progress::Finished);
        report.meshes = Some(Written { files: written, dir });
    }
    if req.plan.tables {
        let mut eval = evaluate(&done.utterances, &done.fit_refs(), req.normalisation, req.worst);
        eval.name_conditions(&super::EvalConditions {
            set: Some(settings.set),
            normalisation: req.normalisation,
            pose: req.pose,
        });
        let dir = req.out.join("tables");
        ensure_real_dir(&dir)?;
        for (table, file) in eval.tables().iter().zip(TABLE_FILES) {
            let p = dir.join(file);
            write_atomic(&p, |mut w| table.write_csv(&mut w)).map_err(|e| Error::io(&p, e))?;
        }
        report.tables = Some(Written { files: TABLE_FILES.len(), dir });
    }
    if req.plan.plots {
        let dir = req.out.join("plots");
        ensure_real_dir(&dir)?;
        for u in &done.utterances {
            let img = trajectory_chart(u, req.normalisation, req.pose, req.plot_width);
            let p = plot_path(&req.out, &file_of(&u.name));
            write_atomic(&p, |w| {
                let enc = image::codecs::png::PngEncoder::new(w);
                img.write_with_encoder(enc).map_err(std::io::Error::other)
            })
            .map_err(|e| Error::io(&p, e))?;
        }
        report.plots = Some(Written { files: done.utterances.len(), dir });
    }
    Ok(report)
}

/// `track` with every coordinate rounded to [`LANDMARK_DECIMALS`] decimals.
pub fn rounded_track(mut track: Track) -> Track {
    let k = 10f64.powi(LANDMARK_DECIMALS);
    for f in &mut track.frames {
        for p in &mut f.points {
            p.x = (p.x * k).round() / k;
            p.y = (p.y * k).round() / k;
        }
    }
    track
}

/// Writes one OBJ per successful fit of one clip; returns how many were written.
fn write_meshes(
    res: &Resources,
    fits: &[FrameFit],
    out: &Path,
    file: &str,
    done_before: usize,
    total: usize,
    progress: ProgressFn<'_>,
) -> Result<usize> {
    let faces = mesh_faces(res);
    ensure_real_dir(&out.join("meshes").join(file))?;
    let mut written = 0;
    for (i, fit) in fits.iter().enumerate() {
        progress(Progress::Steps { done: done_before + i + 1, total });
        if !fit.is_usable() {
            continue;
        }
        let shape = fitted_shape(&res.model, fit);
        let mesh = Mesh::from_flat(shape.as_slice(), faces.clone());
        obj::write_obj(&mesh_path(out, file, fit.frame), &mesh)?;
        written += 1;
    }
    Ok(written)
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
/// the evaluation compares them with (named on each y axis), phone boundaries and labels from
/// the clip's alignment, time in seconds.
pub fn trajectory_chart(
    u: &Utterance,
    normalisation: Normalisation,
    pose: crate::measure::PoseComparison,
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
            y_label: measure_axis_label(m, normalisation),
            caption: None,
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
        title: format!(
            "{}: mouth measures, video landmarks (2D) vs fitted 3D head, W/H {}",
            u.name,
            pose.short_label()
        ),
        fps: u.fps,
        alignment,
        panels,
        width,
        panel_height: 160,
        x_label: "time (s)".into(),
    })
}

/// A measure's y-axis label, two lines: the measure in words, the scale it is compared on.
fn measure_axis_label(m: Measure, normalisation: Normalisation) -> String {
    let name = match m {
        Measure::W => "W mouth width",
        Measure::H => "H mouth height",
        Measure::P => "P protrusion",
    };
    match (normalisation, m) {
        (Normalisation::MinMax, _) => format!("{name}\nmin–max scaled, 0–1"),
        (Normalisation::None, Measure::P) => format!("{name}\n÷ nasion–nose tip length"),
        (Normalisation::None, _) => format!("{name}\n÷ eye–nose length"),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clip_names_become_confined_distinct_file_names() {
        let names: Vec<String> =
            ["../../evil", "/abs/name", "..", ".", "", "a/b", "a_b", "ok", "OK", "x\u{9b}y"]
                .map(String::from)
                .to_vec();
        let safe = safe_file_names(&names);
        assert_eq!(
            safe,
            [".._.._evil", "_abs_name", "_", "_-2", "_-3", "a_b", "a_b-2", "ok", "OK-2", "x_y"]
        );
        for s in &safe {
            assert!(!s.contains('/') && s != ".." && !s.chars().any(char::is_control), "{s}");
        }
        let long = "é".repeat(300);
        let cut = &safe_file_names(&[long])[0];
        assert!(cut.len() <= MAX_NAME_BYTES && cut.chars().all(|c| c == 'é'));
    }

    #[cfg(unix)]
    #[test]
    fn a_symlinked_folder_inside_out_is_replaced_not_followed() {
        let dir = tempfile::tempdir().unwrap();
        let elsewhere = dir.path().join("elsewhere");
        std::fs::create_dir(&elsewhere).unwrap();
        std::fs::write(elsewhere.join("keep.txt"), "x").unwrap();
        let out = dir.path().join("out");
        std::fs::create_dir(&out).unwrap();
        std::os::unix::fs::symlink(&elsewhere, out.join("plots")).unwrap();
        ensure_real_dir(&out.join("plots")).unwrap();
        assert!(std::fs::symlink_metadata(out.join("plots")).unwrap().is_dir());
        assert_eq!(std::fs::read_dir(&elsewhere).unwrap().count(), 1);
        std::fs::write(out.join("file"), "").unwrap();
        assert!(ensure_real_dir(&out.join("file")).is_err());
    }

    #[test]
    fn the_plan_defaults_to_everything_but_meshes() {
        let p = ExportPlan::of(None, false, false, false, false);
        assert_eq!(p.landmarks, Some(LandmarkFormat::LipmapCsv));
        assert!(p.tables && p.plots && !p.meshes);
        let p = ExportPlan::of(None, true, false, false, false);
        assert!(p.meshes && !p.tables && !p.plots && p.landmarks.is_none());
    }
}
