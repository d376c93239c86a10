//! HTK/Festival `.lab` label files (`start end label`) and Festival xlabel files (header,
//! `#`, then `end color label`): parse and write. Start at `parse_lab`.
//!
//! Time units of `start end label` files, decided once per file: when every time is written
//! as a plain integer and the largest exceeds 1000, the file is in HTK's 100 ns units (a
//! phone file in seconds never reaches 1000 s, and one in 100 ns units never stays within
//! 0.1 ms); otherwise the times are seconds (decimals, as wavesurfer and Audacity-style
//! `.lab` files write). Trailing HTK fields (score, auxiliary labels) are ignored, and only
//! the first level of a multi-level file (up to `///`) is read. A file with a line that is
//! exactly `#` is Festival xlabel: each line gives a phone's end time in seconds, its start
//! is the previous end (0 for the first), the middle field (colour, usually `100`) is ignored.

use super::error::{FormatError, Result};
use super::pts::shorten;
use crate::alignment::{Alignment, Phone};
use std::fmt::Write as _;
use std::path::Path;

/// HTK time units per second (100 ns).
const HTK_UNITS_PER_SECOND: f64 = 1e7;

/// Largest all-integer time still read as seconds (see the module notes).
const MAX_INTEGER_SECONDS: u64 = 1000;

/// Whether label text is Festival xlabel (has a line that is just `#`).
pub fn is_xlabel(text: &str) -> bool {
    text.lines().any(|l| l.trim() == "#")
}

/// Parses `.lab` text, HTK or Festival xlabel (see the module notes for the rules).
///
/// # Errors
/// A line that is not `start end label`, a non-numeric or negative time, a phone ending
/// before it starts, overlapping phones, or no phones at all, naming the line.
///
/// # Examples
/// ```
/// # use std::path::Path;
/// let a = lipmap::io::htk_lab::parse_lab("0 1500000 sil\n1500000 2300000 AA1\n", Path::new("a.lab")).unwrap();
/// assert_eq!((a.phones[1].start, a.phones[1].end), (0.15, 0.23));
/// let x = lipmap::io::htk_lab::parse_lab("#\n0.22 100 pau\n0.31 100 b\n", Path::new("a.lab")).unwrap();
/// assert_eq!((x.phones[1].start, x.phones[1].label.as_str()), (0.22, "b"));
/// ```
pub fn parse_lab(text: &str, path: &Path) -> Result<Alignment> {
    let text = crate::io::input::without_bom(text);
    if is_xlabel(text) { parse_xlabel(text, path) } else { parse_htk_lab(text, path) }
}

/// Parses HTK `start end label` text (units as in the module notes).
///
/// # Errors
/// As `parse_lab`.
pub fn parse_htk_lab(text: &str, path: &Path) -> Result<Alignment> {
    struct Row<'a> {
        line: usize,
        start: &'a str,
        end: &'a str,
        label: &'a str,
    }
    let mut rows = Vec::new();
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let trimmed = raw.trim();
        if trimmed.is_empty() {
            continue;
        }
        if trimmed == "///" || trimmed == "." {
            break;
        }
        let fields: Vec<&str> = trimmed.split_whitespace().collect();
        if fields.len() < 3 {
            return Err(FormatError::at_line(
                path,
                line,
                format!("expected `start end label`, found `{}`", shorten(trimmed)),
            ));
        }
        rows.push(Row { line, start: fields[0], end: fields[1], label: fields[2] });
    }
    if rows.is_empty() {
        return Err(FormatError::whole(path, "no labels found"));
    }
    let is_integer = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    let all_integer = rows.iter().all(|r| is_integer(r.start) && is_integer(r.end));
    let htk_units = all_integer
        && rows.iter().any(|r| {
            [r.start, r.end]
                .iter()
                .any(|s| s.parse::<u64>().map_or(true, |v| v > MAX_INTEGER_SECONDS))
        });
    let mut phones: Vec<Phone> = Vec::with_capacity(rows.len());
    for r in &rows {
        let time = |s: &str, which: &str| -> Result<f64> {
            let v = if htk_units {
                s.parse::<u64>().ok().map(|u| u as f64 / HTK_UNITS_PER_SECOND)
            } else {
                s.parse::<f64>().ok()
            };
            match v {
                Some(v) if v.is_finite() && v >= 0.0 => Ok(v),
                _ => Err(FormatError::at_line(
                    path,
                    r.line,
                    format!("{which} time `{}` is not a non-negative number", shorten(s)),
                )),
            }
        };
        let (start, end) = (time(r.start, "start")?, time(r.end, "end")?);
        push_phone(&mut phones, Phone { start, end, label: r.label.to_string() }, path, r.line)?;
    }
    Ok(Alignment { phones })
}

/// Appends a phone after checking it has a label, lasts at least
/// [`crate::alignment::MIN_PHONE_S`] and does not overlap the last.
pub(crate) fn push_phone(
    phones: &mut Vec<Phone>,
    p: Phone,
    path: &Path,
    line: usize,
) -> Result<()> {
    p.check_label()
        .and_then(|()| p.check_duration())
        .map_err(|m| FormatError::at_line(path, line, m))?;
    if let Some(prev) = phones.last()
        && p.start < prev.end - 1e-9
    {
        return Err(FormatError::at_line(
            path,
            line,
            format!(
                "phone `{}` starts at {}, before `{}` ends at {} (overlap)",
                shorten(&p.label),
                p.start,
                shorten(&prev.label),
                prev.end
            ),
        ));
    }
    phones.push(p);
    Ok(())
}

/// Parses Festival xlabel text: header up to `#`, then `end color label` lines.
///
/// # Errors
/// As `parse_lab`; an end time earlier than the previous one is reported as such.
pub fn parse_xlabel(text: &str, path: &Path) -> Result<Alignment> {
    let mut phones: Vec<Phone> = Vec::new();
    let mut in_body = false;
    for (i, raw) in text.lines().enumerate() {
        let line = i + 1;
        let trimmed = raw.trim();
        if !in_body {
            in_body = trimmed == "#";
            continue;
        }
        if trimmed.is_empty() {
            continue;
        }
        // Festival appends `; feature=value` fields after the label.
        let body = trimmed.split(';').next().unwrap_or("");
        let mut fields = body.split_whitespace();
        let end_text = fields.next().unwrap_or("");
        let end = match end_text.parse::<f64>() {
            Ok(v) if v.is_finite() && v >= 0.0 => v,
            _ => {
                return Err(FormatError::at_line(
                    path,
                    line,
                    format!("end time `{}` is not a non-negative number", shorten(end_text)),
                ));
            }
        };
        if fields.next().is_none() {
            return Err(FormatError::at_line(
                path,
                line,
                format!("expected `end color label`, found `{}`", shorten(trimmed)),
            ));
        }
        let label = fields.collect::<Vec<_>>().join(" ");
        let start = phones.last().map_or(0.0, |p| p.end);
        if end < start {
            return Err(FormatError::at_line(
                path,
                line,
                format!("end time {end} is before the previous end {start}"),
            ));
        }
        let phone = Phone { start, end, label };
        phone
            .check_label()
            .and_then(|()| phone.check_duration())
            .map_err(|m| FormatError::at_line(path, line, m))?;
        phones.push(phone);
    }
    if phones.is_empty() {
        return Err(FormatError::whole(path, "no labels after the `#` line"));
    }
    Ok(Alignment { phones })
}

/// Reads a `.lab` (HTK or Festival xlabel) file.
///
/// # Errors
/// I/O failures and everything `parse_lab` rejects.
pub fn read_lab(path: &Path) -> Result<Alignment> {
    let bytes = super::input::read_input(path)?;
    parse_lab(&super::textgrid::decode_text(&bytes, path)?, path)
}

/// What formats that refuse an empty label write for a silence (a TextGrid's empty
/// interval); the phone inventory reads it back as a silence.
pub const SILENCE_WORD: &str = "sil";

/// A label as one HTK word: whitespace becomes `_`, and an empty (silence) label
/// [`SILENCE_WORD`].
fn htk_word(label: &str) -> String {
    let w: String = label.trim().chars().map(|c| if c.is_whitespace() { '_' } else { c }).collect();
    if w.is_empty() { SILENCE_WORD.to_string() } else { w }
}

/// HTK `.lab` text: times in 100 ns integer units (exact for times read from such a file).
pub fn format_htk_lab(alignment: &Alignment) -> String {
    let mut s = String::new();
    for p in &alignment.phones {
        let units = |t: f64| (t * HTK_UNITS_PER_SECOND).round() as u64;
        let _ = writeln!(s, "{} {} {}", units(p.start), units(p.end), htk_word(&p.label));
    }
    s
}

/// Festival xlabel text (`#`, then `end 100 label`); starts are implied by the previous end,
/// so a gap before a phone is absorbed into it.
pub fn format_xlabel(alignment: &Alignment) -> String {
    let mut s = String::from("#\n");
    for p in &alignment.phones {
        let _ = writeln!(s, "{} 100 {}", p.end, htk_word(&p.label));
    }
    s
}

/// Writes an alignment as an HTK `.lab` file (100 ns units).
///
/// # Errors
/// I/O failures, naming `path`.
pub fn write_htk_lab(alignment: &Alignment, path: &Path) -> Result<()> {
    super::atomic::write_atomic_bytes(path, format_htk_lab(alignment).as_bytes())
        .map_err(|e| FormatError::io(path, e))
}

/// Writes an alignment as a Festival xlabel file.
///
/// # Errors
/// I/O failures, naming `path`.
pub fn write_xlabel(alignment: &Alignment, path: &Path) -> Result<()> {
    super::atomic::write_atomic_bytes(path, format_xlabel(alignment).as_bytes())
        .map_err(|e| FormatError::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn seconds_when_decimal_or_small() {
        let a = parse_lab("0.0 0.5 sil\n0.5 0.75 b\n", Path::new("a.lab")).unwrap();
        assert_eq!(a.phones[1].end, 0.75);
        let b = parse_lab("0 1 sil\n1 3 b\n", Path::new("a.lab")).unwrap();
        assert_eq!(b.phones[1].end, 3.0);
    }

    #[test]
    fn htk_units_round_trip_exactly() {
        let text = "0 1234567 sil\n1234567 2345678 AA1 -12.5\n";
        let a = parse_lab(text, Path::new("a.lab")).unwrap();
        assert_eq!(a.phones[1].label, "AA1");
        assert_eq!(format_htk_lab(&a), "0 1234567 sil\n1234567 2345678 AA1\n");
    }

    #[test]
    fn overlap_names_line() {
        let e = parse_lab("0 0.5 a\n0.4 0.6 b\n", Path::new("a.lab")).unwrap_err();
        assert_eq!(
            e.to_string(),
            "a.lab:2: phone `b` starts at 0.4, before `a` ends at 0.5 (overlap)"
        );
    }

    #[test]
    fn xlabel_round_trip() {
        let a =
            parse_lab("separator ;\n#\n0.22 100 pau\n0.3127 100 b ; stress=0\n", Path::new("x"))
                .unwrap();
        assert_eq!(a.phones[1], Phone { start: 0.22, end: 0.3127, label: "b".into() });
        assert_eq!(parse_lab(&format_xlabel(&a), Path::new("x")).unwrap(), a);
    }
}
