//! What kind of file a path holds, judged by its name and, where names are ambiguous (`.json`,
//! `.csv`, `.txt`, folders), by the first bytes: the one detection `validate`, `convert` and
//! anything else that takes "any file" use.
//!
//! Start with [`detect_kind`].

use super::frames::IMAGE_EXTENSIONS;
use super::input::{MAX_INPUT_BYTES, open_input};
use super::json_model::{QUALITY_MODEL, SPEECH_MODEL, names_format};
use std::path::Path;

/// What kind of file a path holds.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum FileKind {
    Session,
    Landmarks,
    Alignment,
    Mesh,
    /// A morphable model (or, with the same names, expression blendshapes).
    Model,
    LandmarkMap,
    /// A MakeHuman blendshape target.
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
    /// Per-frame fit results (`fit.csv`: `frame,yaw,pitch,roll,…`).
    FitResults,
    /// The frame numbers of a `shapes.npy` (`frames.csv`: one `frame` column).
    FrameList,
    /// A table lipmap wrote (`export` tables, `--format csv`): any other CSV.
    Table,
    /// One `.npy` array: per-frame shapes (`shapes.npy`) or blendshapes, rows × 3N.
    Array,
    /// One image (a plot, a frame).
    Image,
}

/// File extensions taken for videos (decoded with ffmpeg; anything ffmpeg reads works with
/// `--frames`, these are the names recognised without being told).
pub const VIDEO_EXTENSIONS: [&str; 11] =
    ["mp4", "m4v", "mov", "avi", "mkv", "webm", "mpg", "mpeg", "wmv", "flv", "y4m"];

/// Bytes read to tell apart files whose names do not say enough.
const HEAD_BYTES: u64 = 4096;

/// The kind of file at `path`.
pub fn detect_kind(path: &Path) -> FileKind {
    let name =
        path.file_name().map(|n| n.to_string_lossy().to_ascii_lowercase()).unwrap_or_default();
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    if name.ends_with(".lipmap.json") {
        return FileKind::Session;
    }
    // A lipmap model file is known by its magic, whatever its name.
    if super::model_file::is_model_file(path) {
        return FileKind::Model;
    }
    if super::makehuman_target::is_target_file(path) {
        return FileKind::Target;
    }
    if is_alignment_path(path) {
        return FileKind::Alignment;
    }
    match ext.as_deref() {
        Some("wav") => FileKind::Audio,
        // A model names its format near the top, an eos map its object; other JSON is
        // landmarks.
        Some("json") => {
            let head = head_of(path);
            if names_format(&head, &SPEECH_MODEL) {
                FileKind::SpeechModel
            } else if names_format(&head, &QUALITY_MODEL) {
                FileKind::QualityModel
            } else if head.contains("\"ibug_to_sfm_vertex\"") {
                FileKind::LandmarkMap
            } else {
                FileKind::Landmarks
            }
        }
        Some("csv") => csv_kind(path),
        Some("npy") if path.is_file() => FileKind::Array,
        Some("png" | "jpg" | "jpeg" | "ppm") if path.is_file() => FileKind::Image,
        Some(e) if VIDEO_EXTENSIONS.contains(&e) && !path.is_dir() => FileKind::Video,
        Some("obj") => FileKind::Mesh,
        Some("bin" | "npz" | "npy" | "lipmodel") => FileKind::Model,
        Some("toml") => FileKind::LandmarkMap,
        Some("txt") if head_of(path).contains("[landmark_mappings]") => FileKind::LandmarkMap,
        Some("txt") => FileKind::Alignment,
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

/// What a CSV (not an alignment) holds, by its header: synthesized motion, fit results, a
/// frame list, landmarks in a format lipmap reads, or else a table.
fn csv_kind(path: &Path) -> FileKind {
    let cols = header_columns(path);
    let starts = |names: &[&str]| cols.len() >= names.len() && cols[..names.len()] == *names;
    if cols.iter().any(|c| c == "vertex") {
        FileKind::Motion
    } else if starts(&["frame", "yaw", "pitch", "roll"]) {
        FileKind::FitResults
    } else if cols == ["frame"] {
        FileKind::FrameList
    } else if is_landmark_header(&cols) {
        FileKind::Landmarks
    } else {
        FileKind::Table
    }
}

/// Whether a CSV header is a landmark format's: lipmap's or eos's by their first columns, an
/// OpenFace CSV only with its landmark columns (a table with a `frame` column is no track).
fn is_landmark_header(cols: &[String]) -> bool {
    use super::landmark_format::{LandmarkFormat, detect_text};
    match detect_text(&cols.join(",")) {
        Some(LandmarkFormat::OpenFace) => cols.iter().any(|c| c == "x_0"),
        other => other.is_some(),
    }
}

/// True for files that hold phone alignments rather than landmarks: a TextGrid, an HTK or
/// Festival label file, or a CSV with `start` and `end` columns.
pub fn is_alignment_path(path: &Path) -> bool {
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    match ext.as_deref() {
        Some("textgrid" | "lab" | "rec" | "seg") => true,
        Some("csv") => {
            let cols = header_columns(path);
            cols.iter().any(|c| c == "start") && cols.iter().any(|c| c == "end")
        }
        _ => false,
    }
}

/// The first line of a CSV file split into trimmed column names (a byte-order mark
/// dropped); empty when unreadable.
fn header_columns(path: &Path) -> Vec<String> {
    let head = head_of(path);
    head.lines()
        .next()
        .map(|l| {
            l.split(',').map(|c| c.trim().trim_start_matches('\u{feff}').to_string()).collect()
        })
        .unwrap_or_default()
}

/// The first [`HEAD_BYTES`] of `path` as text (empty when unreadable: the parser then says
/// why).
fn head_of(path: &Path) -> String {
    use std::io::Read;
    let mut bytes = Vec::new();
    if let Ok(f) = open_input(path, MAX_INPUT_BYTES) {
        let _ = f.take(HEAD_BYTES).read_to_end(&mut bytes);
    }
    String::from_utf8_lossy(&bytes).into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_then_contents_tell_the_kind() {
        let dir = tempfile::tempdir().unwrap();
        let file = |name: &str, text: &str| {
            let p = dir.path().join(name);
            std::fs::write(&p, text).unwrap();
            p
        };
        assert_eq!(detect_kind(&file("a.lipmap.json", "{}")), FileKind::Session);
        let speech = file("m.json", r#"{"format": "lipmap speech model", "version": 1}"#);
        assert_eq!(detect_kind(&speech), FileKind::SpeechModel);
        let quality = file("q.json", r#"{"format":"lipmap saqp model"}"#);
        assert_eq!(detect_kind(&quality), FileKind::QualityModel);
        assert_eq!(detect_kind(&file("l.json", "[]")), FileKind::Landmarks);
        assert_eq!(detect_kind(&file("p.csv", "\u{feff}start,end,phone\n")), FileKind::Alignment);
        assert_eq!(detect_kind(&file("m.csv", "frame,vertex,x,y,z\n")), FileKind::Motion);
        assert_eq!(detect_kind(&file("t.csv", "frame,point,x,y\n")), FileKind::Landmarks);
        assert_eq!(detect_kind(&file("e.csv", "frame,ibug_id,u,v\n")), FileKind::Landmarks);
        let fit = file("fit.csv", "frame,yaw,pitch,roll,scale,tx,ty,reproj_rms_px,failed\n");
        assert_eq!(detect_kind(&fit), FileKind::FitResults);
        assert_eq!(detect_kind(&file("frames.csv", "frame\n0\n")), FileKind::FrameList);
        assert_eq!(detect_kind(&file("s.csv", "sentence,RMSE W\n")), FileKind::Table);
        let worst = file("w.csv", "rank,clip,frame,reproj RMS px,failed\n");
        assert_eq!(detect_kind(&worst), FileKind::Table);
        let openface = file("o.csv", "frame, face_id, timestamp, confidence, success, x_0\n");
        assert_eq!(detect_kind(&openface), FileKind::Landmarks);
        assert_eq!(detect_kind(&file("shapes.npy", "")), FileKind::Array);
        assert_eq!(detect_kind(&file("plot.png", "")), FileKind::Image);
        let map = file("lc.json", "{\"ibug_to_sfm_vertex\": {\"31\": 114}}");
        assert_eq!(detect_kind(&map), FileKind::LandmarkMap);
        assert_eq!(detect_kind(&file("map.txt", "[landmark_mappings]\n")), FileKind::LandmarkMap);
        assert_eq!(detect_kind(&file("a.txt", "0 1 sil\n")), FileKind::Alignment);
        assert_eq!(detect_kind(&file("v.MP4", "")), FileKind::Video);
        std::fs::create_dir(dir.path().join("frames")).unwrap();
        std::fs::write(dir.path().join("frames/0001.png"), "").unwrap();
        assert_eq!(detect_kind(&dir.path().join("frames")), FileKind::Frames);
    }
}
