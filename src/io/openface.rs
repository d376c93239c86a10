//! OpenFace 2.x landmark CSV (`FeatureExtraction` / `FaceLandmarkVid` output): read by column
//! name, write the same columns back. Start at `parse_openface_csv`.
//!
//! OpenFace separates fields with `", "`, so fields are trimmed. Every block of columns is
//! optional: `frame` (1-based in OpenFace, 0-based in lipmap: converted both ways; without it
//! the row number is the frame), `face_id` (only face 0 is kept: lipmap tracks one speaker),
//! `timestamp` (s), `confidence`, `success`, and `x_0..x_67` / `y_0..y_67` (0-based image
//! pixels, as OpenCV). Column names are case-sensitive: `X_0` is OpenFace's 3D block, not 2D.
//! A frame with `success = 0` has its points marked not visible (OpenFace writes zeros there).

use super::error::{FormatError, Result};
use super::pts::shorten;
use super::track_csv::{parse_f32_field, parse_f64_field, parse_usize_field, read_csv_table};
use crate::landmarks::ibug::N_LANDMARKS;
use crate::landmarks::track::{FrameLandmarks, LandmarkPoint, Track};
use std::collections::{BTreeSet, HashMap};
use std::fmt::Write as _;
use std::path::Path;

/// Parses OpenFace 2.x CSV text into a track.
///
/// # Errors
/// A half-present coordinate pair of columns, a non-numeric field, a frame number of 0 or
/// repeated, or a bad `success` flag, each naming the line and column.
///
/// # Examples
/// ```
/// # use std::path::Path;
/// let text = "frame, timestamp, confidence, success, x_48, y_48\n1, 0.04, 0.98, 1, 100.5, 200.25\n";
/// let t = lipmap::io::openface::parse_openface_csv(text, Path::new("of.csv")).unwrap();
/// assert_eq!(t.frames[0].frame, 0);
/// assert_eq!(t.frames[0].points[48].x, 100.5);
/// ```
pub fn parse_openface_csv(text: &str, path: &Path) -> Result<Track> {
    let table = read_csv_table(text, path)?;
    let by_name: HashMap<&str, usize> =
        table.header.iter().enumerate().map(|(i, h)| (h.as_str(), i)).collect();
    let mut coord_cols: Vec<Option<(usize, usize)>> = Vec::with_capacity(N_LANDMARKS);
    for i in 0..N_LANDMARKS {
        let (xn, yn) = (format!("x_{i}"), format!("y_{i}"));
        coord_cols.push(
            match (by_name.get(xn.as_str()).copied(), by_name.get(yn.as_str()).copied()) {
                (Some(cx), Some(cy)) => Some((cx, cy)),
                (None, None) => None,
                (Some(_), None) => {
                    return Err(FormatError::at_line(
                        path,
                        1,
                        format!("column `{xn}` has no `{yn}`"),
                    ));
                }
                (None, Some(_)) => {
                    return Err(FormatError::at_line(
                        path,
                        1,
                        format!("column `{yn}` has no `{xn}`"),
                    ));
                }
            },
        );
    }
    let c_frame = table.column("frame");
    let c_face = table.column("face_id");
    let c_time = table.column("timestamp");
    let c_conf = table.column("confidence");
    let c_success = table.column("success");

    let mut seen = BTreeSet::new();
    let mut frames = Vec::with_capacity(table.rows.len());
    for (row_index, (line, rec)) in table.rows.iter().enumerate() {
        let line = *line;
        if let Some(c) = c_face
            && parse_usize_field(rec, c, "face_id", path, line)? != 0
        {
            continue;
        }
        let frame = match c_frame {
            Some(c) => match parse_usize_field(rec, c, "frame", path, line)? {
                0 => {
                    return Err(FormatError::at_line(
                        path,
                        line,
                        "column `frame`: 0, but OpenFace frames start at 1",
                    ));
                }
                n => n - 1,
            },
            None => row_index,
        };
        if !seen.insert(frame) {
            return Err(FormatError::at_line(
                path,
                line,
                format!("column `frame`: frame {} appears twice", frame + 1),
            ));
        }
        let timestamp = match c_time {
            Some(c) if !rec.get(c).unwrap_or("").is_empty() => {
                Some(parse_f64_field(rec, c, "timestamp", path, line)?)
            }
            _ => None,
        };
        let confidence = match c_conf {
            Some(c) if !rec.get(c).unwrap_or("").is_empty() => {
                Some(parse_f32_field(rec, c, "confidence", path, line)?)
            }
            _ => None,
        };
        let success = match c_success.map_or("", |c| rec.get(c).unwrap_or("")) {
            "" | "1" => true,
            "0" => false,
            other => {
                return Err(FormatError::at_line(
                    path,
                    line,
                    format!("column `success`: `{}` is not 0 or 1", shorten(other)),
                ));
            }
        };
        let mut points = Vec::with_capacity(N_LANDMARKS);
        for cols in &coord_cols {
            points.push(match cols {
                Some((cx, cy)) => {
                    let x = parse_f64_field(rec, *cx, &table.header[*cx], path, line)?;
                    let y = parse_f64_field(rec, *cy, &table.header[*cy], path, line)?;
                    LandmarkPoint { visible: success, ..LandmarkPoint::tracked(x, y) }
                }
                None => LandmarkPoint::missing(),
            });
        }
        let mut f = FrameLandmarks::new(frame, points);
        f.timestamp = timestamp;
        f.confidence = confidence;
        f.success = success;
        frames.push(f);
    }
    Ok(Track::new(frames))
}

/// Reads an OpenFace 2.x CSV file.
///
/// # Errors
/// I/O failures and everything `parse_openface_csv` rejects.
pub fn read_openface_csv(path: &Path) -> Result<Track> {
    let text = super::input::read_input_string(path)?;
    parse_openface_csv(&text, path)
}

/// The OpenFace-style CSV text of a track (`frame, face_id, timestamp, confidence, success,
/// x_0.., y_0..`), 1-based frames, shortest round-trip decimals, empty fields for values the
/// track lacks. Per-point visibility, confidence and source are not representable.
pub fn format_openface_csv(track: &Track) -> String {
    let mut s = String::from("frame, face_id, timestamp, confidence, success");
    for axis in ["x", "y"] {
        for i in 0..N_LANDMARKS {
            let _ = write!(s, ", {axis}_{i}");
        }
    }
    s.push('\n');
    for f in &track.frames {
        // u128: a frame number read from elsewhere may be usize::MAX.
        let _ = write!(s, "{}, 0, ", f.frame as u128 + 1);
        if let Some(t) = f.timestamp {
            let _ = write!(s, "{t}");
        }
        s.push_str(", ");
        if let Some(c) = f.confidence {
            let _ = write!(s, "{c}");
        }
        let _ = write!(s, ", {}", u8::from(f.success));
        for p in &f.points {
            let _ = write!(s, ", {}", p.x);
        }
        for p in &f.points {
            let _ = write!(s, ", {}", p.y);
        }
        s.push('\n');
    }
    s
}

/// Writes a track as OpenFace 2.x CSV.
///
/// # Errors
/// I/O failures, naming `path`.
pub fn write_openface_csv(track: &Track, path: &Path) -> Result<()> {
    super::atomic::write_atomic_bytes(path, format_openface_csv(track).as_bytes())
        .map_err(|e| FormatError::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_keeps_frame_fields() {
        let mut f = FrameLandmarks::new(
            4,
            (0..N_LANDMARKS).map(|i| LandmarkPoint::tracked(i as f64 + 0.125, 0.1)).collect(),
        );
        f.timestamp = Some(0.133);
        f.confidence = Some(0.975);
        let mut g = f.clone();
        g.frame = 5;
        g.success = false;
        g.confidence = None;
        g.points.iter_mut().for_each(|p| p.visible = false);
        let track = Track::new(vec![f, g]);
        let text = format_openface_csv(&track);
        assert!(text.starts_with("frame, face_id, timestamp, confidence, success, x_0, x_1"));
        assert!(text.lines().nth(1).unwrap().starts_with("5, 0, 0.133, 0.975, 1, 0.125, 1.125"));
        assert_eq!(parse_openface_csv(&text, Path::new("o.csv")).unwrap(), track);
    }

    #[test]
    fn only_face_zero_and_case_sensitive_columns() {
        let text = "frame,face_id,X_0,x_0,y_0\n1,0,9,1,2\n1,1,9,3,4\n";
        let t = parse_openface_csv(text, Path::new("o.csv")).unwrap();
        assert_eq!(t.len(), 1);
        assert_eq!((t.frames[0].points[0].x, t.frames[0].points[0].y), (1.0, 2.0));
        assert!(!t.frames[0].points[1].visible);
    }
}
