//! `lipmap transfer SESSION --head HEAD.obj`: the session's fitted motion onto another head
//! (`shapes.npy` per clip, OBJs with `--objs`); the head is recorded in the session so
//! `eval` prints its tables too.

use crate::cli::output::terminal_safe;
use crate::cli::progress::{frames_bar, print_warnings, show_on};
use crate::glossary::names::{PLACEMENT_RESIDUAL, TRIANGLES_DROPPED};
use crate::transfer::Interpolation;
use crate::workflow::{self, open_for_read, select_clips};
use anyhow::Result;
use std::io::Write;
use std::path::PathBuf;

/// Drive another head (an OBJ with a landmark map) with the session's fitted motion.
#[derive(clap::Args, Debug)]
pub struct TransferArgs {
    /// Session file or name.
    pub session: String,
    /// The head to animate (OBJ; MakeHuman's helper-*/joint-* groups are never moved as skin);
    /// default: the session's head.
    #[arg(long)]
    pub head: Option<PathBuf>,
    /// The head's landmark map (eos TOML, 1-based iBUG ids); default: the session's head map
    /// for the session's head, else HEAD.toml or HEAD_map.toml beside the head.
    #[arg(long)]
    pub mapping: Option<PathBuf>,
    /// How the head follows the control points.
    #[arg(long, value_enum, default_value_t = ModeArg::Biharmonic)]
    pub mode: ModeArg,
    /// Only this clip.
    #[arg(long)]
    pub clip: Option<String>,
    /// Also write one OBJ per frame.
    #[arg(long)]
    pub objs: bool,
    /// Output folder (one subfolder per clip).
    #[arg(long)]
    pub out: PathBuf,
    /// Transfer with a map that fails the map checks (`lipmap map check`: shared vertices,
    /// left/right swaps, no landmarks, a mesh that is not a surface) anyway.
    #[arg(long)]
    pub accept_map_warnings: bool,
}

/// `--mode` (and `eval --transfer-mode`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, clap::ValueEnum)]
pub enum ModeArg {
    Biharmonic,
    Barycentric,
}

impl From<ModeArg> for Interpolation {
    fn from(mode: ModeArg) -> Self {
        match mode {
            ModeArg::Biharmonic => Interpolation::Biharmonic,
            ModeArg::Barycentric => Interpolation::Barycentric,
        }
    }
}

pub fn run(a: &TransferArgs, out: &mut dyn Write) -> Result<()> {
    // Its output goes to --out: a session that cannot be saved (read-only, or open in an
    // editor) is read as it is, and the head is then not recorded in it.
    let mut opened = open_for_read(&a.session)?;
    print_warnings(&opened.notices);
    let (res, warnings) = workflow::load_resources(&opened.session, &opened.path)?;
    print_warnings(&warnings);
    let clips = select_clips(&opened.session, a.clip.as_deref())?;
    let head = match &a.head {
        Some(h) => h.clone(),
        None => opened.session.head_mesh.clone().ok_or_else(|| {
            anyhow::anyhow!(
                "the session has no head: give one with --head HEAD.obj (or `lipmap import {} --head HEAD.obj`)",
                a.session
            )
        })?,
    };
    let mapping = match &a.mapping {
        Some(m) => Some(m.clone()),
        None => {
            // Written beside the session when it is saved, else with the output.
            let dir = if opened.is_locked() {
                opened.session.base_dir().to_path_buf()
            } else {
                a.out.clone()
            };
            workflow::transfer::session_head_mapping(&mut opened.session, &head, &dir)?
        }
    };
    let request = workflow::transfer::TransferRequest {
        head,
        mapping,
        mode: a.mode.into(),
        clips,
        out_dir: a.out.clone(),
        objs: a.objs,
        accept_map_warnings: a.accept_map_warnings,
    };
    let bar = frames_bar(0, "fitting");
    let report =
        workflow::transfer::transfer_session(&mut opened.session, &res, &request, &show_on(&bar))?;
    print_warnings(&report.warnings);
    opened.save_if_locked()?;
    // Head units mean nothing alone: the head's eye distance is the yardstick.
    let of_eyes = |r: f64| {
        report
            .eye_distance
            .map_or(String::new(), |d| format!(", {:.0} % of its eye distance", 100.0 * r / d))
    };
    writeln!(
        out,
        "{PLACEMENT_RESIDUAL} {:.4} head units{} ({:.4} after a similarity transform alone); \
         {} control points, {} {TRIANGLES_DROPPED} (spanning the lip gap, or slivers)",
        report.residual,
        of_eyes(report.residual),
        report.residual_rigid,
        report.controls,
        report.triangles_dropped
    )?;
    writeln!(
        out,
        "setup {:.2} s, {:.2} ms per frame",
        report.setup.as_secs_f64(),
        1e3 * report.per_frame.as_secs_f64()
    )?;
    for (clip, frames, dir) in &report.clips {
        let file = dir.join("shapes.npy");
        let (clip, file) =
            (terminal_safe(clip), terminal_safe(&file.to_string_lossy()).into_owned());
        writeln!(out, "{clip}: {frames} frames -> {file}")?;
    }
    if opened.is_locked() {
        writeln!(out, "recorded head `{}` in {}", report.head_name, opened.path.display())?;
    } else {
        writeln!(
            out,
            "head `{}` not recorded: {} was read without saving",
            report.head_name,
            opened.path.display()
        )?;
    }
    writeln!(
        out,
        "(the terms: `lipmap help placement residual`, `lipmap help {TRIANGLES_DROPPED}`)"
    )?;
    Ok(())
}
