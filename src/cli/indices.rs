//! `lipmap indices`: the 12 facial indices of a landmark file, or of a session's speaker
//! (neutral frame) and head (neutral pose) with the matching verdict; corpus class bounds.

use crate::cli::output::{FormatArgs, write_tables};
use crate::cli::progress::print_warnings;
use crate::eval::Table;
use crate::eval::report::indices_table;
use crate::measure::{BoundsTable, FacialIndices};
use crate::workflow::indices::{
    box_plot_table, file_indices, load_bounds, missing_note, save_bounds, session_tables,
    speaker_neutral,
};
use crate::workflow::{clip_or_first, read_session, session_path};
use anyhow::{Result, anyhow, bail};
use std::io::Write;
use std::path::{Path, PathBuf};

/// Facial indices (×100 distance ratios) with their low/middle/high classes.
///
/// On a landmark file: the indices of one frame. On a session: the speaker's indices on a
/// neutral frame, the head's on its neutral pose (the head mesh, else the model's mean,
/// through the landmark map, frontal projection) and the speaker–head verdict.
/// With --compute-bounds: class bounds from many speakers by the box-plot rule.
#[derive(clap::Args, Debug)]
pub struct IndicesArgs {
    /// A session (`NAME` for sessions/NAME.lipmap.json, or a `.lipmap.json` path) or a
    /// landmark file (.pts, OpenFace CSV, dlib XML, lipmap CSV, eos CSV, folder of .pts). With
    /// --compute-bounds: one neutral-frame landmark file (or session) per speaker.
    #[arg(required = true, num_args = 1..)]
    pub inputs: Vec<String>,
    /// Frame to measure (default: a landmark file's first frame; in a session, the frame
    /// with the smallest mouth opening inside a silence interval of the clip's alignment).
    #[arg(long)]
    pub frame: Option<usize>,
    /// Session clip for the speaker (default: the first).
    #[arg(long)]
    pub clip: Option<String>,
    /// Class bounds to use instead of the published ones: CSV with columns index,low,high,
    /// or TOML (`.toml`) with [[bounds]] entries index, low, high.
    #[arg(long, value_name = "FILE")]
    pub bounds: Option<PathBuf>,
    /// Compute class bounds from the inputs (one speaker each, ≥ 4) with the box-plot rule
    /// (low = Q1, high = Q3) and write them to FILE (`.toml` for TOML, else CSV), for use
    /// with --bounds.
    #[arg(long, value_name = "FILE")]
    pub compute_bounds: Option<PathBuf>,
    #[command(flatten)]
    pub output: FormatArgs,
}

/// What a command-line input names.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum IndicesInput {
    Session(PathBuf),
    Landmarks(PathBuf),
}

/// A `.json` path (no landmark format is JSON) or a name that is not an existing path is a
/// session; any other existing path is a landmark file or folder.
pub fn classify_input(s: &str) -> IndicesInput {
    let p = Path::new(s);
    if s.ends_with(".json") || !p.exists() {
        IndicesInput::Session(session_path(s))
    } else {
        IndicesInput::Landmarks(p.to_path_buf())
    }
}

/// One speaker's indices for a corpus: a session's neutral frame or a landmark file's frame.
fn corpus_sample(
    input: &str,
    frame: Option<usize>,
    clip: Option<&str>,
) -> crate::workflow::Result<FacialIndices> {
    match classify_input(input) {
        IndicesInput::Landmarks(p) => Ok(file_indices(&p, frame)?.1),
        IndicesInput::Session(p) => {
            let read = read_session(&p)?;
            print_warnings(&read.notices);
            let c = clip_or_first(&read.session, clip)?;
            Ok(speaker_neutral(&read.session, c, frame)?.indices)
        }
    }
}

pub fn run(a: &IndicesArgs, out: &mut dyn Write) -> Result<()> {
    if let Some(dest) = &a.compute_bounds {
        let samples = a
            .inputs
            .iter()
            .map(|i| {
                corpus_sample(i, a.frame, a.clip.as_deref())
                    .map_err(|e| anyhow::Error::new(e).context(i.clone()))
            })
            .collect::<Result<Vec<_>>>()?;
        let (table, plots) = BoundsTable::from_corpus(&samples)
            .map_err(|e| anyhow!("computing bounds from {} speakers: {e}", samples.len()))?;
        save_bounds(&table, dest)?;
        let mut t = box_plot_table(&table, &plots);
        t.notes.push(format!("written to {}", dest.display()));
        return write_tables(&[&t], a.output.format(), out);
    }
    let [input] = a.inputs.as_slice() else {
        bail!("give one session or landmark file (several only with --compute-bounds)");
    };
    let bounds = match &a.bounds {
        Some(p) => load_bounds(p)?,
        None => crate::reference::current().bounds.clone(),
    };
    let tables = match classify_input(input) {
        IndicesInput::Landmarks(p) => {
            let (frame, ix) = file_indices(&p, a.frame)?;
            let mut t = indices_table("facial indices", &ix, &bounds).keyed("indices");
            t.notes.push(format!("{}, frame {frame}", p.display()));
            t.notes.extend(missing_note(&ix, "points not visible"));
            vec![t]
        }
        IndicesInput::Session(p) => {
            if !p.exists() {
                bail!("{}: no such session or landmark file", p.display());
            }
            let read = read_session(&p)?;
            print_warnings(&read.notices);
            session_tables(&read, a.clip.as_deref(), a.frame, &bounds)?
        }
    };
    let refs: Vec<&Table> = tables.iter().collect();
    write_tables(&refs, a.output.format(), out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_and_missing_paths_are_sessions() {
        let d = tempfile::tempdir().unwrap();
        let pts = d.path().join("a.pts");
        std::fs::write(&pts, "").unwrap();
        let s = pts.to_str().unwrap();
        assert_eq!(classify_input(s), IndicesInput::Landmarks(pts.clone()));
        assert_eq!(classify_input("demo"), IndicesInput::Session(session_path("demo")));
        let j = d.path().join("x.json");
        std::fs::write(&j, "").unwrap();
        assert_eq!(classify_input(j.to_str().unwrap()), IndicesInput::Session(j.clone()));
    }
}
