//! `lipmap fit --model … --landmarks …`: the headless files-in, files-out fit
//! (`workflow::fit_files`); this module turns the flags into its input and prints the summary.

use crate::cli::exit::Outcome;
use crate::cli::output::{median_reprojection, plural, rms_text, terminal_safe};
use crate::cli::progress::{frames_bar, show_on};
use crate::fit::FitSettings;
use crate::workflow::fit_files::{FitFilesInput, fit_files};
use anyhow::Result;
use std::path::PathBuf;

/// The files-mode flags; `cli::fit_cmd::FitArgs` (the command line) builds it once the
/// required flags are known to be present.
#[derive(Debug, Clone)]
pub struct FitFilesArgs {
    pub model: PathBuf,
    pub blendshapes: Option<PathBuf>,
    pub mapping: PathBuf,
    pub landmarks: PathBuf,
    /// Image size in pixels, `WxH` (the height flips y for the camera).
    pub image_size: (u32, u32),
    /// The fit-setting flags, laid over `FitSettings::default()`.
    pub settings: crate::cli::fit_cmd::FitSettingArgs,
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

/// Runs the fit, writes the outputs and prints one summary line; `Outcome::Partial` when
/// some frames failed.
///
/// # Errors
/// Bad settings, and everything [`fit_files`] reports.
pub fn run_with_outcome(args: &FitFilesArgs) -> Result<Outcome> {
    let input = FitFilesInput {
        model: args.model.clone(),
        blendshapes: args.blendshapes.clone(),
        mapping: args.mapping.clone(),
        landmarks: args.landmarks.clone(),
        image_size: args.image_size,
        settings: args.settings.apply(&FitSettings::default())?,
        out: args.out.clone(),
    };
    let bar = frames_bar(0, "fitting");
    let report = fit_files(&input, &show_on(&bar))?;
    bar.finish_and_clear();
    let n = report.fits.len();
    let ms = report.elapsed.as_secs_f64() * 1e3;
    println!(
        "fitted {} ({} failed, {}) in {ms:.1} ms ({:.3} ms/frame); median reprojection RMS {}; wrote {} and {}",
        plural(n, "frame"),
        report.failed(),
        if input.settings.clip { "clip" } else { "per frame" },
        ms / n as f64,
        rms_text(median_reprojection(&report.fits)),
        terminal_safe(&report.fit_csv.display().to_string()),
        terminal_safe(&report.shapes.display().to_string()),
    );
    Ok(if report.failed() > 0 { Outcome::Partial } else { Outcome::Ok })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn image_size_parses_and_rejects() {
        assert_eq!(parse_image_size("1280x720"), Ok((1280, 720)));
        assert!(parse_image_size("1280").is_err());
        assert!(parse_image_size("0x5").is_err());
    }
}
