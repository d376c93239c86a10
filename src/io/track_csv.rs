//! lipmap CSV, the lossless landmark format (`frame,point,x,y,visible,confidence,source`),
//! plus the small CSV table reader shared by the OpenFace and phone-CSV parsers.
//!
//! One row per point, 0-based frames and points, 0-based pixel coordinates printed with
//! shortest round-trip decimals, so a track written and read back is bit-identical. The
//! `visible`, `confidence` and `source` columns are optional on read (defaults: visible,
//! no confidence, tracked); points a frame does not list are read as not visible.
//! Three optional frame-level columns follow when a track has such values (an OpenFace
//! import): `timestamp` (s), `frame_confidence` and `success` (0/1), repeated on every row
//! of the frame and required to agree; then `rerun_disagreement` on a track made by
//! lipmap's tracker (its self-check, `FrameLandmarks::rerun_disagreement`).

use super::error::{FormatError, Result};
use super::pts::shorten;
use crate::landmarks::ibug::N_LANDMARKS;
use crate::landmarks::track::{FrameLandmarks, LandmarkPoint, PointSource, Track};
use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::path::Path;

/// The header lipmap writes; on read the first four columns are required, in any order.
pub const TRACK_CSV_HEADER: &str = "frame,point,x,y,visible,confidence,source";

/// The optional frame-level columns, written after the header above when needed.
pub const TRACK_CSV_FRAME_COLUMNS: &str = "timestamp,frame_confidence,success";

/// The column of lipmap's tracker's self-check, written last when a frame has one.
pub const TRACK_CSV_RERUN_COLUMN: &str = "rerun_disagreement";

const KNOWN_COLUMNS: [&str; 11] = [
    "frame",
    "point",
    "x",
    "y",
    "visible",
    "confidence",
    "source",
    "timestamp",
    "frame_confidence",
    "success",
    TRACK_CSV_RERUN_COLUMN,
];

/// Frame-level values read from one row.
#[derive(Clone, Copy, PartialEq)]
struct FrameFields {
    timestamp: Option<f64>,
    confidence: Option<f32>,
    success: bool,
    rerun_disagreement: Option<f32>,
}

/// A parsed CSV: header names and the data rows with their 1-based line numbers.
pub(crate) struct CsvTable {
    pub header: Vec<String>,
    pub rows: Vec<(usize, csv::StringRecord)>,
}

impl CsvTable {
    /// Index of the column called exactly `name`.
    pub fn column(&self, name: &str) -> Option<usize> {
        column(&self.header, name)
    }
}

/// Index of the column called exactly `name`.
fn column(header: &[String], name: &str) -> Option<usize> {
    header.iter().position(|h| h == name)
}

/// CSV text read row by row into one reused record (fields trimmed, header required, all
/// rows the same width): a landmark file holds a row per point, so keeping every row as
/// its own record cost more than parsing them.
pub(crate) struct CsvRows<'t> {
    pub header: Vec<String>,
    rows: Rows<'t>,
    path: &'t Path,
    /// The last row: the reader's record, or a plain row's fields.
    record: csv::StringRecord,
    fields: Vec<&'t str>,
}

/// One row's fields, trimmed.
pub(crate) trait Fields {
    /// Field `i`, or None past the row's end.
    fn field(&self, i: usize) -> Option<&str>;
}

impl Fields for csv::StringRecord {
    fn field(&self, i: usize) -> Option<&str> {
        self.get(i)
    }
}

/// A row [`CsvRows::next_row`] hands out.
pub(crate) enum Row<'r, 't> {
    Record(&'r csv::StringRecord),
    Plain(&'r [&'t str]),
}

impl Fields for Row<'_, '_> {
    fn field(&self, i: usize) -> Option<&str> {
        match self {
            Row::Record(r) => r.get(i),
            Row::Plain(fields) => fields.get(i).copied(),
        }
    }
}

impl Row<'_, '_> {
    /// The row as a record of its own.
    pub fn to_record(&self) -> csv::StringRecord {
        match self {
            Row::Record(r) => (*r).clone(),
            Row::Plain(fields) => csv::StringRecord::from(fields.to_vec()),
        }
    }
}

/// Where [`CsvRows`] takes its rows from.
enum Rows<'t> {
    /// Rows without a quote or a carriage return, split here: the reader would see each line
    /// as one record of the fields between its commas, skip empty lines and read nothing
    /// else. `line` is the 1-based line `rest` starts on.
    Plain { rest: &'t str, line: usize },
    /// Anything else, read by the csv reader.
    Reader(csv::Reader<&'t [u8]>),
}

impl<'t> CsvRows<'t> {
    /// Reads the header.
    ///
    /// # Errors
    /// No header, a column named twice, or CSV the reader rejects, naming the line.
    pub fn new(text: &'t str, path: &'t Path) -> Result<Self> {
        Self::reading(text, path, true)
    }

    /// As [`CsvRows::new`]; `plain` lets rows without quotes skip the csv reader.
    fn reading(text: &'t str, path: &'t Path, plain: bool) -> Result<Self> {
        let text = crate::io::input::without_bom(text);
        // Fields are trimmed here, only in the rows that need it: the reader's own trimming
        // rewrote every row twice.
        let mut reader = csv::ReaderBuilder::new().has_headers(true).from_reader(text.as_bytes());
        let header: Vec<String> = reader
            .headers()
            .map_err(|e| csv_error(path, &e))?
            .iter()
            .map(|h| h.trim().to_string())
            .collect();
        if header.iter().all(String::is_empty) {
            return Err(FormatError::at_line(path, 1, "empty file: a header line is required"));
        }
        let mut seen = std::collections::HashSet::with_capacity(header.len());
        for h in &header {
            if !seen.insert(h.as_str()) {
                return Err(FormatError::at_line(
                    path,
                    1,
                    format!("column `{}` appears twice", shorten(h)),
                ));
            }
        }
        let after_header = reader.position();
        let rest = text.get(after_header.byte() as usize..).unwrap_or("");
        // Two byte searches (memchr), far cheaper than one test of each byte for both.
        let rows = if plain && ![b'"', b'\r'].iter().any(|b| rest.as_bytes().contains(b)) {
            Rows::Plain { rest, line: after_header.line() as usize }
        } else {
            Rows::Reader(reader)
        };
        Ok(Self { header, rows, path, record: csv::StringRecord::new(), fields: Vec::new() })
    }

    /// Index of the column called exactly `name`.
    pub fn column(&self, name: &str) -> Option<usize> {
        column(&self.header, name)
    }

    /// The next row, trimmed, with its 1-based line number; None at the end.
    ///
    /// # Errors
    /// A row of another width or bytes that are not UTF-8, naming the line.
    pub fn next_row(&mut self) -> Result<Option<(usize, Row<'_, 't>)>> {
        match &mut self.rows {
            Rows::Plain { rest, line } => {
                // The reader numbers a row by where its reading began, before the empty lines
                // it skips.
                let at = *line;
                loop {
                    if rest.is_empty() {
                        return Ok(None);
                    }
                    // One pass over the line's bytes for its commas and its end: a search for
                    // the end first (`split_once`, memchr) cost as much again on rows this
                    // short, and `str::split` more than the rest of a row's parsing.
                    self.fields.clear();
                    let mut start = 0;
                    let mut end = rest.len();
                    for (i, &b) in rest.as_bytes().iter().enumerate() {
                        if b == b',' {
                            self.fields.push(trim_field(&rest[start..i]));
                            start = i + 1;
                        } else if b == b'\n' {
                            end = i;
                            break;
                        }
                    }
                    let text = &rest[..end];
                    (*rest, *line) = (rest.get(end + 1..).unwrap_or(""), *line + 1);
                    if text.is_empty() {
                        continue;
                    }
                    self.fields.push(trim_field(&text[start..]));
                    if self.fields.len() != self.header.len() {
                        let (len, header) = (self.fields.len(), self.header.len());
                        return Err(unequal_lengths(self.path, at, len, header));
                    }
                    return Ok(Some((at, Row::Plain(&self.fields))));
                }
            }
            Rows::Reader(reader) => {
                let rec = &mut self.record;
                if !reader.read_record(rec).map_err(|e| csv_error(self.path, &e))? {
                    return Ok(None);
                }
                let line = rec.position().map_or(0, |p| p.line() as usize);
                // Only a field that starts or ends with whitespace, or holds non-ASCII text
                // (which may be Unicode whitespace), can change.
                let space = |b: &u8| char::from(*b).is_whitespace();
                let padded = |f: &str| {
                    f.as_bytes().first().is_some_and(space)
                        || f.as_bytes().last().is_some_and(space)
                        || !f.is_ascii()
                };
                if rec.iter().any(padded) {
                    rec.trim();
                }
                Ok(Some((line, Row::Record(rec))))
            }
        }
    }
}

/// A field without the whitespace at its ends: a field that begins and ends with a visible
/// ASCII character (nearly all) has none, without `str::trim`'s Unicode decoding.
fn trim_field(f: &str) -> &str {
    match (f.as_bytes().first(), f.as_bytes().last()) {
        (Some(a), Some(b)) if a.is_ascii_graphic() && b.is_ascii_graphic() => f,
        _ => f.trim(),
    }
}

/// Reads CSV text (fields trimmed, header required, all rows the same width).
pub(crate) fn read_csv_table(text: &str, path: &Path) -> Result<CsvTable> {
    let mut reader = CsvRows::new(text, path)?;
    let mut rows = Vec::new();
    while let Some((line, row)) = reader.next_row()? {
        rows.push((line, row.to_record()));
    }
    Ok(CsvTable { header: reader.header, rows })
}

/// A csv crate error as a one-line `FormatError` at the line where it happened.
pub(crate) fn csv_error(path: &Path, e: &csv::Error) -> FormatError {
    match e.kind() {
        csv::ErrorKind::UnequalLengths { pos, expected_len, len } => unequal_lengths(
            path,
            pos.as_ref().map_or(0, |p| p.line() as usize),
            *len as usize,
            *expected_len as usize,
        ),
        csv::ErrorKind::Utf8 { pos, .. } => FormatError::at_line(
            path,
            pos.as_ref().map_or(0, |p| p.line() as usize),
            "text is not valid UTF-8",
        ),
        _ => FormatError::whole(path, e.to_string()),
    }
}

/// A row of `len` fields under a header of `expected`.
fn unequal_lengths(path: &Path, line: usize, len: usize, expected: usize) -> FormatError {
    FormatError::at_line(path, line, format!("{len} fields, but the header has {expected}"))
}

/// One field parsed as a finite number, or an error naming the line and column.
pub(crate) fn parse_f64_field(
    rec: &impl Fields,
    idx: usize,
    name: &str,
    path: &Path,
    line: usize,
) -> Result<f64> {
    match rec.field(idx).and_then(parse_short_decimal) {
        Some(v) => Ok(v),
        None => parse_finite_field(rec, idx, name, path, line),
    }
}

/// `s` as f64 when it is a short plain decimal (`[+-]digits[.digits]`, at most 19 digits,
/// whose digits as a whole number are at most 2⁵³, with at most 22 after the point), else
/// None. Such a number is `m / 10ᵉ` with both exactly representable, so one correctly rounded
/// division gives the correctly rounded value, the bits `str::parse` gives (Clinger 1990,
/// "How to read floating point numbers accurately", the fast path; Rust's parser takes it
/// too), without that parser's general machinery. Anything else goes to `str::parse`.
fn parse_short_decimal(s: &str) -> Option<f64> {
    const POW10: [f64; 23] = [
        1e0, 1e1, 1e2, 1e3, 1e4, 1e5, 1e6, 1e7, 1e8, 1e9, 1e10, 1e11, 1e12, 1e13, 1e14, 1e15, 1e16,
        1e17, 1e18, 1e19, 1e20, 1e21, 1e22,
    ];
    let (negative, digits) = match s.as_bytes() {
        [b'-', rest @ ..] => (true, rest),
        [b'+', rest @ ..] => (false, rest),
        all => (false, all),
    };
    let (mut m, mut n, mut point) = (0u64, 0usize, None);
    for &b in digits {
        let d = b.wrapping_sub(b'0');
        if d < 10 {
            // Past 19 digits m may wrap; such text is left to `str::parse` below.
            m = m.wrapping_mul(10).wrapping_add(u64::from(d));
            n += 1;
        } else if b == b'.' && point.is_none() {
            point = Some(n);
        } else {
            return None;
        }
    }
    let after_point = n - point.unwrap_or(n);
    if n == 0 || n > 19 || m > 1 << 53 || after_point >= POW10.len() {
        return None;
    }
    let v = m as f64 / POW10[after_point];
    Some(if negative { -v } else { v })
}

/// One field parsed as a finite `f32` (a value beyond `f32` range is an error, not `inf`).
pub(crate) fn parse_f32_field(
    rec: &impl Fields,
    idx: usize,
    name: &str,
    path: &Path,
    line: usize,
) -> Result<f32> {
    parse_finite_field(rec, idx, name, path, line)
}

/// One field parsed as a finite number of type `T` (overflowing `T`'s range is not finite).
fn parse_finite_field<T: std::str::FromStr + Copy + Into<f64>>(
    rec: &impl Fields,
    idx: usize,
    name: &str,
    path: &Path,
    line: usize,
) -> Result<T> {
    let s = rec.field(idx).unwrap_or("");
    match s.parse::<T>() {
        Ok(v) if v.into().is_finite() => Ok(v),
        _ => Err(FormatError::at_line(
            path,
            line,
            format!("column `{name}`: `{}` is not a finite number", shorten(s)),
        )),
    }
}

/// One field parsed as a whole number, or an error naming the line and column.
pub(crate) fn parse_usize_field(
    rec: &impl Fields,
    idx: usize,
    name: &str,
    path: &Path,
    line: usize,
) -> Result<usize> {
    let s = rec.field(idx).unwrap_or("");
    s.parse::<usize>().map_err(|_| {
        FormatError::at_line(
            path,
            line,
            format!("column `{name}`: `{}` is not a whole number", shorten(s)),
        )
    })
}

/// Parses lipmap CSV text into a track (frames ascending).
///
/// # Errors
/// A missing required column, an unknown column, a bad number, a point id outside 0..68,
/// a bad `visible`/`source` value or a point given twice, each naming the line.
///
/// # Examples
/// ```
/// # use std::path::Path;
/// let t = lipmap::io::track_csv::parse_track_csv("frame,point,x,y\n0,48,10.5,20\n", Path::new("t.csv")).unwrap();
/// assert!(t.frames[0].points[48].visible && !t.frames[0].points[0].visible);
/// ```
pub fn parse_track_csv(text: &str, path: &Path) -> Result<Track> {
    let mut table = CsvRows::new(text, path)?;
    for h in &table.header {
        if !KNOWN_COLUMNS.contains(&h.as_str()) {
            return Err(FormatError::at_line(
                path,
                1,
                format!("unknown column `{}` (expected {TRACK_CSV_HEADER})", shorten(h)),
            ));
        }
    }
    let need = |name: &str| {
        table.column(name).ok_or_else(|| {
            FormatError::at_line(
                path,
                1,
                format!("missing column `{name}` (expected {TRACK_CSV_HEADER})"),
            )
        })
    };
    let (c_frame, c_point, c_x, c_y) = (need("frame")?, need("point")?, need("x")?, need("y")?);
    let (c_vis, c_conf, c_src) =
        (table.column("visible"), table.column("confidence"), table.column("source"));
    let (c_time, c_fconf, c_success) =
        (table.column("timestamp"), table.column("frame_confidence"), table.column("success"));
    let c_rerun = table.column(TRACK_CSV_RERUN_COLUMN);

    let mut frames: BTreeMap<usize, (FrameFields, Vec<Option<LandmarkPoint>>)> = BTreeMap::new();
    while let Some((line, row)) = table.next_row()? {
        let rec = &row;
        let frame = parse_usize_field(rec, c_frame, "frame", path, line)?;
        let point = parse_usize_field(rec, c_point, "point", path, line)?;
        if point >= N_LANDMARKS {
            return Err(FormatError::at_line(
                path,
                line,
                format!("column `point`: {point} is out of range 0..{}", N_LANDMARKS - 1),
            ));
        }
        let x = parse_f64_field(rec, c_x, "x", path, line)?;
        let y = parse_f64_field(rec, c_y, "y", path, line)?;
        let visible = match c_vis.map_or("", |c| rec.field(c).unwrap_or("")) {
            "" | "1" | "true" => true,
            "0" | "false" => false,
            other => {
                return Err(FormatError::at_line(
                    path,
                    line,
                    format!("column `visible`: `{}` is not 0 or 1", shorten(other)),
                ));
            }
        };
        let confidence = match c_conf {
            Some(c) if !rec.field(c).unwrap_or("").is_empty() => {
                Some(parse_f32_field(rec, c, "confidence", path, line)?)
            }
            _ => None,
        };
        let src_text = c_src.map_or("", |c| rec.field(c).unwrap_or(""));
        let source = PointSource::parse(src_text).ok_or_else(|| {
            FormatError::at_line(
                path,
                line,
                format!(
                    "column `source`: `{}` is not tracked, corrected or interpolated",
                    shorten(src_text)
                ),
            )
        })?;
        let fields = FrameFields {
            timestamp: match c_time {
                Some(c) if !rec.field(c).unwrap_or("").is_empty() => {
                    Some(parse_f64_field(rec, c, "timestamp", path, line)?)
                }
                _ => None,
            },
            confidence: match c_fconf {
                Some(c) if !rec.field(c).unwrap_or("").is_empty() => {
                    Some(parse_f32_field(rec, c, "frame_confidence", path, line)?)
                }
                _ => None,
            },
            success: match c_success.map_or("", |c| rec.field(c).unwrap_or("")) {
                "" | "1" => true,
                "0" => false,
                other => {
                    return Err(FormatError::at_line(
                        path,
                        line,
                        format!("column `success`: `{}` is not 0 or 1", shorten(other)),
                    ));
                }
            },
            rerun_disagreement: match c_rerun {
                Some(c) if !rec.field(c).unwrap_or("").is_empty() => {
                    Some(parse_f32_field(rec, c, TRACK_CSV_RERUN_COLUMN, path, line)?)
                }
                _ => None,
            },
        };
        let entry = frames.entry(frame).or_insert_with(|| (fields, vec![None; N_LANDMARKS]));
        if entry.0 != fields {
            return Err(FormatError::at_line(
                path,
                line,
                format!(
                    "frame {frame}: timestamp, frame_confidence, success or rerun_disagreement differ from its earlier rows"
                ),
            ));
        }
        let slot = &mut entry.1[point];
        if slot.is_some() {
            return Err(FormatError::at_line(
                path,
                line,
                format!("point {point} of frame {frame} is given twice"),
            ));
        }
        *slot = Some(LandmarkPoint { x, y, visible, confidence, source });
    }
    let frames = frames
        .into_iter()
        .map(|(f, (fields, pts))| {
            let mut fl = FrameLandmarks::new(
                f,
                pts.into_iter().map(|p| p.unwrap_or(LandmarkPoint::missing())).collect(),
            );
            fl.timestamp = fields.timestamp;
            fl.confidence = fields.confidence;
            fl.success = fields.success;
            fl.rerun_disagreement = fields.rerun_disagreement;
            fl
        })
        .collect();
    Ok(Track::new(frames))
}

/// Reads a lipmap CSV file.
///
/// # Errors
/// I/O failures and everything `parse_track_csv` rejects.
pub fn read_track_csv(path: &Path) -> Result<Track> {
    let text = super::input::read_input_string(path)?;
    super::landmark_format::check_track_bounds(parse_track_csv(&text, path)?, path)
}

/// The lipmap CSV text of a track: every point of every frame, one row each; the
/// frame-level columns are added only when some frame has a timestamp, a confidence or
/// `success = false`.
pub fn format_track_csv(track: &Track) -> String {
    let rerun_col = track.frames.iter().any(|f| f.rerun_disagreement.is_some());
    let frame_cols = rerun_col
        || track
            .frames
            .iter()
            .any(|f| f.timestamp.is_some() || f.confidence.is_some() || !f.success);
    let mut s = String::with_capacity(64 + track.frames.len() * N_LANDMARKS * 32);
    s.push_str(TRACK_CSV_HEADER);
    if frame_cols {
        s.push(',');
        s.push_str(TRACK_CSV_FRAME_COLUMNS);
    }
    if rerun_col {
        s.push(',');
        s.push_str(TRACK_CSV_RERUN_COLUMN);
    }
    s.push('\n');
    for f in &track.frames {
        for (i, p) in f.points.iter().enumerate() {
            let _ = write!(s, "{},{},{},{},{},", f.frame, i, p.x, p.y, u8::from(p.visible));
            if let Some(c) = p.confidence {
                let _ = write!(s, "{c}");
            }
            let _ = write!(s, ",{}", p.source.as_str());
            if frame_cols {
                s.push(',');
                if let Some(t) = f.timestamp {
                    let _ = write!(s, "{t}");
                }
                s.push(',');
                if let Some(c) = f.confidence {
                    let _ = write!(s, "{c}");
                }
                let _ = write!(s, ",{}", u8::from(f.success));
            }
            if rerun_col {
                s.push(',');
                if let Some(d) = f.rerun_disagreement {
                    let _ = write!(s, "{d}");
                }
            }
            s.push('\n');
        }
    }
    s
}

/// Writes a track as lipmap CSV.
///
/// # Errors
/// I/O failures, naming `path`.
pub fn write_track_csv(track: &Track, path: &Path) -> Result<()> {
    super::atomic::write_atomic_bytes(path, format_track_csv(track).as_bytes())
        .map_err(|e| FormatError::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn lossless_round_trip() {
        let mut pts: Vec<LandmarkPoint> = (0..N_LANDMARKS)
            .map(|i| LandmarkPoint::tracked(i as f64 * 0.1 + 1e-7, 1.0 / 3.0))
            .collect();
        pts[3].visible = false;
        pts[4].confidence = Some(0.123_456_79);
        pts[5].source = PointSource::Corrected;
        pts[6].source = PointSource::Interpolated;
        let mut f = FrameLandmarks::new(7, pts);
        let plain = Track::new(vec![f.clone()]);
        assert!(
            format_track_csv(&plain).starts_with("frame,point,x,y,visible,confidence,source\n")
        );
        assert_eq!(parse_track_csv(&format_track_csv(&plain), Path::new("t.csv")).unwrap(), plain);
        f.timestamp = Some(0.2);
        f.confidence = Some(0.5);
        f.success = false;
        let track = Track::new(vec![f.clone()]);
        let back = parse_track_csv(&format_track_csv(&track), Path::new("t.csv")).unwrap();
        assert_eq!(back, track);
        f.rerun_disagreement = Some(0.031_25);
        let track = Track::new(vec![f]);
        let text = format_track_csv(&track);
        assert!(text.lines().next().unwrap().ends_with(",success,rerun_disagreement"));
        assert_eq!(parse_track_csv(&text, Path::new("t.csv")).unwrap(), track);
    }

    #[test]
    fn non_numeric_coordinate_names_line() {
        let e = parse_track_csv("frame,point,x,y\n0,1,2,3\n0,2,abc,3\n", Path::new("t.csv"))
            .unwrap_err();
        assert_eq!(e.to_string(), "t.csv:3: column `x`: `abc` is not a finite number");
    }

    /// Header, rows with their lines, or the error, read with or without the plain rows.
    fn rows_of(text: &str, plain: bool) -> std::result::Result<RowsRead, String> {
        let mut rows =
            CsvRows::reading(text, Path::new("t.csv"), plain).map_err(|e| e.to_string())?;
        let mut read = Vec::new();
        while let Some((line, row)) = rows.next_row().map_err(|e| e.to_string())? {
            read.push((line, row.to_record().iter().map(String::from).collect()));
        }
        Ok((rows.header, read))
    }
    type RowsRead = (Vec<String>, Vec<(usize, Vec<String>)>);

    proptest::proptest! {
        /// Rows split without the csv reader are the reader's rows, lines and errors.
        #[test]
        fn plain_rows_are_the_readers(
            text in "[ab1 ,\n\t\u{a0}é]{0,40}",
            quoted in "[ab1 ,\n\"\r]{0,40}",
        ) {
            proptest::prop_assert_eq!(rows_of(&text, true), rows_of(&text, false));
            // Quotes or carriage returns in the header only, or anywhere.
            let header_quoted = format!("{}\n{text}", quoted.replace('\n', ""));
            proptest::prop_assert_eq!(rows_of(&header_quoted, true), rows_of(&header_quoted, false));
            proptest::prop_assert_eq!(rows_of(&quoted, true), rows_of(&quoted, false));
        }
    }

    proptest::proptest! {
        /// Short decimals read directly are `str::parse`'s bits; the rest is left to it.
        #[test]
        fn short_decimals_are_parses_bits(
            text in "[+-]?[0-9]{0,12}[.]?[0-9]{0,12}",
            x in proptest::num::f64::NORMAL | proptest::num::f64::SUBNORMAL,
            decimals in 0usize..10,
        ) {
            for s in [text, format!("{x}"), format!("{x:.decimals$}"), format!("{x:e}")] {
                // None leaves the text to `str::parse` itself, which is always right.
                if let Some(v) = parse_short_decimal(&s) {
                    let want: f64 = s.parse().unwrap();
                    proptest::prop_assert_eq!(v.to_bits(), want.to_bits(), "{}", s);
                }
            }
        }
    }

    #[test]
    fn short_decimal_edges() {
        for (s, want) in [
            ("500.241217", Some(500.241217)),
            ("-0", Some(-0.0)),
            (".5", Some(0.5)),
            ("5.", Some(5.0)),
            ("+1.25", Some(1.25)),
            ("9007199254740992", Some(9007199254740992.0)),
        ] {
            assert_eq!(parse_short_decimal(s).map(f64::to_bits), want.map(f64::to_bits), "{s}");
        }
        for s in [
            "",
            ".",
            "-",
            "+-1",
            "1.2.3",
            "1e5",
            "inf",
            "NaN",
            "9007199254740993",
            " 1",
            "1,5",
            "0.00000000000000000000001",
        ] {
            assert_eq!(parse_short_decimal(s), None, "{s}");
        }
    }
}
