//! `lipmap convert IN OUT`: landmark files between formats (by extension or header), and
//! phone alignments between formats, keeping sub-pixel precision wherever the target allows.

use crate::io::alignment_format::{self, AlignmentFormat};
use crate::io::landmark_format::{self, LandmarkFormat};
use anyhow::{Context, Result, bail};
use std::path::PathBuf;

/// Convert landmarks (.pts, folder of .pts, OpenFace CSV, dlib XML, lipmap CSV, eos CSV) or phone
/// alignments (TextGrid, HTK/Festival .lab, xlabel, start,end,phone CSV).
#[derive(clap::Args, Debug)]
pub struct ConvertArgs {
    /// Input file (or folder of .pts files).
    pub input: PathBuf,
    /// Output file; its extension picks the format unless --to is given
    /// (.pts, .xml, .csv, no extension = folder of .pts; .TextGrid, .lab).
    pub output: PathBuf,
    /// Output format: pts, pts-dir, openface, dlib, csv (landmarks) or textgrid, lab,
    /// xlabel, csv (alignments).
    #[arg(long)]
    pub to: Option<String>,
}

/// The landmark format to write `output` in: `to` when given, else judged from the name.
///
/// # Errors
/// An unknown format name, or a name that does not tell.
pub fn landmark_output_format(
    output: &std::path::Path,
    to: Option<&str>,
) -> Result<LandmarkFormat> {
    match to {
        Some(name) => name.parse::<LandmarkFormat>().map_err(anyhow::Error::msg),
        None => LandmarkFormat::for_output(output).with_context(|| {
            format!(
                "{}: cannot tell the output format from the name; use --to pts|pts-dir|openface|dlib|csv",
                output.display()
            )
        }),
    }
}

/// Runs the conversion; returns a one-line description of what was written.
pub fn run(args: &ConvertArgs) -> Result<String> {
    if crate::io::file_kind::is_alignment_path(&args.input) {
        let alignment = alignment_format::read_alignment(&args.input, None)?;
        let format = match &args.to {
            Some(name) => name.parse::<AlignmentFormat>().map_err(anyhow::Error::msg)?,
            None => alignment_output_format(&args.output)?,
        };
        alignment_format::write_alignment(&alignment, &args.output, format)?;
        return Ok(format!(
            "{} phones -> {} ({format})",
            alignment.phones.len(),
            args.output.display()
        ));
    }
    let track = landmark_format::read_track(&args.input)?;
    let format = landmark_output_format(&args.output, args.to.as_deref())?;
    if format == LandmarkFormat::Pts && track.len() != 1 {
        bail!(
            "{}: a single .pts file holds one frame but {} has {}; write a folder (no extension) instead",
            args.output.display(),
            args.input.display(),
            track.len()
        );
    }
    landmark_format::write_track(&track, &args.output, format)?;
    Ok(format!(
        "{} -> {} ({})",
        crate::cli::output::plural(track.len(), "frame"),
        args.output.display(),
        format.name()
    ))
}

fn alignment_output_format(path: &std::path::Path) -> Result<AlignmentFormat> {
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    Ok(match ext.as_deref() {
        Some("textgrid") => AlignmentFormat::TextGrid,
        Some("lab") => AlignmentFormat::HtkLab,
        Some("csv") => AlignmentFormat::PhonesCsv,
        _ => bail!(
            "{}: cannot tell the output format from the name; use --to textgrid|lab|xlabel|csv",
            path.display()
        ),
    })
}
