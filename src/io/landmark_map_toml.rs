//! eos landmark mapping files (TOML: `[landmark_mappings]` then `31 = 114 # nose tip`) read
//! into and written from a [`LandmarkMap`]; also eos's exported `landmarks_and_contours.json`,
//! read by the same [`read_landmark_map`] wherever a map is read.
//!
//! In these files the iBUG ids are **1-based** (1..68) and vertex indices 0-based; lipmap is
//! 0-based everywhere, so ids are converted here and nowhere else. Other sections
//! (`[contour_landmarks]`) are accepted and ignored; unmapped points are simply absent.

use crate::io::error::{FormatError, Result};
use crate::io::pts::shorten;
use crate::landmarks::{LandmarkNames, N_LANDMARKS};
use crate::model::LandmarkMap;
use std::fmt::Write as _;
use std::path::Path;

/// The TOML table holding the mapping.
pub const SECTION: &str = "landmark_mappings";

/// Reads an eos landmark map: its TOML mapping file, or its JSON form (a `.json` name, or
/// text that opens with `{`: [`parse_landmark_map_json`]).
///
/// # Errors
/// Unreadable file, TOML syntax errors, a missing `[landmark_mappings]` table, an id outside
/// 1..=68 or a vertex that is not a non-negative integer: each names the line (the JSON
/// form's errors as [`parse_landmark_map_json`]'s).
pub fn read_landmark_map(path: &Path) -> Result<LandmarkMap> {
    let text = super::input::read_input_string(path)?;
    let json = path.extension().is_some_and(|e| e.eq_ignore_ascii_case("json"))
        || super::input::without_bom(&text).trim_start().starts_with('{');
    if json { parse_landmark_map_json(&text, path) } else { parse_landmark_map(&text, path) }
}

/// Parses mapping-file text; `path` is used only in error messages.
///
/// # Errors
/// As [`read_landmark_map`].
///
/// ```
/// use std::path::Path;
/// let map = lipmap::io::landmark_map_toml::parse_landmark_map(
///     "[landmark_mappings]\n31 = 114 # nose tip\n", Path::new("m.toml")).unwrap();
/// assert_eq!(map.vertex(30), Some(114)); // iBUG 31 is lipmap's 0-based point 30
/// ```
pub fn parse_landmark_map(text: &str, path: &Path) -> Result<LandmarkMap> {
    let text = super::input::without_bom(text);
    let table: toml::Table = toml::from_str(text).map_err(|e| {
        let line = e.span().map_or(1, |s| line_of_offset(text, s.start));
        FormatError::at_line(path, line, e.message().trim().to_string())
    })?;
    let section = table.get(SECTION).ok_or_else(|| {
        FormatError::at_field(path, SECTION, "no [landmark_mappings] table in the file")
    })?;
    let section =
        section.as_table().ok_or_else(|| FormatError::at_field(path, SECTION, "is not a table"))?;
    let mut map = LandmarkMap::default();
    for (key, value) in section {
        let line = line_of_key(text, key);
        let id: usize =
            key.parse().ok().filter(|id| (1..=N_LANDMARKS).contains(id)).ok_or_else(|| {
                FormatError::at_line(
                    path,
                    line,
                    format!("`{}` is not an iBUG id in 1..=68", shorten(key)),
                )
            })?;
        let vertex = value.as_integer().and_then(|v| usize::try_from(v).ok()).ok_or_else(|| {
            FormatError::at_line(
                path,
                line,
                format!(
                    "vertex for iBUG {id} must be a non-negative integer, got {}",
                    shorten(&value.to_string())
                ),
            )
        })?;
        map.to_vertex.insert(id - 1, vertex);
    }
    Ok(map)
}

/// The 1-based line holding byte `offset`.
fn line_of_offset(text: &str, offset: usize) -> usize {
    text[..offset.min(text.len())].matches('\n').count() + 1
}

/// The 1-based line of `key = …` inside the mapping section (1 if not found, which only
/// happens for exotic TOML such as dotted or inline-table keys).
fn line_of_key(text: &str, key: &str) -> usize {
    let mut in_section = false;
    for (i, line) in text.lines().enumerate() {
        let t = line.trim();
        if t.starts_with('[') {
            in_section = t.trim_start_matches('[').trim_end_matches(']').trim() == SECTION;
            continue;
        }
        let lhs = t.split('=').next().unwrap_or("").trim().trim_matches('"').trim_matches('\'');
        if in_section && t.contains('=') && lhs == key {
            return i + 1;
        }
    }
    1
}

/// Formats a map in eos's TOML layout: 1-based ids, one line per iBUG point with its name in
/// `names` as a comment; unmapped points appear as comment lines so the file reads like eos's.
pub fn format_landmark_map(map: &LandmarkMap, names: &LandmarkNames<'_>) -> String {
    let mut s = String::new();
    s.push_str("# iBUG-68 landmark -> mesh vertex mapping, written by lipmap.\n");
    s.push_str(
        "# TOML, as eos's mapping files: iBUG ids are 1-based (1..68), vertices 0-based.\n\n",
    );
    let _ = writeln!(s, "[{SECTION}]");
    for l in 0..N_LANDMARKS {
        let name = names.name(l);
        match map.vertex(l) {
            Some(v) => {
                let _ = writeln!(s, "{} = {v}  # {name}", l + 1);
            }
            None => {
                let _ = writeln!(s, "            # {} not mapped ({name})", l + 1);
            }
        }
    }
    // Entries beyond iBUG-68 cannot be written in this format; they cannot be read either.
    s
}

/// Writes a map as an eos TOML mapping file (see [`format_landmark_map`]).
///
/// # Errors
/// A point outside 0..68 (not representable), or I/O errors.
pub fn write_landmark_map(path: &Path, map: &LandmarkMap, names: &LandmarkNames<'_>) -> Result<()> {
    if let Some(&l) = map.to_vertex.keys().find(|&&l| l >= N_LANDMARKS) {
        return Err(FormatError::whole(path, format!("point {l} is not an iBUG-68 point")));
    }
    super::atomic::write_atomic_bytes(path, format_landmark_map(map, names).as_bytes())
        .map_err(|e| FormatError::io(path, e))
}

/// Parses eos's exported `landmarks_and_contours.json`: the object `ibug_to_sfm_vertex`
/// (1-based iBUG id strings → 0-based vertex), or a top-level object of that form; `path`
/// is used only in errors.
///
/// # Errors
/// Invalid JSON (with serde_json's line), ids outside 1..=68, non-integer vertices (naming
/// the field).
pub fn parse_landmark_map_json(text: &str, path: &Path) -> Result<LandmarkMap> {
    let v: serde_json::Value =
        serde_json::from_str(super::input::without_bom(text)).map_err(|e| {
            FormatError::new(
                path,
                crate::io::error::Location::LineColumn(e.line(), e.column()),
                e.to_string(),
            )
        })?;
    let obj = v
        .get("ibug_to_sfm_vertex")
        .unwrap_or(&v)
        .as_object()
        .ok_or_else(|| FormatError::whole(path, "expected an object of iBUG id -> vertex"))?;
    let mut map = LandmarkMap::default();
    for (key, value) in obj {
        let id: usize =
            key.parse().ok().filter(|id| (1..=N_LANDMARKS).contains(id)).ok_or_else(|| {
                FormatError::at_field(path, key.as_str(), "not an iBUG id in 1..=68")
            })?;
        // As in the TOML form, whose integers are i64.
        let vertex = value.as_u64().filter(|&v| i64::try_from(v).is_ok()).ok_or_else(|| {
            FormatError::at_field(path, key.as_str(), "vertex must be a non-negative integer")
        })?;
        map.to_vertex.insert(id - 1, vertex as usize);
    }
    Ok(map)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::io::error::Location;

    #[test]
    fn converts_ids_and_round_trips() {
        let text = "# c\n[landmark_mappings]\n 9 = 33 # chin\n            # 61 not defined\n\
                    62 = 416\n[contour_landmarks]\nright = [ 1,\n 2 ]\n";
        let map = parse_landmark_map(text, Path::new("m.txt")).unwrap();
        assert_eq!(map.len(), 2);
        assert_eq!(map.vertex(8), Some(33));
        assert_eq!(map.vertex(61), Some(416));
        assert_eq!(map.vertex(60), None);
        let written = format_landmark_map(&map, &LandmarkNames::builtin());
        assert!(written.contains("\n62 = 416  # inner lip 2\n"), "{written}");
        assert!(written.contains("# 61 not mapped"), "{written}");
        assert_eq!(parse_landmark_map(&written, Path::new("w.txt")).unwrap(), map);
    }

    #[test]
    fn errors_name_the_line() {
        let p = Path::new("m.txt");
        let e = parse_landmark_map("[landmark_mappings]\n1 = 2\n69 = 5\n", p).unwrap_err();
        assert_eq!(e.location, Location::Line(3));
        let e = parse_landmark_map("[landmark_mappings]\n1 = 2\n2 = -5\n", p).unwrap_err();
        assert_eq!(e.location, Location::Line(3));
        let e = parse_landmark_map("[landmark_mappings]\n1 = 2\n2 = = 5\n", p).unwrap_err();
        assert_eq!(e.location, Location::Line(3));
        let huge = format!(
            "[landmark_mappings]\n1 = \"{}\"\n{} = 3\n",
            "x".repeat(100_000),
            "9".repeat(50_000)
        );
        let e = parse_landmark_map(&huge, p).unwrap_err();
        assert!(
            e.to_string().len() < 200,
            "the value is echoed whole: {} bytes",
            e.to_string().len()
        );
        let e = parse_landmark_map("[other]\n1 = 2\n", p).unwrap_err();
        assert_eq!(e.location, Location::Field(SECTION.into()));
    }
}
