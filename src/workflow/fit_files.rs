//! The files-in, files-out fit (no session): a model, a landmark map and a lipmap landmark CSV
//! in; `fit.csv` and `shapes.npy` out, each written atomically.
//!
//! Start with [`fit_files`]; the core does the fitting (`fit::Fitter`), this only reads,
//! reports progress and writes.

use super::error::{Error, Progress, ProgressFn, Result};
use crate::fit::{FitSettings, Fitter, FrameFit, for_each_block_of_fitted_shapes};
use crate::io::{FormatError, atomic, landmark_map_toml, model_source, npy_model};
use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// The checked inputs of a files-mode fit.
#[derive(Debug, Clone)]
pub struct FitFilesInput {
    /// Model: eos `.bin`, `.npz`, a `.npy` folder, a lipmap model file or a folder of pose OBJs.
    pub model: PathBuf,
    /// Expression blendshapes to add to the model (eos `.bin`, `.npy`, `.target`/OBJ folder).
    pub blendshapes: Option<PathBuf>,
    /// Landmark map: eos TOML (1-based iBUG ids) or eos's `landmarks_and_contours.json`.
    pub mapping: PathBuf,
    /// lipmap landmark CSV: `frame,point,x,y[,visible,confidence,source]`, pixels, y down.
    pub landmarks: PathBuf,
    /// Image size in pixels, (width, height); the height flips y for the camera.
    pub image_size: (u32, u32),
    /// The fit settings.
    pub settings: FitSettings,
    /// Output folder (created if missing).
    pub out: PathBuf,
}

/// What a files-mode fit did.
#[derive(Debug, Clone)]
pub struct FitFilesReport {
    /// One fit per frame of the landmark file, in its order.
    pub fits: Vec<FrameFit>,
    /// Time spent fitting (reading and writing excluded).
    pub elapsed: Duration,
    pub fit_csv: PathBuf,
    pub shapes: PathBuf,
}

impl FitFilesReport {
    pub fn failed(&self) -> usize {
        self.fits.iter().filter(|f| f.failed.is_some()).count()
    }
}

/// Fits every frame of `input.landmarks` and writes `fit.csv` and `shapes.npy` into
/// `input.out`. `progress` gets one stage ("fitting clip" or "fitting frames") and its steps.
///
/// # Errors
/// Unreadable or invalid inputs (naming the file), a map that points past the model's
/// vertices or that the fit cannot use, or output that cannot be written.
pub fn fit_files(input: &FitFilesInput, progress: ProgressFn<'_>) -> Result<FitFilesReport> {
    let settings = &input.settings;
    let model = model_source::load_model(&input.model, input.blendshapes.as_deref())?;
    let map = landmark_map_toml::read_landmark_map(&input.mapping)?;
    super::check_map_vertices(&map, model.num_vertices(), Some(&input.mapping))?;
    let track = crate::io::landmark_format::read_track(&input.landmarks)?;
    if track.is_empty() {
        return Err(FormatError::whole(&input.landmarks, "no frames").into());
    }
    // The files are one clip of one tracker: its own meeting frames give the precision.
    let pooled = crate::landmarks::closure::contact_precision([&track]);
    let track = crate::landmarks::closure::with_sealed_lips(track, settings.closure, pooled);
    std::fs::create_dir_all(&input.out).map_err(|e| Error::io(&input.out, e))?;
    super::check_map_for_fit(&map, model.num_vertices(), settings)
        .map_err(|e| Error::from(e).context(input.mapping.display().to_string()))?;

    let height = f64::from(input.image_size.1);
    let fitter = Fitter::new(&model, &map, settings);
    let total = track.len();
    let what = if settings.clip { "fitting clip" } else { "fitting frames" };
    progress(Progress::Stage { what: what.into(), total });
    let t0 = Instant::now();
    let step = |done: usize| progress(Progress::Steps { done, total });
    let fits = fitter.fit_frames(&track.frames, height, Some(&step));
    let elapsed = t0.elapsed();
    progress(Progress::Finished);

    let fit_csv = input.out.join("fit.csv");
    write_fit_csv(&fit_csv, &fits)?;
    let shapes = input.out.join("shapes.npy");
    let n3 = 3 * model.num_vertices();
    // A block of meshes at a time straight to the file: the whole array is 41 MB per 1,000
    // frames.
    let mut npy = npy_model::NpyF32Writer::create(&shapes, &[fits.len() as u64, n3 as u64])?;
    let mut written = Ok(());
    for_each_block_of_fitted_shapes(&model, &fits, |_, block| {
        if written.is_ok() {
            written = npy.write_rows(block);
        }
    });
    written?;
    npy.finish()?;
    Ok(FitFilesReport { fits, elapsed, fit_csv, shapes })
}

/// Writes `frame,yaw,pitch,roll,scale,tx,ty,reproj_rms_px,failed` (failed: empty, or the
/// reason; a failed frame's numbers are left empty, so no one reads its zeros as a fit).
fn write_fit_csv(path: &Path, fits: &[FrameFit]) -> Result<()> {
    atomic::write_atomic(path, |out| {
        let mut w = csv::Writer::from_writer(out);
        w.write_record([
            "frame",
            "yaw",
            "pitch",
            "roll",
            "scale",
            "tx",
            "ty",
            "reproj_rms_px",
            "failed",
        ])?;
        for f in fits {
            let num = |v: f64| if f.failed.is_some() { String::new() } else { format!("{v:.6}") };
            w.write_record([
                f.frame.to_string(),
                num(f.yaw),
                num(f.pitch),
                num(f.roll),
                num(f.scale),
                num(f.tx),
                num(f.ty),
                num(f.reproj_rms_px),
                f.failed.clone().unwrap_or_default(),
            ])?;
        }
        w.flush()
    })
    .map_err(|e| Error::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::workflow::no_progress;

    #[test]
    fn a_failed_frame_has_no_numbers_in_fit_csv() {
        let fit = |frame: usize, failed: Option<&str>| FrameFit {
            reproj_rms_px: 0.5,
            failed: failed.map(String::from),
            ..FrameFit::unposed(frame)
        };
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("fit.csv");
        write_fit_csv(&path, &[fit(0, None), fit(1, Some("too few"))]).unwrap();
        let text = std::fs::read_to_string(&path).unwrap();
        let rows: Vec<&str> = text.lines().collect();
        assert!(rows[1].ends_with(",0.500000,"), "{text}");
        assert_eq!(rows[2], "1,,,,,,,,too few");
    }

    fn input(eos: &Path, landmarks: PathBuf, out: PathBuf) -> FitFilesInput {
        FitFilesInput {
            model: eos.join("model"),
            blendshapes: None,
            mapping: eos.join("share/ibug_to_sfm.txt"),
            landmarks,
            image_size: (1280, 720),
            settings: FitSettings::default(),
            out,
        }
    }

    #[test]
    fn missing_landmarks_file_is_named_once() {
        let Some(eos) = crate::testdata::shared("peer/eos") else { return };
        let dir = tempfile::tempdir().unwrap();
        let missing = dir.path().join("nope.csv");
        let a = input(&eos, missing.clone(), dir.path().join("out"));
        let e = super::super::error_chain(&fit_files(&a, &no_progress).unwrap_err());
        assert_eq!(e.matches(&*missing.to_string_lossy()).count(), 1, "{e}");
    }

    #[test]
    fn fits_eos_frames_and_writes_both_outputs() {
        let Some(eos) = crate::testdata::shared("peer/eos") else { return };
        let dir = tempfile::tempdir().unwrap();
        // First 4 frames of eos's synthetic landmarks as lipmap CSV (0-based points).
        let text = std::fs::read_to_string(eos.join("reference/landmarks.csv")).unwrap();
        let mut csv = String::from("frame,point,x,y\n");
        for line in text.lines().skip(1) {
            let v: Vec<&str> = line.split(',').collect();
            if v[0].parse::<usize>().unwrap() < 4 {
                let id: usize = v[1].parse().unwrap();
                csv.push_str(&format!("{},{},{},{}\n", v[0], id - 1, v[2], v[3]));
            }
        }
        let lm = dir.path().join("lm.csv");
        std::fs::write(&lm, csv).unwrap();
        let out = dir.path().join("out");
        let mut a = input(&eos, lm, out.clone());
        a.settings.clip = true;
        let report = fit_files(&a, &no_progress).unwrap();
        assert_eq!(report.failed(), 0);
        let fit = std::fs::read_to_string(out.join("fit.csv")).unwrap();
        assert_eq!(fit.lines().count(), 5);
        assert!(fit.starts_with("frame,yaw,pitch,roll,scale,tx,ty,reproj_rms_px,failed"));
        let shapes = npy_model::read_npy(&out.join("shapes.npy")).unwrap();
        assert_eq!(shapes.shape, vec![4, 3 * 3448]);
        let names: Vec<_> =
            std::fs::read_dir(&out).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names.len(), 2, "no temp files left: {names:?}");
    }
}
