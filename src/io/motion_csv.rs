//! Synthesized motion as CSV (`frame,vertex,x,y,z`, header required): per frame the
//! pose-free model-space positions of some model vertices. The format a researcher's own
//! synthesizer writes for `lipmap saqp cv --synth-files`; `lipmap saqp markers` names the
//! vertices it must give.
//!
//! Rows may come in any order; every frame from 0 to the last must name the same vertex set
//! (each once), so the file is one rectangular motion.

use super::error::{FormatError, Result};
use super::track_csv::{parse_f64_field, read_csv_table};
use crate::landmarks::MAX_FRAME;
use crate::math::Point3;
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// The header lipmap writes and reads.
pub const MOTION_CSV_HEADER: &str = "frame,vertex,x,y,z";

/// Per-frame positions of a fixed vertex set.
#[derive(Clone, Debug, PartialEq)]
pub struct VertexMotion {
    /// Vertex ids, ascending.
    pub vertices: Vec<usize>,
    /// `frames[f][k]` is the position of `vertices[k]` at frame `f`.
    pub frames: Vec<Vec<Point3>>,
}

fn parse_index(
    rec: &csv::StringRecord,
    idx: usize,
    name: &str,
    max: usize,
    path: &Path,
    line: usize,
) -> Result<usize> {
    let s = rec.get(idx).unwrap_or("");
    match s.parse::<usize>() {
        Ok(v) if v <= max => Ok(v),
        Ok(v) => Err(FormatError::at_line(
            path,
            line,
            format!("column `{name}`: {v} is past the largest lipmap accepts ({max})"),
        )),
        Err(_) => Err(FormatError::at_line(
            path,
            line,
            format!(
                "column `{name}`: `{}` is not a whole number ≥ 0",
                s.chars().take(24).collect::<String>()
            ),
        )),
    }
}

/// Largest vertex coordinate accepted, in any unit: far beyond any head, and small enough
/// that the squared distances the quality measures sum stay finite.
pub const MAX_COORDINATE: f64 = 1e9;

/// Parses `frame,vertex,x,y,z` CSV text.
///
/// # Errors
/// A missing column, a bad number, a vertex given twice in a frame, no rows, or a frame
/// whose vertex set differs from frame 0's (or that is missing), naming the line or frame.
pub fn parse_motion_csv(text: &str, path: &Path) -> Result<VertexMotion> {
    let table = read_csv_table(text, path)?;
    let need = |name: &str| {
        table.column(name).ok_or_else(|| {
            FormatError::at_line(
                path,
                1,
                format!("missing column `{name}` (expected {MOTION_CSV_HEADER})"),
            )
        })
    };
    let cols = [need("frame")?, need("vertex")?, need("x")?, need("y")?, need("z")?];
    // Bounded by the rows read (a file under the input cap), never by a number in the file.
    let mut by_frame: BTreeMap<usize, BTreeMap<usize, Point3>> = BTreeMap::new();
    for (line, rec) in &table.rows {
        let line = *line;
        let frame = parse_index(rec, cols[0], "frame", MAX_FRAME, path, line)?;
        let vertex = parse_index(rec, cols[1], "vertex", u32::MAX as usize, path, line)?;
        let mut p = Point3::origin();
        for (a, name) in ["x", "y", "z"].into_iter().enumerate() {
            p[a] = parse_f64_field(rec, cols[2 + a], name, path, line)?;
            if p[a].abs() > MAX_COORDINATE {
                return Err(FormatError::at_line(
                    path,
                    line,
                    format!(
                        "column `{name}`: {} is not within ±{MAX_COORDINATE:e}",
                        crate::math::short_number(p[a])
                    ),
                ));
            }
        }
        if by_frame.entry(frame).or_default().insert(vertex, p).is_some() {
            return Err(FormatError::at_line(
                path,
                line,
                format!("frame {frame} gives vertex {vertex} twice"),
            ));
        }
    }
    let Some(first) = by_frame.values().next() else {
        return Err(FormatError::whole(path, "no rows: the motion has no frames"));
    };
    let vertices: Vec<usize> = first.keys().copied().collect();
    let mut frames = Vec::with_capacity(by_frame.len());
    for (expected, (&frame, points)) in by_frame.iter().enumerate() {
        if frame != expected {
            return Err(FormatError::at_field(
                path,
                format!("frame {expected}"),
                "missing (frames must run from 0 without gaps)",
            ));
        }
        if points.len() != vertices.len() || !points.keys().eq(vertices.iter()) {
            return Err(FormatError::at_field(
                path,
                format!("frame {frame}"),
                format!(
                    "gives {} vertices, not the {} of frame 0 (every frame must give the same vertices)",
                    points.len(),
                    vertices.len()
                ),
            ));
        }
        frames.push(points.values().copied().collect());
    }
    Ok(VertexMotion { vertices, frames })
}

/// Reads a `frame,vertex,x,y,z` CSV file.
///
/// # Errors
/// I/O failures and everything [`parse_motion_csv`] rejects.
pub fn read_motion_csv(path: &Path) -> Result<VertexMotion> {
    let bytes = super::input::read_input(path)?;
    parse_motion_csv(&super::textgrid::decode_text(&bytes, path)?, path)
}

/// The CSV text of a motion, frame by frame, shortest round-trip decimals.
pub fn format_motion_csv(motion: &VertexMotion) -> String {
    let mut s = String::from(MOTION_CSV_HEADER);
    s.push('\n');
    for (f, points) in motion.frames.iter().enumerate() {
        for (v, p) in motion.vertices.iter().zip(points) {
            let _ = writeln!(s, "{f},{v},{},{},{}", p.x, p.y, p.z);
        }
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    fn path() -> &'static Path {
        Path::new("m.csv")
    }

    #[test]
    fn a_written_motion_reads_back_bit_identical_in_any_row_order() {
        let m = VertexMotion {
            vertices: vec![3, 17],
            frames: vec![
                vec![Point3::new(0.1, -2.0, 1.0 / 3.0), Point3::new(4.0, 5.5, 6.25)],
                vec![Point3::new(1e-9, 2.0, 3.0), Point3::new(-7.0, 8.0, 9.0)],
            ],
        };
        let text = format_motion_csv(&m);
        assert_eq!(parse_motion_csv(&text, path()).unwrap(), m);
        let mut lines: Vec<&str> = text.lines().collect();
        lines[1..].reverse();
        assert_eq!(parse_motion_csv(&lines.join("\n"), path()).unwrap(), m);
    }

    #[test]
    fn bad_motion_files_get_one_line_errors_naming_the_place() {
        let cases = [
            ("frame,vertex,x,y\n0,1,0,0\n", "missing column `z`"),
            ("frame,vertex,x,y,z\n", "no rows"),
            ("frame,vertex,x,y,z\n0,1,0,0,nan\n", "m.csv:2"),
            ("frame,vertex,x,y,z\n0,1,0,1e200,0\n", "column `y`: 1e200 is not within ±1e9"),
            ("frame,vertex,x,y,z\n-1,1,0,0,0\n", "whole number"),
            ("frame,vertex,x,y,z\n99999999999,1,0,0,0\n", "largest"),
            ("frame,vertex,x,y,z\n0,1,0,0,0\n0,1,1,1,1\n", "twice"),
            ("frame,vertex,x,y,z\n0,1,0,0,0\n2,1,0,0,0\n", "frame 1"),
            ("frame,vertex,x,y,z\n0,1,0,0,0\n0,2,0,0,0\n1,1,0,0,0\n", "frame 1"),
        ];
        for (text, want) in cases {
            let e = parse_motion_csv(text, path()).unwrap_err().to_string();
            assert!(e.contains(want) && e.contains("m.csv"), "{text:?}: {e}");
            assert!(!e.contains('\n'), "{e}");
        }
    }
}
