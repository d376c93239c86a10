//! Phone-alignment formats as one choice: detect a file's format (extension, then content)
//! and read it into an `Alignment`, choosing the TextGrid tier. Start at `read_alignment`.
//!
//! Detection: `.TextGrid` is Praat; `.csv` is `start,end,phone`; `.lab`/`.rec`/`.seg` are HTK
//! or Festival. Other names are sniffed from the decoded text: `File type =` or a first
//! quoted `"ooTextFile"` is a TextGrid, a header with `start` and `end` columns is CSV, a
//! line that is only `#` is Festival xlabel, anything else is tried as HTK.

use super::error::{FormatError, Result};
use super::{htk_lab, phones_csv, textgrid};
use crate::alignment::Alignment;
use std::fmt;
use std::path::Path;
use std::str::FromStr;

pub use super::phones_csv::{format_phones_csv, write_phones_csv};
pub use super::textgrid::TierChoice;

/// A phone-alignment file format.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum AlignmentFormat {
    /// Praat TextGrid (long or short text).
    TextGrid,
    /// HTK `start end label` (100 ns units or seconds).
    HtkLab,
    /// Festival xlabel (`#`, then `end color label`).
    Xlabel,
    /// `start,end,phone` CSV.
    PhonesCsv,
}

impl AlignmentFormat {
    pub const ALL: [AlignmentFormat; 4] =
        [Self::TextGrid, Self::HtkLab, Self::Xlabel, Self::PhonesCsv];

    pub fn name(self) -> &'static str {
        match self {
            Self::TextGrid => "textgrid",
            Self::HtkLab => "lab",
            Self::Xlabel => "xlabel",
            Self::PhonesCsv => "csv",
        }
    }
}

impl fmt::Display for AlignmentFormat {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for AlignmentFormat {
    type Err = String;

    fn from_str(s: &str) -> std::result::Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "textgrid" | "praat" => Ok(Self::TextGrid),
            "lab" | "htk" => Ok(Self::HtkLab),
            "xlabel" | "festival" => Ok(Self::Xlabel),
            "csv" => Ok(Self::PhonesCsv),
            _ => Err(format!("unknown alignment format `{s}` (textgrid, lab, xlabel, csv)")),
        }
    }
}

/// The alignment format of decoded text, judged from content alone.
pub fn detect_text(text: &str) -> AlignmentFormat {
    let text = crate::io::input::without_bom(text);
    let first = text.lines().map(str::trim).find(|l| !l.is_empty()).unwrap_or("");
    if first.starts_with("File type") || first.starts_with("\"ooTextFile") {
        return AlignmentFormat::TextGrid;
    }
    let cols: Vec<&str> = first.split(',').map(str::trim).collect();
    if cols.len() >= 3 && cols.contains(&"start") && cols.contains(&"end") {
        return AlignmentFormat::PhonesCsv;
    }
    if htk_lab::is_xlabel(text) { AlignmentFormat::Xlabel } else { AlignmentFormat::HtkLab }
}

/// Parses alignment bytes of any supported encoding and format (detected from `path`'s
/// extension, then content); `tier` applies to TextGrids only.
///
/// # Errors
/// Encoding and parse errors naming `path` and the line; no matching TextGrid tier.
pub fn parse_alignment(bytes: &[u8], path: &Path, tier: Option<&TierChoice>) -> Result<Alignment> {
    let text = textgrid::decode_text(bytes, path)?;
    let ext = path.extension().map(|e| e.to_string_lossy().to_ascii_lowercase());
    let format = match ext.as_deref() {
        Some("textgrid") => AlignmentFormat::TextGrid,
        Some("csv") => AlignmentFormat::PhonesCsv,
        Some("lab" | "rec" | "seg") if htk_lab::is_xlabel(&text) => AlignmentFormat::Xlabel,
        Some("lab" | "rec" | "seg") => AlignmentFormat::HtkLab,
        _ => detect_text(&text),
    };
    parse_alignment_as(&text, path, format, tier)
}

/// Parses decoded alignment text in a known format.
///
/// # Errors
/// As the format's parser; no matching TextGrid tier.
pub fn parse_alignment_as(
    text: &str,
    path: &Path,
    format: AlignmentFormat,
    tier: Option<&TierChoice>,
) -> Result<Alignment> {
    let alignment = match format {
        AlignmentFormat::TextGrid => {
            textgrid::parse_textgrid_str(text, path)?.alignment(tier, path)
        }
        AlignmentFormat::HtkLab => {
            htk_lab::parse_htk_lab(crate::io::input::without_bom(text), path)
        }
        AlignmentFormat::Xlabel => htk_lab::parse_xlabel(text, path),
        AlignmentFormat::PhonesCsv => phones_csv::parse_phones_csv(text, path),
    }?;
    alignment
        .check_times(crate::alignment::MAX_PHONE_END_S)
        .map_err(|m| FormatError::at_field(path, "phones", m))?;
    Ok(alignment)
}

/// Reads a phone alignment from any supported file; `tier` picks the TextGrid tier (default:
/// the phone tier, see `textgrid::TextGrid::alignment`).
///
/// # Errors
/// I/O failures, parse errors naming file and line, no matching tier.
///
/// # Examples
/// ```no_run
/// use lipmap::io::alignment_format::{read_alignment, TierChoice};
/// let a = read_alignment("s1.TextGrid".as_ref(), Some(&TierChoice::Name("phones".into()))).unwrap();
/// println!("{} phones", a.phones.len());
/// ```
pub fn read_alignment(path: &Path, tier: Option<&TierChoice>) -> Result<Alignment> {
    let bytes = super::input::read_input(path)?;
    parse_alignment(&bytes, path, tier)
}

/// The text of an alignment in `format`.
pub fn format_alignment(alignment: &Alignment, format: AlignmentFormat) -> String {
    match format {
        AlignmentFormat::TextGrid => textgrid::format_textgrid(alignment, "phones"),
        AlignmentFormat::HtkLab => htk_lab::format_htk_lab(alignment),
        AlignmentFormat::Xlabel => htk_lab::format_xlabel(alignment),
        AlignmentFormat::PhonesCsv => phones_csv::format_phones_csv(alignment),
    }
}

/// Writes an alignment in `format`.
///
/// # Errors
/// I/O failures, naming `path`.
pub fn write_alignment(alignment: &Alignment, path: &Path, format: AlignmentFormat) -> Result<()> {
    super::atomic::write_atomic_bytes(path, format_alignment(alignment, format).as_bytes())
        .map_err(|e| FormatError::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sniffs_content() {
        assert_eq!(detect_text("File type = \"ooTextFile\"\n"), AlignmentFormat::TextGrid);
        assert_eq!(detect_text("start, end, phone\n"), AlignmentFormat::PhonesCsv);
        assert_eq!(detect_text("#\n0.2 100 pau\n"), AlignmentFormat::Xlabel);
        assert_eq!(detect_text("0 100000 sil\n"), AlignmentFormat::HtkLab);
    }

    #[test]
    fn every_format_round_trips() {
        use crate::alignment::Phone;
        let a = Alignment {
            phones: vec![
                Phone { start: 0.0, end: 0.125, label: "sil".into() },
                Phone { start: 0.125, end: 0.3, label: "AA1".into() },
            ],
        };
        for f in AlignmentFormat::ALL {
            let text = format_alignment(&a, f);
            assert_eq!(parse_alignment_as(&text, Path::new("x"), f, None).unwrap(), a, "{f}");
            assert_eq!(detect_text(&text), f);
        }
    }
}
