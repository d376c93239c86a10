//! `lipmap validate FILE...`: parse any file lipmap reads or writes (landmarks, alignments,
//! meshes, models, landmark maps, blendshape targets, sessions, videos and frame folders,
//! WAVs, speech and quality models, synthesized motion, fit results, shapes arrays, tables,
//! plots) and print `ok` and what it holds, or the one-line error. The use case is
//! `workflow::validate`; this module words its summary.

use crate::cli::output::plural;
use crate::workflow::validate::{FileSummary, validate_file};
use anyhow::Result;
use std::io::Write;
use std::path::PathBuf;

/// Check files of any supported kind; exit code 2 when any is bad.
#[derive(clap::Args, Debug)]
pub struct ValidateArgs {
    /// Files (or folders of .pts / pose OBJs / .npy model parts) to check.
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
}

/// What a valid file holds, in a few words.
fn describe(summary: &FileSummary) -> String {
    match summary {
        FileSummary::Session { clips, frames, cached_fits, map, notices } => {
            let map = match map {
                Some(Ok(summary)) => format!("; {summary}"),
                Some(Err(e)) => format!("; map not checked: {e}"),
                None => String::new(),
            };
            let notes: String = notices.iter().map(|w| format!("; {}", w.status_text())).collect();
            format!(
                "session, {}, {} tracked, {}{map}{notes}",
                plural(*clips, "clip"),
                plural(*frames, "frame"),
                plural(*cached_fits, "cached fit")
            )
        }
        FileSummary::Landmarks { frames } => format!("landmarks, {}", plural(*frames, "frame")),
        FileSummary::Alignment { phones } => format!("alignment, {}", plural(*phones, "phone")),
        FileSummary::Mesh { vertices, faces } => {
            format!("mesh, {}, {}", plural_vertices(*vertices), plural(*faces, "face"))
        }
        FileSummary::Model { vertices, shape_components, expressions } => format!(
            "model, {}, {}, {}",
            plural_vertices(*vertices),
            plural(*shape_components, "shape component"),
            plural(*expressions, "expression")
        ),
        FileSummary::Blendshapes { expressions, vertices } => format!(
            "blendshapes, {}, {}",
            plural(*expressions, "expression"),
            plural_vertices(*vertices)
        ),
        FileSummary::BlendshapeFolder { targets } => {
            format!("blendshape folder, {}", plural(*targets, "target"))
        }
        FileSummary::LandmarkMap { landmarks } => {
            format!("landmark map, {} mapped", plural(*landmarks, "landmark"))
        }
        FileSummary::Target { offsets } => {
            format!("blendshape target, {}", plural(*offsets, "vertex offset"))
        }
        FileSummary::Audio { seconds, sample_rate } => {
            format!("audio, {seconds:.2} s at {sample_rate} Hz")
        }
        FileSummary::SpeechModel { states, frame_rate, drives } => format!(
            "speech model, {} at {frame_rate} fps, driving {}",
            plural(*states, "state"),
            drives.display()
        ),
        FileSummary::QualityModel { sentences, sessions } => format!(
            "quality model, trained on {} from {}",
            plural(*sentences, "sentence"),
            plural(*sessions, "session")
        ),
        FileSummary::Motion { frames, vertices } => format!(
            "synthesized motion, {} of {}",
            plural(*frames, "frame"),
            plural_vertices(*vertices)
        ),
        FileSummary::FitResults { frames, failed } => {
            format!("fit results (fit.csv), {}, {failed} failed", plural(*frames, "frame"))
        }
        FileSummary::FrameList { frames } => {
            format!("frame list (frames.csv beside a shapes.npy), {}", plural(*frames, "frame"))
        }
        FileSummary::Table { rows, columns } => {
            let mut cols = columns.iter().take(4).cloned().collect::<Vec<_>>().join(", ");
            if columns.len() > 4 {
                cols.push_str(", …");
            }
            format!(
                "table, {} × {} ({cols})",
                plural(*rows, "row"),
                plural(columns.len(), "column")
            )
        }
        FileSummary::Array { rows, columns } if columns % 3 == 0 => format!(
            "array {rows} × {columns}: {} of {} (per-frame shapes as shapes.npy, or blendshapes)",
            plural(*rows, "shape"),
            plural_vertices(columns / 3)
        ),
        FileSummary::Array { rows, columns } => format!("array {rows} × {columns}"),
        FileSummary::Image { size: [w, h] } => format!("image, {w}x{h}"),
        FileSummary::Frames { folder, frames, fps, size: [w, h] } => {
            // 29.97002997… prints as 29.97, 25.0 as 25.
            let rate = format!("{fps:.2}");
            let rate = rate.trim_end_matches('0').trim_end_matches('.');
            let (what, fps) = if *folder {
                ("image folder", format!("{rate} fps assumed (give --fps to `lipmap new`)"))
            } else {
                ("video", format!("{rate} fps"))
            };
            format!("{what}, {} at {fps}, {w}x{h}", plural(*frames, "frame"))
        }
    }
}

fn plural_vertices(n: usize) -> String {
    if n == 1 { "1 vertex".into() } else { format!("{n} vertices") }
}

/// Validates every file, printing `PATH: ok (...)` or the error; returns the number of bad files.
pub fn run(args: &ValidateArgs, out: &mut dyn Write) -> Result<usize> {
    let mut bad = 0;
    for path in &args.files {
        match validate_file(path) {
            Ok(summary) => writeln!(out, "{}: ok ({})", path.display(), describe(&summary))?,
            Err(e) => {
                bad += 1;
                let msg = crate::workflow::error_chain(&e);
                // Parser errors already name the file; don't print it twice.
                if msg.contains(&path.display().to_string()) {
                    writeln!(out, "{msg}")?;
                } else {
                    writeln!(out, "{}: {msg}", path.display())?;
                }
            }
        }
    }
    Ok(bad)
}
