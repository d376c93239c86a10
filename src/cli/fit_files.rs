//! `lipmap fit --model … --landmarks …`: the headless files-in, files-out fit. Reads a model,
//! a landmark map and a lipmap landmark CSV; writes `fit.csv` and `shapes.npy` into `--out`.
//!
//! Every unreadable input is an error naming the file; the core does the fitting
//! (`fit::Fitter`), this module only reads, reports progress and writes.

use crate::cli::exit::Outcome;
use crate::cli::progress::frames_bar;
use crate::fit::{FitSettings, Fitter, FrameFit, for_each_fitted_shape};
use crate::io::{landmark_map_toml, model_source, npy_model, track_csv};
use crate::model::LandmarkMap;
use anyhow::{Context, Result, bail};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// The checked inputs of a files-mode fit; `cli::fit_cmd::FitArgs` (the command line)
/// builds it once the required flags are known to be present.
#[derive(Debug, Clone)]
pub struct FitFilesArgs {
    /// Model: eos `.bin`, `.npz`, a `.npy` folder, a lipmap model file or a folder of pose OBJs.
    pub model: PathBuf,
    /// Expression blendshapes to add to the model (eos `.bin`, `.npy`, `.target`/OBJ folder).
    pub blendshapes: Option<PathBuf>,
    /// Landmark map: eos TOML (1-based iBUG ids) or eos's `landmarks_and_contours.json`.
    pub mapping: PathBuf,
    /// lipmap landmark CSV: `frame,point,x,y[,visible,confidence,source]`, pixels, y down.
    pub landmarks: PathBuf,
    /// Image size in pixels, `WxH` (the height flips y for the camera).
    pub image_size: (u32, u32),
    /// The fit-setting flags, laid over `FitSettings::default()`.
    pub settings: crate::cli::fit_cmd::FitSettingArgs,
    /// Output folder (created if missing).
    pub out: PathBuf,
}

/// Parses `WxH` (e.g. `1280x720`).
pub fn parse_image_size(s: &str) -> std::result::Result<(u32, u32), String> {
    let (w, h) = s
        .trim()
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("image size `{s}` is not WxH (e.g. 1280x720)"))?;
    let parse = |v: &str| v.trim().parse::<u32>().ok().filter(|&n| n > 0);
    match (parse(w), parse(h)) {
        (Some(w), Some(h)) => Ok((w, h)),
        _ => Err(format!("image size `{s}` needs two positive integers, WxH")),
    }
}

fn read_mapping(path: &Path) -> Result<LandmarkMap> {
    let is_json = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("json"));
    Ok(if is_json {
        landmark_map_toml::read_landmark_map_json(path)?
    } else {
        landmark_map_toml::read_landmark_map(path)?
    })
}

/// Runs the fit and writes the outputs; `Outcome::Partial` when some frames failed.
///
/// # Errors
/// Unreadable or invalid inputs (naming the file), a map that points past the model's
/// vertices, bad settings, or output that cannot be written.
pub fn run_with_outcome(args: &FitFilesArgs) -> Result<Outcome> {
    let settings = args.settings.apply(&FitSettings::default())?;
    let model = model_source::load_model(&args.model, args.blendshapes.as_deref())?;
    let map = read_mapping(&args.mapping)?;
    crate::workflow::check_map_vertices(&map, model.num_vertices(), Some(&args.mapping))?;
    let track = track_csv::read_track_csv(&args.landmarks)?;
    if track.is_empty() {
        bail!("{}: no frames", args.landmarks.display());
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("{}: cannot create the output folder", args.out.display()))?;

    let height = f64::from(args.image_size.1);
    crate::workflow::check_map_for_fit(&map, model.num_vertices(), &settings)
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.mapping.display()))?;
    let fitter = Fitter::new(&model, &map, &settings);
    let bar = frames_bar(
        track.len() as u64,
        if settings.clip { "fitting clip" } else { "fitting frames" },
    );
    let t0 = Instant::now();
    let progress = |n: usize| bar.set_position(n as u64);
    let fits = fitter.fit_frames(&track.frames, height, Some(&progress));
    let elapsed = t0.elapsed();
    bar.finish_and_clear();

    let fit_csv = args.out.join("fit.csv");
    write_fit_csv(&fit_csv, &fits)?;
    let shapes = args.out.join("shapes.npy");
    let n3 = 3 * model.num_vertices();
    // One mesh at a time straight to the file: the whole array is 41 MB per 1,000 frames.
    let mut npy = npy_model::NpyF32Writer::create(&shapes, &[fits.len() as u64, n3 as u64])?;
    let mut written = Ok(());
    for_each_fitted_shape(&model, &fits, |_, s| {
        if written.is_ok() {
            written = npy.write(s);
        }
    });
    written?;
    npy.finish()?;

    let failed = fits.iter().filter(|f| f.failed.is_some()).count();
    let median = crate::cli::output::rms_text(crate::cli::output::median_reprojection(&fits));
    println!(
        "fitted {} ({} failed, {}) in {:.1} ms ({:.3} ms/frame); median reprojection RMS {}; wrote {} and {}",
        crate::cli::output::plural(fits.len(), "frame"),
        failed,
        if settings.clip { "clip" } else { "per frame" },
        elapsed.as_secs_f64() * 1e3,
        elapsed.as_secs_f64() * 1e3 / fits.len() as f64,
        median,
        fit_csv.display(),
        shapes.display()
    );
    Ok(if failed > 0 { Outcome::Partial } else { Outcome::Ok })
}

/// Runs the fit and writes the outputs (see [`run_with_outcome`]).
///
/// # Errors
/// As [`run_with_outcome`].
pub fn run(args: &FitFilesArgs) -> Result<()> {
    run_with_outcome(args).map(|_| ())
}

/// Writes `frame,yaw,pitch,roll,scale,tx,ty,reproj_rms_px,failed` (failed: empty, or the
/// reason; a failed frame's numbers are left empty, so no one reads its zeros as a fit).
fn write_fit_csv(path: &Path, fits: &[FrameFit]) -> Result<()> {
    let err = |e: csv::Error| anyhow::anyhow!("{}: {e}", path.display());
    let mut w = csv::Writer::from_path(path).map_err(err)?;
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
    ])
    .map_err(err)?;
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
        ])
        .map_err(err)?;
    }
    w.flush().map_err(|e| anyhow::anyhow!("{}: {e}", path.display()))?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

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

    #[test]
    fn image_size_parses_and_rejects() {
        assert_eq!(parse_image_size("1280x720"), Ok((1280, 720)));
        assert!(parse_image_size("1280").is_err());
        assert!(parse_image_size("0x5").is_err());
    }

    #[test]
    fn missing_landmarks_file_is_named() {
        let Some(eos) = crate::testdata::shared("peer/eos") else { return };
        let dir = tempfile::tempdir().unwrap();
        let args = FitFilesArgs {
            model: eos.join("model"),
            blendshapes: None,
            mapping: eos.join("share/ibug_to_sfm.txt"),
            landmarks: dir.path().join("nope.csv"),
            image_size: (1280, 720),
            settings: Default::default(),
            out: dir.path().join("out"),
        };
        let e = run(&args).unwrap_err().to_string();
        assert!(e.contains("nope.csv"), "{e}");
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
        let args = FitFilesArgs {
            model: eos.join("model"),
            blendshapes: None,
            mapping: eos.join("share/ibug_to_sfm.txt"),
            landmarks: lm,
            image_size: (1280, 720),
            settings: crate::cli::fit_cmd::FitSettingArgs { clip: true, ..Default::default() },
            out: out.clone(),
        };
        assert_eq!(run_with_outcome(&args).unwrap(), Outcome::Ok);
        let fit = std::fs::read_to_string(out.join("fit.csv")).unwrap();
        assert_eq!(fit.lines().count(), 5);
        assert!(fit.starts_with("frame,yaw,pitch,roll,scale,tx,ty,reproj_rms_px,failed"));
        let shapes = npy_model::read_npy(&out.join("shapes.npy")).unwrap();
        assert_eq!(shapes.shape, vec![4, 3 * 3448]);
    }
}
