//! Phone alignments as plain CSV (`start,end,phone`, seconds, header required): parse and
//! write. The format `lipmap phones` prints and the simplest way to hand-make an alignment.
//!
//! Columns are found by name (`phone` or `label` for the label); other columns are ignored,
//! so a table with an extra `word` column still reads. Times print with shortest round-trip
//! decimals, so a write then read gives bit-identical times.

use super::error::{FormatError, Result};
use super::htk_lab::{SILENCE_WORD, push_phone};
use super::track_csv::{parse_f64_field, read_csv_table};
use crate::alignment::{Alignment, Phone};
use std::path::Path;

/// The header lipmap writes.
pub const PHONES_CSV_HEADER: &str = "start,end,phone";

/// Parses `start,end,phone` CSV text.
///
/// # Errors
/// A missing column, a non-numeric or negative time, a phone ending before it starts, or
/// overlapping phones, naming the line.
///
/// # Examples
/// ```
/// # use std::path::Path;
/// let a = lipmap::io::phones_csv::parse_phones_csv("start,end,phone\n0,0.12,B\n0.12,0.3,AA1\n", Path::new("p.csv")).unwrap();
/// assert_eq!(a.phones[1].label, "AA1");
/// ```
pub fn parse_phones_csv(text: &str, path: &Path) -> Result<Alignment> {
    let table = read_csv_table(text, path)?;
    let need = |name: &str| {
        table.column(name).ok_or_else(|| {
            FormatError::at_line(
                path,
                1,
                format!("missing column `{name}` (expected {PHONES_CSV_HEADER})"),
            )
        })
    };
    let (c_start, c_end) = (need("start")?, need("end")?);
    let c_label = table.column("phone").or_else(|| table.column("label")).ok_or_else(|| {
        FormatError::at_line(
            path,
            1,
            format!("missing column `phone` (expected {PHONES_CSV_HEADER})"),
        )
    })?;
    let mut phones = Vec::with_capacity(table.rows.len());
    for (line, rec) in &table.rows {
        let line = *line;
        let start = parse_f64_field(rec, c_start, "start", path, line)?;
        let end = parse_f64_field(rec, c_end, "end", path, line)?;
        if start < 0.0 {
            return Err(FormatError::at_line(
                path,
                line,
                format!("column `start`: {start} is negative"),
            ));
        }
        let label = rec.get(c_label).unwrap_or("").to_string();
        push_phone(&mut phones, Phone { start, end, label }, path, line)?;
    }
    Ok(Alignment { phones })
}

/// Reads a `start,end,phone` CSV file.
///
/// # Errors
/// I/O failures and everything `parse_phones_csv` rejects.
pub fn read_phones_csv(path: &Path) -> Result<Alignment> {
    let bytes = super::input::read_input(path)?;
    parse_phones_csv(&super::textgrid::decode_text(&bytes, path)?, path)
}

/// The `start,end,phone` CSV text of an alignment (labels quoted when they need it; a
/// silence, which the reader would refuse as an empty label, as [`SILENCE_WORD`]).
pub fn format_phones_csv(alignment: &Alignment) -> String {
    let mut w = csv::WriterBuilder::new().from_writer(Vec::new());
    // Writing into a Vec cannot fail; errors would only come from the sink.
    let _ = w.write_record(["start", "end", "phone"]);
    for p in &alignment.phones {
        let label = if p.label.trim().is_empty() { SILENCE_WORD } else { p.label.as_str() };
        let _ = w.write_record([p.start.to_string(), p.end.to_string(), label.to_string()]);
    }
    let bytes = w.into_inner().unwrap_or_default();
    String::from_utf8(bytes).unwrap_or_default()
}

/// Writes an alignment as `start,end,phone` CSV.
///
/// # Errors
/// I/O failures, naming `path`.
pub fn write_phones_csv(alignment: &Alignment, path: &Path) -> Result<()> {
    super::atomic::write_atomic_bytes(path, format_phones_csv(alignment).as_bytes())
        .map_err(|e| FormatError::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_with_awkward_labels() {
        let a = Alignment {
            phones: vec![
                Phone { start: 0.0, end: 0.1, label: String::new() },
                Phone { start: 0.1, end: 1.0 / 3.0, label: "a, \"b\"".into() },
                Phone { start: 0.4, end: 0.5, label: " aʊ ".trim().into() },
            ],
        };
        let text = format_phones_csv(&a);
        assert!(text.starts_with("start,end,phone\n0,0.1,sil\n"), "{text}");
        let mut silence_named = a.clone();
        silence_named.phones[0].label = SILENCE_WORD.into();
        assert_eq!(parse_phones_csv(&text, Path::new("p.csv")).unwrap(), silence_named);
    }
}
