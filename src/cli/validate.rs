//! `lipmap validate FILE...`: parse any file lipmap reads (landmarks, alignments, meshes,
//! models, landmark maps, blendshape targets, sessions, videos and frame folders, WAVs, speech
//! and quality models, synthesized motion) and print
//! `ok` or the one-line error.

use crate::cli::convert::is_alignment_path;
use crate::cli::output::plural;
use crate::io::frames::{FrameOptions, FrameSource, IMAGE_EXTENSIONS};
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
    /// A video file (decoded with ffmpeg).
    Video,
    /// A folder of frame images.
    Frames,
    /// A WAV recording.
    Audio,
    /// A `speech train` model (JSON).
    SpeechModel,
    /// A `saqp train` quality model (JSON).
    QualityModel,
    /// Synthesized motion for `saqp --synth-files` (`frame,vertex,x,y,z`).
    Motion,
}

/// File extensions taken for videos (decoded with ffmpeg; anything ffmpeg reads works with
/// `--frames`, these are the names recognised without being told).
pub const VIDEO_EXTENSIONS: [&str; 11] =
    ["mp4", "m4v", "mov", "avi", "mkv", "webm", "mpg", "mpeg", "wmv", "flv", "y4m"];

/// Guesses the kind of `path`.
pub fn classify(path: &Path) -> FileKind {
    let name =
        path.file_name().map(|n| n.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    if name.ends_with(".lipmap.json") {
        return FileKind::Session;
    }
    // A lipmap model file is known by its magic, whatever its name.
    if crate::io::model_file::is_model_file(path) {
        return FileKind::Model;
    }
    if makehuman_target::is_target_file(path) {
        return FileKind::Target;
    }
    if is_alignment_path(path) {
        return FileKind::Alignment;
    }
    // JSON and CSV files are told apart by what they start with; a model names its format.
    let format_is = |format: &str| head_of(path).contains(&format!("\"{format}\""));
    match ext.as_deref() {
        Some("wav") => FileKind::Audio,
        Some("json") => {
            if format_is(crate::workflow::speech::SPEECH_MODEL_FORMAT) {
                FileKind::SpeechModel
            } else if format_is(crate::workflow::saqp::SAQP_MODEL_FORMAT) {
                FileKind::QualityModel
            } else {
                FileKind::Landmarks
            }
        }
        Some("csv")
            if head_of(path)
                .lines()
                .next()
                .is_some_and(|h| h.split(',').any(|c| c.trim() == "vertex")) =>
        {
            FileKind::Motion
        }
        Some(e) if VIDEO_EXTENSIONS.contains(&e) && !path.is_dir() => FileKind::Video,
        Some("obj") => FileKind::Mesh,
        Some("bin" | "npz" | "npy" | "lipmodel") => FileKind::Model,
        Some("toml") => FileKind::LandmarkMap,
        Some("txt") => {
            if head_of(path).contains("[landmark_mappings]") {
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
            if has("pts") {
                FileKind::Landmarks
            } else if IMAGE_EXTENSIONS.iter().any(|e| has(e)) && !has("obj") && !has("npy") {
                FileKind::Frames
            } else {
                FileKind::Model
            }
        }
        _ => FileKind::Landmarks,
    }
}

/// The first 4 KB of `path` as text (empty when unreadable: the parser then says why).
fn head_of(path: &Path) -> String {
    use std::io::Read;
    let mut bytes = Vec::new();
    if let Ok(f) = crate::io::input::open_input(path, crate::io::input::MAX_INPUT_BYTES) {
        let _ = f.take(4096).read_to_end(&mut bytes);
    }
    String::from_utf8_lossy(&bytes).into_owned()
}

/// Parses `path` as its kind; `Ok` carries a short description of what was found.
pub fn validate_file(path: &Path) -> Result<String> {
    Ok(match classify(path) {
        FileKind::Session => {
            let s = Session::load(path)?;
            let map = match crate::workflow::map::check_session_map(&s) {
                Ok(Some(check)) => format!("; {}", check.summary()),
                Ok(None) => String::new(),
                Err(e) => format!("; map not checked: {e}"),
            };
            format!("session, {}{map}", plural(s.clips.len(), "clip"))
        }
        FileKind::Landmarks => {
            let t = landmark_format::read_track(path)?;
            format!("landmarks, {}", plural(t.len(), "frame"))
        }
        FileKind::Alignment => {
            let a = alignment_format::read_alignment(path, None)?;
            format!("alignment, {}", plural(a.phones.len(), "phone"))
        }
        FileKind::Mesh => {
            let m = obj::read_obj(path)?;
            if m.faces.is_empty() {
                anyhow::bail!("{}: a mesh with no faces", path.display());
            }
            format!(
                "mesh, {}, {}",
                plural_vertices(m.vertices.len()),
                plural(m.faces.len(), "face")
            )
        }
        FileKind::Model => {
            let m = match model_source::load_model(path, None) {
                Ok(m) => m,
                // Blendshapes share the model files' names (.bin, .npy, folders).
                Err(e) => return validate_blendshapes(path).ok_or(e)?,
            };
            format!(
                "model, {}, {}, {}",
                plural_vertices(m.num_vertices()),
                plural(m.num_shape_components(), "shape component"),
                plural(m.num_expressions(), "expression")
            )
        }
        FileKind::LandmarkMap => {
            let m = landmark_map_toml::read_landmark_map(path)?;
            format!("landmark map, {} mapped", plural(m.len(), "landmark"))
        }
        FileKind::Target => {
            let t = makehuman_target::read_target(path)?;
            format!("blendshape target, {}", plural(t.len(), "vertex offset"))
        }
        FileKind::Audio => {
            let a = crate::io::wav::check_wav(path)?;
            format!("audio, {:.2} s at {} Hz", a.seconds(), a.sample_rate)
        }
        FileKind::SpeechModel => {
            let m = crate::workflow::speech::load_speech_model(path)?;
            format!(
                "speech model, {} at {} fps, driving {}",
                plural(m.speech.hmm.n_states(), "state"),
                m.speech.features.mfcc.frame_rate,
                m.head.model.display()
            )
        }
        FileKind::QualityModel => {
            let m = crate::workflow::saqp::load_predictor(path)?;
            format!(
                "quality model, trained on {} from {}",
                plural(m.sentences, "sentence"),
                plural(m.sessions.len(), "session")
            )
        }
        FileKind::Motion => {
            let m = crate::io::motion_csv::read_motion_csv(path)?;
            format!(
                "synthesized motion, {} of {}",
                plural(m.frames.len(), "frame"),
                plural_vertices(m.vertices.len())
            )
        }
        FileKind::Video | FileKind::Frames => {
            let f = FrameSource::open(path, &FrameOptions::default())?;
            let [w, h] = f.size();
            let what = if f.path().is_dir() { "image folder" } else { "video" };
            // 29.97002997… prints as 29.97, 25.0 as 25.
            let rate = format!("{:.2}", f.fps());
            let rate = rate.trim_end_matches('0').trim_end_matches('.');
            let fps = if f.path().is_dir() {
                format!("{rate} fps assumed (give --fps to `lipmap new`)")
            } else {
                format!("{rate} fps")
            };
            format!("{what}, {} at {fps}, {w}x{h}", plural(f.len(), "frame"))
        }
    })
}

/// Checks `path` as expression blendshapes (an eos `.bin`, or a folder of MakeHuman
/// targets); `None` when it is neither, so the model error stands.
fn validate_blendshapes(path: &Path) -> Option<Result<String>> {
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    if path.is_file() && ext.as_deref() == Some("bin") {
        let parsed = crate::io::eos_bin::read_eos_blendshapes(path);
        // Neither a model nor blendshapes: the model's error is the one to show.
        let e = parsed.ok()?;
        let described = format!(
            "blendshapes, {}, {}",
            plural(e.deltas.ncols(), "expression"),
            plural_vertices(e.deltas.nrows() / 3)
        );
        return Some(Ok(described));
    }
    if !path.is_dir() {
        return None;
    }
    let mut targets: Vec<PathBuf> = std::fs::read_dir(path)
        .ok()?
        .flatten()
        .map(|d| d.path())
        .filter(|p| makehuman_target::is_target_file(p))
        .collect();
    if targets.is_empty() {
        return None;
    }
    targets.sort();
    let checked = targets.iter().try_for_each(|t| makehuman_target::read_target(t).map(drop));
    Some(
        checked
            .map(|()| format!("blendshape folder, {}", plural(targets.len(), "target")))
            .map_err(Into::into),
    )
}

fn plural_vertices(n: usize) -> String {
    if n == 1 { "1 vertex".into() } else { format!("{n} vertices") }
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
