//! `lipmap validate FILE...`: parse any file lipmap reads (landmarks, alignments, meshes,
//! models, landmark maps, blendshape targets, sessions) and print `ok` or the one-line error.

use crate::cli::convert::is_alignment_path;
use crate::io::{
    alignment_format, landmark_format, landmark_map_toml, makehuman_target, model_source, obj,
};
use crate::session::Session;
use anyhow::Result;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Check files of any supported kind; exit code 2 when any is bad.
#[derive(clap::Args, Debug)]
pub struct ValidateArgs {
    /// Files (or folders of .pts / pose OBJs / .npy model parts) to check.
    #[arg(required = true)]
    pub files: Vec<PathBuf>,
}

/// What kind of file a path holds, judged by name and, for ambiguous names, content.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileKind {
    Session,
    Landmarks,
    Alignment,
    Mesh,
    Model,
    LandmarkMap,
    Target,
}

/// Guesses the kind of `path`.
pub fn classify(path: &Path) -> FileKind {
    let name =
        path.file_name().map(|n| n.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    if name.ends_with(".lipmap.json") {
        return FileKind::Session;
    }
    if makehuman_target::is_target_file(path) {
        return FileKind::Target;
    }
    if is_alignment_path(path) {
        return FileKind::Alignment;
    }
    match ext.as_deref() {
        Some("obj") => FileKind::Mesh,
        Some("bin" | "npz" | "npy" | "lipmodel") => FileKind::Model,
        Some("toml") => FileKind::LandmarkMap,
        Some("txt") => {
            let head = std::fs::read(path)
                .map(|b| String::from_utf8_lossy(&b[..b.len().min(4096)]).into_owned());
            if head.is_ok_and(|t| t.contains("[landmark_mappings]")) {
                FileKind::LandmarkMap
            } else {
                FileKind::Alignment
            }
        }
        _ if path.is_dir() => {
            let has = |e: &str| {
                std::fs::read_dir(path)
                    .into_iter()
                    .flatten()
                    .flatten()
                    .any(|d| d.path().extension().is_some_and(|x| x.eq_ignore_ascii_case(e)))
            };
            if has("pts") { FileKind::Landmarks } else { FileKind::Model }
        }
        _ => FileKind::Landmarks,
    }
}

/// Parses `path` as its kind; `Ok` carries a short description of what was found.
pub fn validate_file(path: &Path) -> Result<String> {
    Ok(match classify(path) {
        FileKind::Session => {
            let s = Session::load(path)?;
            format!("session, {} clip(s)", s.clips.len())
        }
        FileKind::Landmarks => {
            let t = landmark_format::read_track(path)?;
            format!("landmarks, {} frame(s)", t.len())
        }
        FileKind::Alignment => {
            let a = alignment_format::read_alignment(path, None)?;
            format!("alignment, {} phone(s)", a.phones.len())
        }
        FileKind::Mesh => {
            let m = obj::read_obj(path)?;
            format!("mesh, {} vertices, {} faces", m.vertices.len(), m.faces.len())
        }
        FileKind::Model => {
            let m = model_source::load_model(path, None)?;
            format!(
                "model, {} vertices, {} shape components, {} expressions",
                m.num_vertices(),
                m.num_shape_components(),
                m.num_expressions()
            )
        }
        FileKind::LandmarkMap => {
            let m = landmark_map_toml::read_landmark_map(path)?;
            format!("landmark map, {} landmarks mapped", m.len())
        }
        FileKind::Target => {
            let t = makehuman_target::read_target(path)?;
            format!("blendshape target, {} vertex offsets", t.len())
        }
    })
}

/// Validates every file, printing `PATH: ok (...)` or the error; returns the number of bad files.
pub fn run(args: &ValidateArgs, out: &mut dyn Write) -> Result<usize> {
    let mut bad = 0;
    for path in &args.files {
        match validate_file(path) {
            Ok(what) => writeln!(out, "{}: ok ({what})", path.display())?,
            Err(e) => {
                bad += 1;
                let msg = format!("{e:#}");
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
