//! Validating a file of any kind lipmap reads (`lipmap validate`): its kind detected
//! (`io::file_kind`), then parsed by that kind's own reader, and what it holds summarised as
//! typed values for the front to word. A session is read as every reader reads it
//! ([`read_session`]): with its journal, whose unsaved edits are counted.
//!
//! Start with [`validate_file`].

use super::error::{Error, Result, Warning};
use super::session::read_session;
use crate::io::file_kind::{FileKind, detect_kind};
use crate::io::frames::{FrameOptions, FrameSource};
use crate::io::track_csv::read_csv_table;
use crate::io::{alignment_format, landmark_format, landmark_map_toml, makehuman_target};
use crate::io::{model_source, obj};
use std::path::{Path, PathBuf};

/// What a valid file holds.
#[derive(Clone, Debug, PartialEq)]
pub enum FileSummary {
    Session {
        clips: usize,
        /// Tracked frames over every clip, each clip's track file read and checked.
        frames: usize,
        /// Cached fits over every clip, each clip's fits file read and checked.
        cached_fits: usize,
        /// The map checked on the head: its one-line summary, or why it was not checked;
        /// `None` without a map.
        map: Option<std::result::Result<String, String>>,
        /// What reading it noticed (edits of its journal applied, a journal not applied).
        notices: Vec<Warning>,
    },
    Landmarks {
        frames: usize,
    },
    Alignment {
        phones: usize,
    },
    Mesh {
        vertices: usize,
        faces: usize,
    },
    Model {
        vertices: usize,
        shape_components: usize,
        expressions: usize,
    },
    /// An eos expression-blendshape file.
    Blendshapes {
        expressions: usize,
        vertices: usize,
    },
    /// A folder of MakeHuman targets.
    BlendshapeFolder {
        targets: usize,
    },
    LandmarkMap {
        landmarks: usize,
    },
    Target {
        offsets: usize,
    },
    Audio {
        seconds: f64,
        sample_rate: u32,
    },
    SpeechModel {
        states: usize,
        frame_rate: f64,
        drives: PathBuf,
    },
    QualityModel {
        sentences: usize,
        sessions: usize,
    },
    Motion {
        frames: usize,
        vertices: usize,
    },
    /// `fit.csv`: frames fitted, and how many of them failed.
    FitResults {
        frames: usize,
        failed: usize,
    },
    /// `frames.csv`: the frame numbers of a `shapes.npy`.
    FrameList {
        frames: usize,
    },
    /// A CSV table: its rows and column names.
    Table {
        rows: usize,
        columns: Vec<String>,
    },
    /// One `.npy` array of `rows` × `columns`.
    Array {
        rows: usize,
        columns: usize,
    },
    /// One image.
    Image {
        size: [u32; 2],
    },
    /// A video (`folder` false) or a folder of images, whose rate is then assumed.
    Frames {
        folder: bool,
        frames: usize,
        fps: f64,
        size: [u32; 2],
    },
}

/// Parses `path` as the kind it is and summarises it.
///
/// # Errors
/// The reader's one-line error (naming the file and line or field); a mesh without faces.
pub fn validate_file(path: &Path) -> Result<FileSummary> {
    Ok(match detect_kind(path) {
        FileKind::Session => validate_session(path)?,
        FileKind::Landmarks => {
            FileSummary::Landmarks { frames: landmark_format::read_track(path)?.len() }
        }
        FileKind::Alignment => FileSummary::Alignment {
            phones: alignment_format::read_alignment(path, None)?.phones.len(),
        },
        FileKind::Mesh => {
            let m = obj::read_obj(path)?;
            if m.faces.is_empty() {
                return Err(Error::Invalid(format!("{}: a mesh with no faces", path.display())));
            }
            FileSummary::Mesh { vertices: m.vertices.len(), faces: m.faces.len() }
        }
        FileKind::Model => match model_source::load_model(path, None) {
            Ok(m) => FileSummary::Model {
                vertices: m.num_vertices(),
                shape_components: m.num_shape_components(),
                expressions: m.num_expressions(),
            },
            // Blendshapes share the model files' names (.bin, .npy, folders).
            Err(e) => blendshapes_summary(path).ok_or(e)??,
        },
        FileKind::LandmarkMap => FileSummary::LandmarkMap {
            landmarks: landmark_map_toml::read_landmark_map(path)?.len(),
        },
        FileKind::Target => {
            FileSummary::Target { offsets: makehuman_target::read_target(path)?.len() }
        }
        FileKind::Audio => {
            // Read through block by block: an hour's samples are never held.
            let a = crate::io::wav::check_wav(path)?;
            FileSummary::Audio { seconds: a.seconds(), sample_rate: a.sample_rate }
        }
        FileKind::SpeechModel => {
            let m = super::speech::load_speech_model(path)?;
            FileSummary::SpeechModel {
                states: m.speech.hmm.n_states(),
                frame_rate: m.speech.features.mfcc.frame_rate,
                drives: m.head.model,
            }
        }
        FileKind::QualityModel => {
            let m = super::saqp::load_predictor(path)?;
            FileSummary::QualityModel { sentences: m.sentences, sessions: m.sessions.len() }
        }
        FileKind::Motion => {
            let m = crate::io::motion_csv::read_motion_csv(path)?;
            FileSummary::Motion { frames: m.frames.len(), vertices: m.vertices.len() }
        }
        FileKind::FitResults => fit_results(path)?,
        FileKind::FrameList => {
            let t = read_csv_table(&crate::io::input::read_input_string(path)?, path)?;
            for (line, rec) in &t.rows {
                crate::io::track_csv::parse_usize_field(rec, 0, "frame", path, *line)?;
            }
            FileSummary::FrameList { frames: t.rows.len() }
        }
        FileKind::Table => {
            let t = read_csv_table(&crate::io::input::read_input_string(path)?, path)?;
            FileSummary::Table { rows: t.rows.len(), columns: t.header }
        }
        FileKind::Array => {
            let a = crate::io::npy_model::read_npy(path)?;
            match a.shape.as_slice() {
                [rows, columns] => FileSummary::Array { rows: *rows, columns: *columns },
                [n] => FileSummary::Array { rows: 1, columns: *n },
                dims => {
                    return Err(Error::Invalid(format!(
                        "{}: an array of {} dimensions; lipmap's arrays have 1 or 2",
                        path.display(),
                        dims.len()
                    )));
                }
            }
        }
        FileKind::Image => {
            let size = image::image_dimensions(path)
                .map_err(|e| Error::Invalid(format!("{}: {e}", path.display())))?;
            FileSummary::Image { size: [size.0, size.1] }
        }
        FileKind::Video | FileKind::Frames => {
            let f = FrameSource::open(path, &FrameOptions::default())?;
            let folder = f.path().is_dir();
            FileSummary::Frames { folder, frames: f.len(), fps: f.fps(), size: f.size() }
        }
    })
}

/// `fit.csv` as `fit` writes it: every row a whole frame number and either the fitted
/// numbers or the reason the frame failed.
fn fit_results(path: &Path) -> Result<FileSummary> {
    use crate::io::track_csv::{parse_f64_field, parse_usize_field};
    let t = read_csv_table(&crate::io::input::read_input_string(path)?, path)?;
    let (Some(rms), Some(failed)) = (t.column("reproj_rms_px"), t.column("failed")) else {
        return Err(Error::Invalid(format!(
            "{}: fit results need the columns `reproj_rms_px` and `failed`",
            path.display()
        )));
    };
    let mut n_failed = 0;
    for (line, rec) in &t.rows {
        parse_usize_field(rec, 0, "frame", path, *line)?;
        if rec.get(failed).is_some_and(|f| !f.is_empty()) {
            n_failed += 1;
        } else {
            parse_f64_field(rec, rms, "reproj_rms_px", path, *line)?;
        }
    }
    Ok(FileSummary::FitResults { frames: t.rows.len(), failed: n_failed })
}

/// A session read as every reader reads it, then every file it refers to: each clip's data
/// files read and checked one clip at a time (memory bounded by the largest clip), the
/// files its use cases need (model, blendshapes, head, maps, audio, speech model,
/// transferred heads) present, and the model's map checked. Files kept only as a record of
/// where data came from (landmark and alignment files) and frames (a session made without
/// frames still fits and evaluates) are noted when missing.
///
/// # Errors
/// The session's or a data file's one-line error; a needed file missing, naming the field.
fn validate_session(path: &Path) -> Result<FileSummary> {
    let read = read_session(path)?;
    let s = &read.session;
    let mut notices = read.notices.clone();
    let (mut frames, mut cached_fits) = (0, 0);
    for c in &s.clips {
        let (f, fits) = c.check_data()?;
        frames += f;
        cached_fits += fits;
    }
    let missing = |what: &str, file: &Path| -> Result<()> {
        match std::fs::metadata(file) {
            Ok(_) => Ok(()),
            Err(e) => {
                Err(Error::Invalid(format!("{}: {what}: {}: {e}", path.display(), file.display())))
            }
        }
    };
    if let Some(m) = &s.model {
        missing("model", &m.path)?;
        if let Some(b) = &m.blendshapes {
            missing("model blendshapes", b)?;
        }
    }
    if let Some(h) = &s.head_mesh {
        missing("head_mesh", h)?;
    }
    for (what, map) in [("landmark_map", Some(&s.landmark_map)), ("head_map", s.head_map.as_ref())]
    {
        if let Some(file) = map.and_then(|m| m.file.as_ref()) {
            missing(what, file)?;
        }
    }
    if let Some(m) = &s.speech_model {
        missing("speech_model", m)?;
    }
    for h in &s.transferred_heads {
        missing(&format!("transferred head `{}` mesh", h.name), &h.mesh)?;
        missing(&format!("transferred head `{}` mapping", h.name), &h.mapping)?;
    }
    for c in &s.clips {
        if let Some(a) = &c.audio {
            missing(&format!("clip {:?}: audio", c.name), &a.file)?;
            crate::io::wav::WavStream::open(&a.file)?;
        }
        let records = [
            ("frames", Some(c.front.source.path())),
            ("side frames", c.side.as_ref().map(|v| v.source.path())),
            ("landmarks_file", c.landmarks_file.as_deref()),
            ("alignment_file", c.alignment_file.as_deref()),
        ];
        for (what, file) in records {
            if let Some(file) = file.filter(|f| !f.exists()) {
                notices.push(Warning(format!(
                    "lipmap: note: clip {:?}: {what} {} not found",
                    c.name,
                    file.display()
                )));
            }
        }
    }
    let map = super::map::check_session_map(s, crate::session::MapRole::Model)
        .map(|c| c.map(|c| c.summary()))
        .map_err(|e| e.to_string())
        .transpose();
    Ok(FileSummary::Session { clips: s.clips.len(), frames, cached_fits, map, notices })
}

/// `path` read as expression blendshapes (an eos `.bin`, or a folder of MakeHuman targets);
/// `None` when it is neither, so the model's error stands.
fn blendshapes_summary(path: &Path) -> Option<Result<FileSummary>> {
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    if path.is_file() && ext.as_deref() == Some("bin") {
        // Neither a model nor blendshapes: the model's error is the one to show.
        let e = crate::io::eos_bin::read_eos_blendshapes(path).ok()?;
        let (expressions, vertices) = (e.deltas.ncols(), e.deltas.nrows() / 3);
        return Some(Ok(FileSummary::Blendshapes { expressions, vertices }));
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
            .map(|()| FileSummary::BlendshapeFolder { targets: targets.len() })
            .map_err(Error::from),
    )
}
