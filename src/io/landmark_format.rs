//! Landmark file formats as one choice: detect a file's format from its extension and first
//! line, and read or write a `Track` in any of them. Start at `read_track` / `write_track`.
//!
//! Detection rules: a directory is a `.pts` folder; `.pts` is one iBUG frame; `.xml` is dlib
//! imglab; `.csv` is lipmap CSV when its header starts with `frame,point` (after trimming),
//! eos's CSV when it starts with `frame,ibug_id`, and OpenFace when it has an `x_0` or
//! `frame`/`timestamp`/`success` column. Other
//! extensions are sniffed from the content the same way (`version:`/`n_points:`/`{` = pts,
//! `<` = XML).

use super::error::{FormatError, Result};
use super::{dlib_xml, eos_csv, openface, pts, track_csv};
use crate::landmarks::track::Track;
use std::fmt;
use std::path::Path;
use std::str::FromStr;

/// A landmark file format lipmap reads and writes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum LandmarkFormat {
    /// One iBUG `.pts` file: a single frame.
    Pts,
    /// A folder of `.pts` files, one per frame, natural name order.
    PtsFolder,
    /// OpenFace 2.x CSV.
    OpenFace,
    /// dlib imglab XML.
    DlibXml,
    /// lipmap CSV (`frame,point,x,y,visible,confidence,source`), lossless.
    LipmapCsv,
    /// eos's CSV (`frame,ibug_id,u,v`, 1-based ids): visible points only.
    EosCsv,
}

impl LandmarkFormat {
    pub const ALL: [LandmarkFormat; 6] =
        [Self::Pts, Self::PtsFolder, Self::OpenFace, Self::DlibXml, Self::LipmapCsv, Self::EosCsv];

    /// The short name used on the command line (`pts`, `pts-dir`, `openface`, `dlib`, `csv`,
    /// `eos-csv`).
    pub fn name(self) -> &'static str {
        match self {
            Self::Pts => "pts",
            Self::PtsFolder => "pts-dir",
            Self::OpenFace => "openface",
            Self::DlibXml => "dlib",
            Self::LipmapCsv => "csv",
            Self::EosCsv => "eos-csv",
        }
    }

    /// The format a path is to be written in, judged from its name alone (the file may not
    /// exist yet): `.pts` = Pts, `.xml` = DlibXml, `.csv` = LipmapCsv (OpenFace must be
    /// asked for by name), no extension = PtsFolder.
    pub fn for_output(path: &Path) -> Option<Self> {
        match path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase()) {
            None => Some(Self::PtsFolder),
            Some(e) if e == "pts" => Some(Self::Pts),
            Some(e) if e == "xml" => Some(Self::DlibXml),
            Some(e) if e == "csv" => Some(Self::LipmapCsv),
            Some(_) => None,
        }
    }
}

impl fmt::Display for LandmarkFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for LandmarkFormat {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "pts" => Ok(Self::Pts),
            "pts-dir" | "pts-folder" | "ptsdir" => Ok(Self::PtsFolder),
            "openface" => Ok(Self::OpenFace),
            "dlib" | "xml" | "dlib-xml" => Ok(Self::DlibXml),
            "csv" | "lipmap" | "lipmap-csv" => Ok(Self::LipmapCsv),
            "eos-csv" | "eos" => Ok(Self::EosCsv),
            _ => Err(format!(
                "unknown landmark format `{s}` (pts, pts-dir, openface, dlib, csv, eos-csv)"
            )),
        }
    }
}

/// The format of landmark text judged from its content alone, if recognisable.
pub fn detect_text(text: &str) -> Option<LandmarkFormat> {
    let text = crate::io::input::without_bom(text);
    let first = text.lines().map(str::trim).find(|l| !l.is_empty())?;
    if first.starts_with('<') {
        return Some(LandmarkFormat::DlibXml);
    }
    if first.starts_with("version:") || first.starts_with("n_points:") || first == "{" {
        return Some(LandmarkFormat::Pts);
    }
    let cols: Vec<&str> = first.split(',').map(str::trim).collect();
    if cols.len() >= 4 && cols[..2] == ["frame", "point"] {
        return Some(LandmarkFormat::LipmapCsv);
    }
    if eos_csv::is_eos_header(first) {
        return Some(LandmarkFormat::EosCsv);
    }
    if cols.iter().any(|c| matches!(*c, "x_0" | "frame" | "timestamp" | "success" | "face_id")) {
        return Some(LandmarkFormat::OpenFace);
    }
    None
}

/// The format of an existing landmark file or folder, by extension and first line.
///
/// # Errors
/// When the path cannot be read or its format is not recognised.
pub fn detect(path: &Path) -> Result<LandmarkFormat> {
    let meta = std::fs::metadata(path).map_err(|e| FormatError::io(path, e))?;
    if meta.is_dir() {
        return Ok(LandmarkFormat::PtsFolder);
    }
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    match ext.as_deref() {
        Some("pts") => return Ok(LandmarkFormat::Pts),
        Some("xml") => return Ok(LandmarkFormat::DlibXml),
        _ => {}
    }
    let bytes = super::input::read_input(path)?;
    let head = String::from_utf8_lossy(&bytes[..bytes.len().min(64 * 1024)]);
    detect_text(&head).ok_or_else(|| {
        FormatError::at_line(
            path,
            1,
            "not a landmark file lipmap knows (.pts, OpenFace CSV, dlib XML, lipmap CSV, eos CSV)",
        )
    })
}

/// Parses landmark text of a known format (not `PtsFolder`, which is many files).
///
/// # Errors
/// Whatever the format's parser rejects, naming `path` and the line.
pub fn parse_track(text: &str, path: &Path, format: LandmarkFormat) -> Result<Track> {
    let track = match format {
        LandmarkFormat::Pts => Ok(Track::new(vec![crate::landmarks::track::FrameLandmarks::new(
            0,
            pts::parse_pts(text, path)?,
        )])),
        LandmarkFormat::PtsFolder => {
            Err(FormatError::whole(path, "a .pts folder cannot be parsed from one text"))
        }
        LandmarkFormat::OpenFace => openface::parse_openface_csv(text, path),
        LandmarkFormat::DlibXml => dlib_xml::parse_dlib_xml(text, path),
        LandmarkFormat::LipmapCsv => track_csv::parse_track_csv(text, path),
        LandmarkFormat::EosCsv => eos_csv::parse_eos_csv(text, path),
    }?;
    check_track_bounds(track, path)
}

/// Refuses a track whose frame numbers exceed [`MAX_FRAME`](crate::landmarks::MAX_FRAME)
/// or whose coordinates lie beyond [`MAX_COORDINATE_PX`](crate::landmarks::MAX_COORDINATE_PX):
/// such values are typos or a corrupt file; per-frame tables sized by the first would exhaust
/// memory later, sums of the second overflow.
///
/// # Errors
/// The first value past a bound, naming `path`.
pub fn check_track_bounds(track: Track, path: &Path) -> Result<Track> {
    use crate::landmarks::{MAX_FRAME, point_out_of_bounds};
    if let Some(f) = track.frames.iter().find(|f| f.frame > MAX_FRAME) {
        return Err(FormatError::at_field(
            path,
            "frame",
            format!("frame {} is past the largest frame lipmap accepts ({MAX_FRAME})", f.frame),
        ));
    }
    for f in &track.frames {
        if let Some(why) = point_out_of_bounds(f) {
            return Err(FormatError::at_field(path, format!("frame {}", f.frame), why));
        }
    }
    Ok(track)
}

/// Reads landmarks from a file or `.pts` folder, detecting the format.
///
/// # Errors
/// Unreadable or unrecognised files, and any parse error (naming file and line).
///
/// # Examples
/// ```no_run
/// let track = lipmap::io::landmark_format::read_track("clip/landmarks.csv".as_ref()).unwrap();
/// println!("{} frames", track.len());
/// ```
pub fn read_track(path: &Path) -> Result<Track> {
    match detect(path)? {
        LandmarkFormat::PtsFolder => check_track_bounds(pts::read_pts_folder(path)?, path),
        format => {
            let text = super::input::read_input_string(path)?;
            parse_track(&text, path, format)
        }
    }
}

/// Writes a track in `format`. `Pts` needs a track of exactly one frame; `PtsFolder`
/// creates the folder and writes `frame_NNNNNN.pts` files.
///
/// # Errors
/// I/O failures, or a multi-frame track asked for as a single `.pts`.
pub fn write_track(track: &Track, path: &Path, format: LandmarkFormat) -> Result<()> {
    match format {
        LandmarkFormat::Pts => match track.frames.as_slice() {
            [one] => pts::write_pts(one, path),
            frames => Err(FormatError::whole(
                path,
                format!(
                    "a .pts file holds one frame but the track has {}; write to a folder",
                    frames.len()
                ),
            )),
        },
        LandmarkFormat::PtsFolder => pts::write_pts_folder(track, path),
        LandmarkFormat::OpenFace => openface::write_openface_csv(track, path),
        LandmarkFormat::DlibXml => dlib_xml::write_dlib_xml(track, path),
        LandmarkFormat::LipmapCsv => track_csv::write_track_csv(track, path),
        LandmarkFormat::EosCsv => eos_csv::write_eos_csv(track, path),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn detects_by_content() {
        assert_eq!(detect_text("frame,point,x,y\n"), Some(LandmarkFormat::LipmapCsv));
        assert_eq!(detect_text("frame, face_id, timestamp, x_0\n"), Some(LandmarkFormat::OpenFace));
        assert_eq!(detect_text("\u{feff}version: 1\n"), Some(LandmarkFormat::Pts));
        assert_eq!(detect_text("<?xml version='1.0'?>"), Some(LandmarkFormat::DlibXml));
        assert_eq!(detect_text("start,end,phone\n"), None);
        let eos = "frame,ibug_id,u,v,u_clean,v_clean\n";
        assert_eq!(detect_text(eos), Some(LandmarkFormat::EosCsv));
    }

    #[test]
    fn names_parse_back() {
        for f in LandmarkFormat::ALL {
            assert_eq!(f.name().parse::<LandmarkFormat>(), Ok(f));
        }
    }
}
