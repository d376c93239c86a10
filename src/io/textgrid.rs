//! Praat TextGrid files (long and short text formats; UTF-8 with or without BOM, UTF-16 LE/BE):
//! parse every tier, pick the phone tier, write one back. Start at `parse_textgrid`.
//!
//! Both text formats carry the same values in the same order; the long one merely adds
//! labels (`xmin =`, `intervals [3]:`). As Praat itself does, the reader keeps only numbers,
//! quoted strings (`""` is an escaped quote) and `<flags>`, and skips labels, `[…]` and
//! `!` comments, so one reader handles both. Labels are kept raw (an empty label is a
//! silence: grouping happens later, through `alignment::PhoneInventory`).

use super::error::{FormatError, Location, Result};
use super::pts::shorten;
use crate::alignment::{Alignment, Phone};
use std::fmt::{self, Write as _};
use std::path::Path;
use std::str::FromStr;

/// Which tier of a TextGrid holds the phones.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum TierChoice {
    /// The first interval tier with this name (case-insensitive).
    Name(String),
    /// A 1-based tier number, as Praat's object window numbers them.
    Index(usize),
}

impl FromStr for TierChoice {
    type Err = String;

    /// A whole number picks by (1-based) index, anything else by name.
    fn from_str(s: &str) -> std::result::Result<Self, String> {
        let s = s.trim();
        if s.is_empty() {
            return Err("empty tier name".into());
        }
        Ok(match s.parse::<usize>() {
            Ok(i) => Self::Index(i),
            Err(_) => Self::Name(s.to_string()),
        })
    }
}

impl fmt::Display for TierChoice {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Name(n) => write!(f, "`{n}`"),
            Self::Index(i) => write!(f, "{i}"),
        }
    }
}

/// Tier names taken as the phone tier when none is chosen, in order of preference. MFA
/// writes `phones` (or `SPEAKER - phones` with several speakers).
pub const PHONE_TIER_NAMES: [&str; 4] = ["phones", "phone", "phonemes", "phoneme"];

/// One tier of a TextGrid.
#[derive(Clone, Debug, PartialEq)]
pub struct Tier {
    pub name: String,
    /// 1-based line where the tier starts (for messages).
    pub line: usize,
    pub kind: TierKind,
}

/// An interval tier's intervals, or a point tier's (time, mark) pairs.
#[derive(Clone, Debug, PartialEq)]
pub enum TierKind {
    Intervals(Vec<Phone>),
    Points(Vec<(f64, String)>),
}

/// A parsed TextGrid: its time domain (s) and tiers in file order.
#[derive(Clone, Debug, PartialEq)]
pub struct TextGrid {
    pub xmin: f64,
    pub xmax: f64,
    pub tiers: Vec<Tier>,
}

impl TextGrid {
    /// The alignment of the chosen tier, or of the default phone tier (first named as in
    /// `PHONE_TIER_NAMES`, or ending in ` - phones`; else the only interval tier).
    ///
    /// # Errors
    /// No such tier, a point tier, or no default candidate (the message lists the tiers).
    pub fn alignment(&self, choice: Option<&TierChoice>, path: &Path) -> Result<Alignment> {
        let tier = match choice {
            Some(TierChoice::Index(i)) => self.tiers.get(i.wrapping_sub(1)).ok_or_else(|| {
                FormatError::whole(
                    path,
                    format!(
                        "no tier {i}: the TextGrid has {} tiers ({})",
                        self.tiers.len(),
                        self.tier_list()
                    ),
                )
            })?,
            Some(TierChoice::Name(n)) => self
                .tiers
                .iter()
                .find(|t| t.name.trim().eq_ignore_ascii_case(n.trim()))
                .ok_or_else(|| {
                    FormatError::whole(
                        path,
                        format!("no tier named `{n}` (tiers: {})", self.tier_list()),
                    )
                })?,
            None => self.default_phone_tier().ok_or_else(|| {
                FormatError::whole(
                    path,
                    format!(
                        "no phone tier (tiers: {}); choose one by name or number",
                        self.tier_list()
                    ),
                )
            })?,
        };
        match &tier.kind {
            TierKind::Intervals(phones) => {
                // The phones' own rule; an empty label is a silence here (Praat's way).
                if let Some((k, m)) = phones
                    .iter()
                    .enumerate()
                    .find_map(|(k, p)| p.check_duration().err().map(|m| (k, m)))
                {
                    return Err(FormatError::at_line(
                        path,
                        tier.line,
                        format!("tier `{}`, interval {}: {m}", tier.name, k + 1),
                    ));
                }
                Ok(Alignment { phones: phones.clone() })
            }
            TierKind::Points(_) => Err(FormatError::at_line(
                path,
                tier.line,
                format!("tier `{}` is a point tier, not an interval tier", tier.name),
            )),
        }
    }

    /// A tier named like a phone tier wins even when it is a point tier, so the caller
    /// reports that instead of a vaguer "no phone tier".
    fn default_phone_tier(&self) -> Option<&Tier> {
        let intervals = || self.tiers.iter().filter(|t| matches!(t.kind, TierKind::Intervals(_)));
        for want in PHONE_TIER_NAMES {
            let hit = self.tiers.iter().find(|t| {
                let n = t.name.trim().to_lowercase();
                n == want || n.ends_with(&format!(" - {want}"))
            });
            if hit.is_some() {
                return hit;
            }
        }
        let mut all = intervals();
        match (all.next(), all.next()) {
            (Some(only), None) => Some(only),
            _ => None,
        }
    }

    fn tier_list(&self) -> String {
        if self.tiers.is_empty() {
            return "none".into();
        }
        // A one-line message: a file of thousands of tiers is named by its first few.
        const SHOWN: usize = 10;
        let mut list = self
            .tiers
            .iter()
            .take(SHOWN)
            .enumerate()
            .map(|(i, t)| format!("{} `{}`", i + 1, shorten(&t.name)))
            .collect::<Vec<_>>()
            .join(", ");
        if self.tiers.len() > SHOWN {
            list.push_str(&format!(", … {} in all", self.tiers.len()));
        }
        list
    }
}

/// Decodes a text file: UTF-8 (BOM optional), or UTF-16 LE/BE (with a BOM, or recognised
/// by a zero byte in the first two).
///
/// # Errors
/// Invalid UTF-8 (naming the line) or UTF-16 (naming the byte offset).
pub fn decode_text(bytes: &[u8], path: &Path) -> Result<String> {
    let utf16 = |body: &[u8], little: bool, base: u64| -> Result<String> {
        if !body.len().is_multiple_of(2) {
            return Err(FormatError::new(
                path,
                Location::Offset(base + body.len() as u64 - 1),
                "UTF-16 text with an odd number of bytes",
            ));
        }
        let units = body.chunks_exact(2).map(|c| {
            if little { u16::from_le_bytes([c[0], c[1]]) } else { u16::from_be_bytes([c[0], c[1]]) }
        });
        let mut out = String::with_capacity(body.len() / 2);
        for (i, ch) in char::decode_utf16(units).enumerate() {
            match ch {
                Ok(c) => out.push(c),
                Err(_) => {
                    return Err(FormatError::new(
                        path,
                        Location::Offset(base + 2 * i as u64),
                        "invalid UTF-16 (unpaired surrogate)",
                    ));
                }
            }
        }
        Ok(out)
    };
    match bytes {
        [0xEF, 0xBB, 0xBF, rest @ ..] => utf8(rest, path),
        [0xFF, 0xFE, rest @ ..] => utf16(rest, true, 2),
        [0xFE, 0xFF, rest @ ..] => utf16(rest, false, 2),
        [a, 0, ..] if *a != 0 => utf16(bytes, true, 0),
        [0, b, ..] if *b != 0 => utf16(bytes, false, 0),
        _ => utf8(bytes, path),
    }
}

fn utf8(bytes: &[u8], path: &Path) -> Result<String> {
    match std::str::from_utf8(bytes) {
        Ok(s) => Ok(s.to_string()),
        Err(e) => {
            let line = 1 + bytes[..e.valid_up_to()].iter().filter(|&&b| b == b'\n').count();
            Err(FormatError::at_line(path, line, "text is neither UTF-8 nor UTF-16"))
        }
    }
}

#[derive(Debug)]
enum Tok {
    Num(f64, String),
    Str(String),
    Flag(String),
}

impl Tok {
    fn describe(&self) -> String {
        match self {
            Tok::Num(_, raw) => format!("number {raw}"),
            Tok::Str(s) => format!("string \"{}\"", shorten(s)),
            Tok::Flag(f) => format!("<{}>", shorten(f)),
        }
    }
}

/// Splits TextGrid text into numbers, strings and flags, with 1-based line numbers.
struct Lexer<'a> {
    text: &'a str,
    pos: usize,
    line: usize,
    path: &'a Path,
}

impl Lexer<'_> {
    fn next(&mut self) -> Result<Option<(Tok, usize)>> {
        let bytes = self.text.as_bytes();
        let mut after_equals = false;
        loop {
            let Some(&b) = bytes.get(self.pos) else { return Ok(None) };
            match b {
                b'\n' => {
                    self.line += 1;
                    self.pos += 1;
                }
                b if b.is_ascii_whitespace() => self.pos += 1,
                b'!' => {
                    self.pos =
                        self.text[self.pos..].find('\n').map_or(self.text.len(), |i| self.pos + i);
                }
                b'"' => {
                    let start_line = self.line;
                    let mut s = String::new();
                    let mut i = self.pos + 1;
                    loop {
                        let Some(off) = self.text[i..].find('"') else {
                            return Err(FormatError::at_line(
                                self.path,
                                start_line,
                                "string never closes",
                            ));
                        };
                        s.push_str(&self.text[i..i + off]);
                        i += off + 1;
                        if bytes.get(i) == Some(&b'"') {
                            s.push('"');
                            i += 1;
                        } else {
                            break;
                        }
                    }
                    self.line += self.text[self.pos..i].matches('\n').count();
                    self.pos = i;
                    return Ok(Some((Tok::Str(s), start_line)));
                }
                b'<' => {
                    let rest = &self.text[self.pos..];
                    let end = rest.find(['>', '\n']).filter(|&e| rest.as_bytes()[e] == b'>');
                    let Some(end) = end else {
                        return Err(FormatError::at_line(self.path, self.line, "`<` without `>`"));
                    };
                    self.pos += end + 1;
                    return Ok(Some((Tok::Flag(rest[1..end].to_string()), self.line)));
                }
                b'[' => {
                    let rest = &self.text[self.pos..];
                    let end = rest.find([']', '\n']).filter(|&e| rest.as_bytes()[e] == b']');
                    let Some(end) = end else {
                        return Err(FormatError::at_line(self.path, self.line, "`[` without `]`"));
                    };
                    self.pos += end + 1;
                }
                _ => {
                    let rest = &self.text[self.pos..];
                    // Unicode whitespace (vertical tab, NBSP, U+2028…) separates words too; it
                    // must be skipped here or the word below would be empty and never advance
                    // (an endless loop found by fuzzing).
                    if let Some(c) = rest.chars().next().filter(|c| c.is_whitespace()) {
                        self.pos += c.len_utf8();
                        continue;
                    }
                    let end = rest
                        .find(|c: char| c.is_whitespace() || c == '"' || c == '<' || c == '!')
                        .unwrap_or(rest.len());
                    let word = &rest[..end];
                    self.pos += end;
                    if let Ok(v) = word.parse::<f64>() {
                        if !v.is_finite() {
                            return Err(FormatError::at_line(
                                self.path,
                                self.line,
                                format!("`{}` is not a finite number", shorten(word)),
                            ));
                        }
                        return Ok(Some((Tok::Num(v, word.to_string()), self.line)));
                    }
                    if after_equals {
                        return Err(FormatError::at_line(
                            self.path,
                            self.line,
                            format!("`{}` is not a number", shorten(word)),
                        ));
                    }
                    after_equals = word.ends_with('=');
                }
            }
        }
    }
}

struct Parser<'a> {
    lex: Lexer<'a>,
    last_line: usize,
}

impl Parser<'_> {
    fn err(&self, line: usize, msg: impl Into<String>) -> FormatError {
        FormatError::at_line(self.lex.path, line, msg)
    }

    fn next(&mut self, what: &str) -> Result<(Tok, usize)> {
        match self.lex.next()? {
            Some((t, line)) => {
                self.last_line = line;
                Ok((t, line))
            }
            None => Err(self.err(self.lex.line, format!("file ends where {what} was expected"))),
        }
    }

    fn num(&mut self, what: &str) -> Result<(f64, usize)> {
        match self.next(what)? {
            (Tok::Num(v, _), line) => Ok((v, line)),
            (t, line) => Err(self.err(line, format!("expected {what}, found {}", t.describe()))),
        }
    }

    fn count(&mut self, what: &str) -> Result<(usize, usize)> {
        match self.next(what)? {
            (Tok::Num(v, raw), line) => {
                if v >= 0.0 && v.fract() == 0.0 && v < 1e12 {
                    Ok((v as usize, line))
                } else {
                    Err(self.err(
                        line,
                        format!("{what} must be a whole number, found {}", shorten(&raw)),
                    ))
                }
            }
            (t, line) => Err(self.err(line, format!("expected {what}, found {}", t.describe()))),
        }
    }

    fn string(&mut self, what: &str) -> Result<(String, usize)> {
        match self.next(what)? {
            (Tok::Str(s), line) => Ok((s, line)),
            (t, line) => Err(self.err(line, format!("expected {what}, found {}", t.describe()))),
        }
    }
}

const BINARY_MESSAGE: &str = "binary TextGrids are not supported; save as text file";

/// Parses TextGrid bytes (any supported encoding) into all its tiers.
///
/// # Errors
/// Not a text TextGrid, a value of the wrong kind, a count that runs past the end of the
/// file, an interval ending before it starts, or overlapping intervals, naming the line.
///
/// # Examples
/// ```
/// # use std::path::Path;
/// let short = "File type = \"ooTextFile\"\nObject class = \"TextGrid\"\n\n0\n1\n<exists>\n1\n\
///              \"IntervalTier\"\n\"phones\"\n0\n1\n2\n0\n0.4\n\"\"\n0.4\n1\n\"AA1\"\n";
/// let grid = lipmap::io::textgrid::parse_textgrid(short.as_bytes(), Path::new("a.TextGrid")).unwrap();
/// let a = grid.alignment(None, Path::new("a.TextGrid")).unwrap();
/// assert_eq!(a.phones[1].label, "AA1");
/// ```
pub fn parse_textgrid(bytes: &[u8], path: &Path) -> Result<TextGrid> {
    if bytes.starts_with(b"ooBinaryFile") {
        return Err(FormatError::at_line(path, 1, BINARY_MESSAGE));
    }
    let text = decode_text(bytes, path)?;
    parse_textgrid_str(&text, path)
}

/// Parses already-decoded TextGrid text (see `parse_textgrid`).
///
/// # Errors
/// As `parse_textgrid`.
pub fn parse_textgrid_str(text: &str, path: &Path) -> Result<TextGrid> {
    let text = crate::io::input::without_bom(text);
    if text.starts_with("ooBinaryFile") {
        return Err(FormatError::at_line(path, 1, BINARY_MESSAGE));
    }
    if text.trim_start().starts_with("\"Praat chronological TextGrid") {
        return Err(FormatError::at_line(
            path,
            1,
            "chronological TextGrids are not supported; save as text file",
        ));
    }
    let mut p = Parser { lex: Lexer { text, pos: 0, line: 1, path }, last_line: 1 };
    let (file_type, line) = p.string("the file type \"ooTextFile\"")?;
    if !file_type.starts_with("ooTextFile") {
        let msg = if file_type.starts_with("ooBinaryFile") {
            BINARY_MESSAGE.to_string()
        } else {
            format!("file type is \"{}\", expected \"ooTextFile\"", shorten(&file_type))
        };
        return Err(p.err(line, msg));
    }
    let (class, line) = p.string("the object class \"TextGrid\"")?;
    if class != "TextGrid" {
        return Err(
            p.err(line, format!("object class is \"{}\", expected \"TextGrid\"", shorten(&class)))
        );
    }
    let (xmin, _) = p.num("the TextGrid's xmin")?;
    let (xmax, line) = p.num("the TextGrid's xmax")?;
    if xmax < xmin {
        return Err(p.err(line, format!("TextGrid ends ({xmax}) before it starts ({xmin})")));
    }
    let (flag, line) = p.next("<exists> or <absent>")?;
    let n_tiers = match flag {
        Tok::Flag(f) if f == "exists" => p.count("the number of tiers")?.0,
        Tok::Flag(f) if f == "absent" => 0,
        t => {
            return Err(
                p.err(line, format!("expected <exists> or <absent>, found {}", t.describe()))
            );
        }
    };
    let mut tiers = Vec::new();
    for tier_no in 1..=n_tiers {
        let what = format!("the class of tier {tier_no}");
        let (class, tier_line) = p.string(&what)?;
        let (name, _) = p.string(&format!("the name of tier {tier_no}"))?;
        p.num(&format!("the xmin of tier `{name}`"))?;
        p.num(&format!("the xmax of tier `{name}`"))?;
        let (n, _) = p.count(&format!("the size of tier `{name}`"))?;
        let kind = match class.as_str() {
            "IntervalTier" => TierKind::Intervals(read_intervals(&mut p, &name, n)?),
            "TextTier" | "PointTier" => {
                let mut points = Vec::new();
                for k in 1..=n {
                    let (t, _) = p.num(&format!("the time of point {k} of tier `{name}`"))?;
                    let (mark, _) = p.string(&format!("the mark of point {k} of tier `{name}`"))?;
                    points.push((t, mark));
                }
                TierKind::Points(points)
            }
            other => {
                return Err(p.err(
                    tier_line,
                    format!(
                        "tier class is \"{}\", expected \"IntervalTier\" or \"TextTier\"",
                        shorten(other)
                    ),
                ));
            }
        };
        tiers.push(Tier { name, line: tier_line, kind });
    }
    Ok(TextGrid { xmin, xmax, tiers })
}

/// Reads `n` intervals, checking each ends after it starts and none overlaps the previous.
fn read_intervals(p: &mut Parser<'_>, name: &str, n: usize) -> Result<Vec<Phone>> {
    let mut phones: Vec<Phone> = Vec::new();
    for k in 1..=n {
        let (start, line) = p.num(&format!("the xmin of interval {k} of tier `{name}`"))?;
        let (end, _) = p.num(&format!("the xmax of interval {k} of tier `{name}`"))?;
        let (label, _) = p.string(&format!("the text of interval {k} of tier `{name}`"))?;
        if end < start {
            return Err(p.err(
                line,
                format!("interval {k} of tier `{name}` ends ({end}) before it starts ({start})"),
            ));
        }
        if let Some(prev) = phones.last()
            && start < prev.end - 1e-9
        {
            return Err(p.err(
                line,
                format!(
                    "interval {k} of tier `{name}` starts at {start}, before interval {} ends at {} (overlap)",
                    k - 1,
                    prev.end
                ),
            ));
        }
        phones.push(Phone { start, end, label });
    }
    Ok(phones)
}

/// Reads a TextGrid file and returns the chosen (or default phone) tier as an alignment.
///
/// # Errors
/// I/O failures, parse errors, or no matching tier.
pub fn read_textgrid(path: &Path, tier: Option<&TierChoice>) -> Result<Alignment> {
    let bytes = super::input::read_input(path)?;
    parse_textgrid(&bytes, path)?.alignment(tier, path)
}

fn quote(s: &str) -> String {
    format!("\"{}\"", s.replace('"', "\"\""))
}

/// The long-format TextGrid text of an alignment as one interval tier `tier_name`. The grid
/// starts at 0 (or the first phone, if earlier) and ends at the last phone; gaps between
/// phones are written as they are, like praatio does, so a read gives the same phones back.
pub fn format_textgrid(alignment: &Alignment, tier_name: &str) -> String {
    let first = alignment.phones.first().map_or(0.0, |p| p.start);
    let xmin = first.min(0.0);
    let xmax = alignment.duration().max(xmin);
    let mut s = String::new();
    let _ = write!(
        s,
        "File type = \"ooTextFile\"\nObject class = \"TextGrid\"\n\nxmin = {xmin}\nxmax = {xmax}\n\
         tiers? <exists>\nsize = 1\nitem []:\n    item [1]:\n        class = \"IntervalTier\"\n\
         \x20       name = {}\n        xmin = {first}\n        xmax = {xmax}\n        intervals: size = {}\n",
        quote(tier_name),
        alignment.phones.len()
    );
    for (i, p) in alignment.phones.iter().enumerate() {
        let _ = write!(
            s,
            "        intervals [{}]:\n            xmin = {}\n            xmax = {}\n            text = {}\n",
            i + 1,
            p.start,
            p.end,
            quote(&p.label)
        );
    }
    s
}

/// Writes an alignment as a long-format UTF-8 TextGrid with one tier `phones`.
///
/// # Errors
/// I/O failures, naming `path`.
pub fn write_textgrid(alignment: &Alignment, path: &Path) -> Result<()> {
    super::atomic::write_atomic_bytes(path, format_textgrid(alignment, "phones").as_bytes())
        .map_err(|e| FormatError::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn sample() -> Alignment {
        Alignment {
            phones: vec![
                Phone { start: 0.0, end: 0.1, label: String::new() },
                Phone { start: 0.1, end: 0.25, label: "say \"hi\"".into() },
                Phone { start: 0.25, end: 1.0 / 3.0, label: "ɪ".into() },
            ],
        }
    }

    #[test]
    fn a_grid_of_many_tiers_is_named_in_one_short_line() {
        let tier = |i: usize| Tier {
            name: format!("p{i}"),
            line: i,
            kind: TierKind::Intervals(sample().phones),
        };
        let grid = TextGrid { xmin: 0.0, xmax: 1.0, tiers: (0..5000).map(tier).collect() };
        let e = grid.alignment(None, Path::new("t")).unwrap_err().to_string();
        assert!(e.contains("1 `p0`") && e.contains("5000 in all") && e.len() < 300, "{e}");
    }

    #[test]
    fn long_format_round_trips() {
        let text = format_textgrid(&sample(), "phones");
        let grid = parse_textgrid(text.as_bytes(), Path::new("t")).unwrap();
        assert_eq!(grid.alignment(None, Path::new("t")).unwrap(), sample());
    }

    #[test]
    fn utf16_both_byte_orders() {
        let text = format_textgrid(&sample(), "phones");
        for little in [true, false] {
            let mut bytes = if little { vec![0xFF, 0xFE] } else { vec![0xFE, 0xFF] };
            for u in text.encode_utf16() {
                bytes.extend(if little { u.to_le_bytes() } else { u.to_be_bytes() });
            }
            let grid = parse_textgrid(&bytes, Path::new("t")).unwrap();
            assert_eq!(
                grid.alignment(Some(&TierChoice::Index(1)), Path::new("t")).unwrap(),
                sample()
            );
        }
    }

    #[test]
    fn overlap_is_an_error_with_line() {
        let text = format_textgrid(&sample(), "phones").replacen("xmin = 0.25", "xmin = 0.2", 1);
        let e = parse_textgrid(text.as_bytes(), Path::new("t")).unwrap_err();
        assert_eq!(
            e.to_string(),
            "t:24: interval 3 of tier `phones` starts at 0.2, before interval 2 ends at 0.25 (overlap)"
        );
    }

    /// Fuzzing found these: a vertical tab (or any non-ASCII whitespace) outside a string
    /// made the lexer loop forever.
    #[test]
    fn unicode_whitespace_does_not_hang() {
        for ws in ["\u{b}", "\u{a0}", "\u{2028}", "\u{3000}"] {
            let text = format!(
                "File type = \"ooTextFile\"{ws}Object class = \"TextGrid\"{ws}0 1 <absent>"
            );
            let grid = parse_textgrid(text.as_bytes(), Path::new("t")).unwrap();
            assert!(grid.tiers.is_empty());
        }
        let fuzz_found = b"\0ar\x0b\0\0\0\0\0\0\0d,";
        assert!(parse_textgrid(fuzz_found, Path::new("t")).is_err());
        let e = parse_textgrid(b"# phoneme(IPA\x0b\x0b\x0b\n", Path::new("t")).unwrap_err();
        assert_eq!(e.to_string(), "t:2: file ends where the file type \"ooTextFile\" was expected");
    }

    #[test]
    fn tier_choice_parses() {
        assert_eq!("2".parse::<TierChoice>(), Ok(TierChoice::Index(2)));
        assert_eq!("words".parse::<TierChoice>(), Ok(TierChoice::Name("words".into())));
    }
}
