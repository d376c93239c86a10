//! MakeHuman `.target` files (sparse blendshapes): one `vertex dx dy dz` line per moved
//! vertex (0-based into the base mesh), `#` comments; files ending `.gz` are gzipped.
//!
//! [`read_target_blendshape`] turns one file into a dense [`Blendshape`] for a base mesh;
//! [`read_target`] gives the sparse offsets with their line numbers.

use crate::io::error::{FormatError, Result};
use crate::math::{DVector, Vector3};
use crate::model::blendshapes::Blendshape;
use std::io::Read;
use std::path::Path;

/// One moved vertex of a target, with the 1-based line it came from.
#[derive(Clone, Debug, PartialEq)]
pub struct TargetOffset {
    pub vertex: usize,
    pub delta: Vector3,
    pub line: usize,
}

/// Whether `path` names a target file (`.target` or `.target.gz`).
pub fn is_target_file(path: &Path) -> bool {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("");
    name.ends_with(".target") || name.ends_with(".target.gz")
}

/// The blendshape name of a target file: its name without `.target` / `.target.gz`
/// (`faceunits/jawOpen.target` → `jawOpen`).
pub fn target_name(path: &Path) -> String {
    let name = path.file_name().and_then(|n| n.to_str()).unwrap_or("target");
    let name = name.strip_suffix(".gz").unwrap_or(name);
    name.strip_suffix(".target").unwrap_or(name).to_string()
}

/// Reads a target file's text, gunzipping when the name ends with `.gz`.
///
/// # Errors
/// Unreadable file or corrupt gzip data.
pub fn read_target_text(path: &Path) -> Result<String> {
    let bytes = super::input::read_input(path)?;
    let bytes = if path.extension().is_some_and(|e| e == "gz") {
        let mut out = Vec::new();
        flate2::read::GzDecoder::new(bytes.as_slice())
            .read_to_end(&mut out)
            .map_err(|e| FormatError::whole(path, format!("bad gzip data: {e}")))?;
        out
    } else {
        bytes
    };
    Ok(String::from_utf8_lossy(&bytes).into_owned())
}

/// Reads the sparse offsets of a target file.
///
/// # Errors
/// As [`read_target_text`] and [`parse_target`].
pub fn read_target(path: &Path) -> Result<Vec<TargetOffset>> {
    parse_target(&read_target_text(path)?, path)
}

/// Parses target text: `vertex dx dy dz` per line; blank lines and `#` comments skipped.
///
/// # Errors
/// A line that is not an index and three finite numbers, naming the line.
///
/// ```
/// use std::path::Path;
/// let t = lipmap::io::makehuman_target::parse_target("# c\n35 0 -.001 0\n", Path::new("a.target"));
/// assert_eq!(t.unwrap()[0].vertex, 35);
/// ```
pub fn parse_target(text: &str, path: &Path) -> Result<Vec<TargetOffset>> {
    let mut out = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let content = raw.split('#').next().unwrap_or("").trim();
        if content.is_empty() {
            continue;
        }
        let tokens: Vec<&str> = content.split_whitespace().collect();
        if tokens.len() != 4 {
            return Err(FormatError::at_line(
                path,
                line,
                format!("expected `vertex dx dy dz`, got `{content}`"),
            ));
        }
        let vertex = tokens[0].parse::<usize>().map_err(|_| {
            FormatError::at_line(path, line, format!("bad vertex index `{}`", tokens[0]))
        })?;
        let mut d = [0.0; 3];
        for (k, slot) in d.iter_mut().enumerate() {
            let t = tokens[k + 1];
            *slot = t.parse::<f64>().ok().filter(|v| v.is_finite()).ok_or_else(|| {
                FormatError::at_line(path, line, format!("`{t}` is not a finite number"))
            })?;
        }
        out.push(TargetOffset { vertex, delta: Vector3::new(d[0], d[1], d[2]), line });
    }
    Ok(out)
}

/// The dense delta (3N) of sparse offsets for a base of `num_vertices` vertices. A vertex
/// listed twice takes its last line, as MakeHuman's loader does (assignment, not sum).
///
/// # Errors
/// An offset whose vertex is past the base's last vertex, naming its line.
pub fn offsets_to_delta(
    offsets: &[TargetOffset],
    num_vertices: usize,
    path: &Path,
) -> Result<DVector> {
    let mut delta = DVector::zeros(3 * num_vertices);
    for o in offsets {
        if o.vertex >= num_vertices {
            return Err(FormatError::at_line(
                path,
                o.line,
                format!("vertex {} is past the base mesh's {num_vertices} vertices", o.vertex),
            ));
        }
        delta.fixed_rows_mut::<3>(3 * o.vertex).copy_from(&o.delta);
    }
    Ok(delta)
}

/// Reads a target file as a dense [`Blendshape`] (named after the file) for a base mesh
/// of `num_vertices` vertices.
///
/// # Errors
/// As [`read_target`] and [`offsets_to_delta`].
pub fn read_target_blendshape(path: &Path, num_vertices: usize) -> Result<Blendshape> {
    let offsets = read_target(path)?;
    let delta = offsets_to_delta(&offsets, num_vertices, path)?;
    Ok(Blendshape { name: target_name(path), delta })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::error::Location;

    #[test]
    fn parses_and_densifies() {
        let p = Path::new("x.target");
        let t = parse_target("# header\n\n1 0.5 -1 2 # moved\n0 1 1 1\n1 3 3 3\n", p).unwrap();
        assert_eq!(t.len(), 3);
        let d = offsets_to_delta(&t, 3, p).unwrap();
        assert_eq!(d.as_slice(), &[1.0, 1.0, 1.0, 3.0, 3.0, 3.0, 0.0, 0.0, 0.0]);
        let e = offsets_to_delta(&t, 1, p).unwrap_err();
        assert_eq!(e.location, Location::Line(3));
        let e = parse_target("1 2 3\n", p).unwrap_err();
        assert_eq!(e.location, Location::Line(1));
        let e = parse_target("0 0 0 0\n-1 2 3 4\n", p).unwrap_err();
        assert_eq!(e.location, Location::Line(2));
    }

    #[test]
    fn names_strip_suffixes() {
        assert_eq!(target_name(Path::new("a/jawOpen.target")), "jawOpen");
        assert_eq!(target_name(Path::new("mouth-trans-up.target.gz")), "mouth-trans-up");
        assert!(is_target_file(Path::new("m.target.gz")));
        assert!(!is_target_file(Path::new("m.obj")));
    }

    #[test]
    fn reads_gzipped_targets() {
        use flate2::{Compression, write::GzEncoder};
        use std::io::Write;
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("lip.target.gz");
        let mut enc = GzEncoder::new(Vec::new(), Compression::default());
        enc.write_all(b"2 0 0.25 0\n").unwrap();
        std::fs::write(&path, enc.finish().unwrap()).unwrap();
        let b = read_target_blendshape(&path, 3).unwrap();
        assert_eq!(b.name, "lip");
        assert_eq!(b.delta[7], 0.25);
        std::fs::write(dir.path().join("bad.target.gz"), b"not gzip").unwrap();
        assert!(read_target(&dir.path().join("bad.target.gz")).is_err());
    }
}
