//! eos's landmark CSV (`frame,ibug_id,u,v`), the layout of the eos peer's test set
//! (`reference/landmarks.csv`): one row per visible point, frames 0-based, **iBUG ids
//! 1-based** (1–68, as in eos's map files), `u`, `v` image pixels. The test set's extra
//! `u_clean,v_clean` columns (the points before noise) are accepted and not read; any other
//! column is refused, as in lipmap's own CSV. Points a frame does not list are not visible.
//!
//! Start at [`parse_eos_csv`].

use super::error::{FormatError, Result};
use super::pts::shorten;
use super::track_csv::{CsvRows, parse_f64_field, parse_usize_field};
use crate::landmarks::ibug::N_LANDMARKS;
use crate::landmarks::track::{FrameLandmarks, LandmarkPoint, Track};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// The columns every eos landmark CSV has, in the order eos writes them.
pub const EOS_CSV_HEADER: &str = "frame,ibug_id,u,v";

/// Columns read and columns accepted without being read.
const KNOWN_COLUMNS: [&str; 6] = ["frame", "ibug_id", "u", "v", "u_clean", "v_clean"];

/// Whether a CSV header line is eos's (its first two columns `frame,ibug_id`).
pub fn is_eos_header(first_line: &str) -> bool {
    let mut cols = first_line.split(',').map(str::trim);
    cols.next() == Some("frame") && cols.next() == Some("ibug_id")
}

/// Parses eos landmark CSV text into a track (frames ascending, ids converted to 0-based).
///
/// # Errors
/// A missing or unknown column, a bad number, an id outside 1–68 or a point given twice,
/// each naming the line.
///
/// # Examples
/// ```
/// # use std::path::Path;
/// let t = lipmap::io::eos_csv::parse_eos_csv("frame,ibug_id,u,v\n0,63,10.5,20\n", Path::new("e.csv")).unwrap();
/// assert!(t.frames[0].points[62].visible && !t.frames[0].points[0].visible);
/// ```
pub fn parse_eos_csv(text: &str, path: &Path) -> Result<Track> {
    let mut table = CsvRows::new(text, path)?;
    if let Some(h) = table.header.iter().find(|h| !KNOWN_COLUMNS.contains(&h.as_str())) {
        return Err(FormatError::at_line(
            path,
            1,
            format!(
                "unknown column `{}` (expected {EOS_CSV_HEADER}[,u_clean,v_clean])",
                shorten(h)
            ),
        ));
    }
    let need = |name: &str| {
        table.column(name).ok_or_else(|| {
            FormatError::at_line(
                path,
                1,
                format!("missing column `{name}` (expected {EOS_CSV_HEADER})"),
            )
        })
    };
    let (c_frame, c_id, c_u, c_v) = (need("frame")?, need("ibug_id")?, need("u")?, need("v")?);
    let mut frames: BTreeMap<usize, Vec<LandmarkPoint>> = BTreeMap::new();
    while let Some((line, record)) = table.next_row()? {
        let frame = parse_usize_field(&record, c_frame, "frame", path, line)?;
        let id = parse_usize_field(&record, c_id, "ibug_id", path, line)?;
        if !(1..=N_LANDMARKS).contains(&id) {
            return Err(FormatError::at_line(
                path,
                line,
                format!("column `ibug_id`: {id} is not an iBUG id (1–{N_LANDMARKS})"),
            ));
        }
        let u = parse_f64_field(&record, c_u, "u", path, line)?;
        let v = parse_f64_field(&record, c_v, "v", path, line)?;
        let points =
            frames.entry(frame).or_insert_with(|| vec![LandmarkPoint::missing(); N_LANDMARKS]);
        if points[id - 1].visible {
            return Err(FormatError::at_line(
                path,
                line,
                format!("iBUG id {id} of frame {frame} is given twice"),
            ));
        }
        points[id - 1] = LandmarkPoint::tracked(u, v);
    }
    Ok(Track::new(frames.into_iter().map(|(f, pts)| FrameLandmarks::new(f, pts)).collect()))
}

/// The eos CSV text of a track: the visible points of every frame, 1-based ids, shortest
/// round-trip decimals. Visibility alone survives: eos's layout has no confidence or source.
pub fn format_eos_csv(track: &Track) -> String {
    let mut s = format!("{EOS_CSV_HEADER}\n");
    for f in &track.frames {
        for (i, p) in f.points.iter().enumerate().filter(|(_, p)| p.visible) {
            let _ = writeln!(s, "{},{},{},{}", f.frame, i + 1, p.x, p.y);
        }
    }
    s
}

/// Writes a track as eos CSV.
///
/// # Errors
/// I/O failures, naming `path`.
pub fn write_eos_csv(track: &Track, path: &Path) -> Result<()> {
    super::atomic::write_atomic_bytes(path, format_eos_csv(track).as_bytes())
        .map_err(|e| FormatError::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ids_are_one_based_and_the_clean_columns_are_not_read() {
        let text = "frame,ibug_id,u,v,u_clean,v_clean\n0,1,500.2,188.5,500.7,188.2\n\
                    0,68,10,20,11,21\n3,31,1,2,x,y\n";
        let t = parse_eos_csv(text, Path::new("e.csv")).unwrap();
        assert_eq!(t.frames.iter().map(|f| f.frame).collect::<Vec<_>>(), [0, 3]);
        let p = &t.frames[0].points;
        assert_eq!((p[0].x, p[0].y), (500.2, 188.5));
        assert_eq!((p[67].x, p[67].y), (10.0, 20.0));
        assert_eq!(p.iter().filter(|p| p.visible).count(), 2);
        assert!(t.frames[1].points[30].visible);
        let back = parse_eos_csv(&format_eos_csv(&t), Path::new("w.csv")).unwrap();
        assert_eq!(back, t);
    }

    #[test]
    fn bad_rows_name_their_line() {
        let p = Path::new("e.csv");
        let err = |text: &str| parse_eos_csv(text, p).unwrap_err().to_string();
        assert_eq!(
            err("frame,ibug_id,u,v\n0,0,1,2\n"),
            "e.csv:2: column `ibug_id`: 0 is not an iBUG id (1–68)"
        );
        assert!(err("frame,ibug_id,u,v\n0,69,1,2\n").contains("69 is not an iBUG id"));
        assert!(
            err("frame,ibug_id,u,v\n0,5,1,2\n0,5,3,4\n")
                .starts_with("e.csv:3: iBUG id 5 of frame 0")
        );
        assert!(err("frame,ibug_id,u\n0,5,1\n").contains("missing column `v`"));
        assert!(err("frame,ibug_id,u,v,w\n0,5,1,2,3\n").contains("unknown column `w`"));
        assert!(err("frame,ibug_id,u,v\n0,5,nan,2\n").starts_with("e.csv:2: column `u`"));
    }
}
