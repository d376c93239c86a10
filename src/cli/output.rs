//! How commands print tables: aligned text (default), CSV blocks, or one JSON document —
//! the `--format`/`--json` choice every tabular command shares.

use crate::eval::Table;
use anyhow::Result;
use std::io::Write;

#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum TableFormat {
    #[default]
    Text,
    Csv,
    Json,
}

/// `--format` / `--json` flags for tabular output.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct FormatArgs {
    /// Output format for tables.
    #[arg(long, value_enum, default_value_t = TableFormat::Text)]
    pub format: TableFormat,
    /// Same as --format json.
    #[arg(long)]
    pub json: bool,
}

impl FormatArgs {
    pub fn format(&self) -> TableFormat {
        if self.json { TableFormat::Json } else { self.format }
    }
}

/// Writes tables in `format`: text tables separated by blank lines; CSV blocks each headed
/// by a `# title` line; JSON as one document keyed by the tables' stable keys
/// ([`json_document`]).
///
/// # Errors
/// A table holding a number that is not finite ([`ensure_figures_finite`]), before anything
/// is written; any error of `out`.
pub fn write_tables(tables: &[&Table], format: TableFormat, out: &mut dyn Write) -> Result<()> {
    ensure_figures_finite(tables)?;
    let mut out = out;
    match format {
        TableFormat::Text => {
            for (i, t) in tables.iter().enumerate() {
                if i > 0 {
                    writeln!(out)?;
                }
                t.write_text(&mut out)?;
            }
        }
        TableFormat::Csv => {
            for (i, t) in tables.iter().enumerate() {
                if i > 0 {
                    writeln!(out)?;
                }
                writeln!(out, "# {}", t.title)?;
                t.write_csv(&mut out)?;
            }
        }
        TableFormat::Json => {
            serde_json::to_writer_pretty(&mut out, &json_document(tables))?;
            writeln!(out)?;
        }
    }
    Ok(())
}

/// Refuses tables with a NaN or an infinity among their numbers: no command prints one as a
/// figure or writes it into an output. A value that does not exist is `Cell::Missing` or
/// `Cell::Empty`; a non-finite number is a fault upstream (a damaged model, a degenerate
/// input), named here by table, row and column so it can be traced.
///
/// # Errors
/// The first non-finite number found.
pub fn ensure_figures_finite(tables: &[&Table]) -> Result<()> {
    for t in tables {
        t.check_finite().map_err(|e| anyhow::anyhow!("{}", terminal_safe(&e.to_string())))?;
    }
    Ok(())
}

/// The JSON document of some tables (docs/json.md): an object with one member per table
/// key ([`Table::key`]). A table is `{"title", "columns", "rows", "notes"}`, its
/// rows objects keyed by column; tables repeated per clip, head or speaker
/// ([`Table::item`]) are an array under their key, each with an `"item"` member. The key,
/// not the title, names a table: titles carry counts and names that change from run to run.
pub fn json_document(tables: &[&Table]) -> serde_json::Value {
    let mut doc = serde_json::Map::new();
    for (i, t) in tables.iter().enumerate() {
        let key = if t.key.is_empty() { format!("table_{}", i + 1) } else { t.key.clone() };
        let mut object = serde_json::Map::new();
        if let Some(item) = &t.item {
            object.insert("item".into(), item.clone().into());
        }
        object.insert("title".into(), t.title.clone().into());
        object.insert("columns".into(), t.headers.clone().into());
        object.insert("rows".into(), t.to_json_records());
        object.insert("notes".into(), t.notes.clone().into());
        let object = serde_json::Value::Object(object);
        if t.item.is_some() {
            match doc.entry(key).or_insert_with(|| serde_json::Value::Array(Vec::new())) {
                serde_json::Value::Array(list) => list.push(object),
                slot => *slot = object,
            }
        } else {
            doc.insert(key, object);
        }
    }
    serde_json::Value::Object(doc)
}

/// Writes `line` and a line break on stderr. A closed stderr (`lipmap fit S 2>&1 | head`)
/// is no more an error than a closed stdout: the line is dropped, where `eprintln!` would
/// panic and end the command with a panic's exit code instead of its own.
pub fn eprint_line(line: impl std::fmt::Display) {
    // Nothing to report a failed write to: stderr is where it would go.
    let _ = writeln!(std::io::stderr().lock(), "{line}");
}

/// `text` with every control character (C0, DEL, C1) and bidirectional override spelt as an escape (`\x1b`, `\n`,
/// `\u{9b}`), so a clip name, phone label or path from a file cannot move the cursor, clear
/// the screen or forge a line on the terminal. Every name the command line prints goes
/// through here (directly, or through [`TerminalSafe`] on stdout).
pub fn terminal_safe(text: &str) -> std::borrow::Cow<'_, str> {
    if !text.chars().any(needs_escape) {
        return std::borrow::Cow::Borrowed(text);
    }
    let mut out = String::with_capacity(text.len() + 8);
    for c in text.chars() {
        push_escaped(&mut out, c);
    }
    std::borrow::Cow::Owned(out)
}

/// Control characters, and the bidirectional overrides and isolates, which reorder what
/// follows them on the line (a name could make a path read backwards).
fn needs_escape(c: char) -> bool {
    c.is_control() || matches!(c, '\u{202a}'..='\u{202e}' | '\u{2066}'..='\u{2069}')
}

fn push_escaped(out: &mut String, c: char) {
    match c {
        '\n' => out.push_str("\\n"),
        '\t' => out.push_str("\\t"),
        '\r' => out.push_str("\\r"),
        c if (c as u32) < 0x80 && c.is_control() => out.push_str(&format!("\\x{:02x}", c as u32)),
        c if needs_escape(c) => out.push_str(&format!("\\u{{{:x}}}", c as u32)),
        c => out.push(c),
    }
}

/// A writer that passes text through [`terminal_safe`] line by line, keeping the line breaks
/// and tabs the command itself writes: every command's stdout goes through one.
pub struct TerminalSafe<W: Write> {
    inner: W,
    /// Bytes of an unfinished UTF-8 character (a write may split one).
    pending: Vec<u8>,
}

impl<W: Write> TerminalSafe<W> {
    pub fn new(inner: W) -> Self {
        Self { inner, pending: Vec::new() }
    }

    fn write_text(&mut self, text: &str) -> std::io::Result<()> {
        let mut out = String::with_capacity(text.len());
        for c in text.chars() {
            if c == '\n' || c == '\t' {
                out.push(c);
            } else {
                push_escaped(&mut out, c);
            }
        }
        self.inner.write_all(out.as_bytes())
    }
}

impl<W: Write> Drop for TerminalSafe<W> {
    fn drop(&mut self) {
        let _ = self.flush();
    }
}

impl<W: Write> Write for TerminalSafe<W> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        self.pending.extend_from_slice(buf);
        let bytes = std::mem::take(&mut self.pending);
        match std::str::from_utf8(&bytes) {
            Ok(text) => self.write_text(text)?,
            Err(e) => {
                let (good, rest) = bytes.split_at(e.valid_up_to());
                self.write_text(std::str::from_utf8(good).unwrap_or_default())?;
                if e.error_len().is_some() {
                    // Not UTF-8 at all: shown lossily rather than sent raw.
                    self.write_text(&String::from_utf8_lossy(rest))?;
                } else {
                    self.pending = rest.to_vec();
                }
            }
        }
        Ok(buf.len())
    }

    fn flush(&mut self) -> std::io::Result<()> {
        if !self.pending.is_empty() {
            let rest = std::mem::take(&mut self.pending);
            self.write_text(&String::from_utf8_lossy(&rest))?;
        }
        self.inner.flush()
    }
}

/// `n` and the noun, plural when `n` is not 1: "1 frame", "2 frames", "0 landmarks".
pub fn plural(n: usize, noun: &str) -> String {
    if n == 1 { format!("{n} {noun}") } else { format!("{n} {noun}s") }
}

/// A reprojection RMS for printing: `—` when there is none (every fit failed), never NaN.
pub fn rms_text(rms_px: Option<f64>) -> String {
    match rms_px {
        Some(v) if v.is_finite() => format!("{v:.2} px"),
        _ => "—".into(),
    }
}

/// Median reprojection RMS of the fits that succeeded (`None` when none did).
pub fn median_reprojection(fits: &[crate::fit::FrameFit]) -> Option<f64> {
    let mut rms: Vec<f64> = fits
        .iter()
        .filter(|f| f.is_usable() && f.reproj_rms_px.is_finite())
        .map(|f| f.reproj_rms_px)
        .collect();
    rms.sort_by(f64::total_cmp);
    rms.get(rms.len() / 2).copied()
}

/// Frame numbers as compact ranges: `0-3, 7, 9-11`.
pub fn frame_ranges(frames: &[usize]) -> String {
    let mut sorted = frames.to_vec();
    sorted.sort_unstable();
    sorted.dedup();
    let mut parts = Vec::new();
    let mut i = 0;
    while i < sorted.len() {
        let mut j = i;
        while j + 1 < sorted.len() && sorted[j + 1] == sorted[j] + 1 {
            j += 1;
        }
        parts.push(if i == j {
            sorted[i].to_string()
        } else {
            format!("{}-{}", sorted[i], sorted[j])
        });
        i = j + 1;
    }
    parts.join(", ")
}

/// One line per distinct failure reason of a clip's fits, each naming its frames, so a reason
/// shared by every frame prints once: `clip: 120 frames failed (0-119): too few …`.
pub fn failure_lines(clip: &str, fits: &[crate::fit::FrameFit]) -> Vec<String> {
    let mut by_reason: Vec<(&str, Vec<usize>)> = Vec::new();
    for f in fits {
        let Some(why) = f.failed.as_deref() else { continue };
        match by_reason.iter_mut().find(|(r, _)| *r == why) {
            Some((_, frames)) => frames.push(f.frame),
            None => by_reason.push((why, vec![f.frame])),
        }
    }
    by_reason
        .into_iter()
        .map(|(why, frames)| {
            let what = if frames.len() == 1 {
                format!("frame {}", frames[0])
            } else {
                format!("{} failed ({})", plural(frames.len(), "frame"), frame_ranges(&frames))
            };
            if frames.len() == 1 {
                format!("{clip}: {what} failed: {why}")
            } else {
                format!("{clip}: {what}: {why}")
            }
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_tables_are_found_by_key_and_nothing_non_finite_is_written() {
        use crate::eval::Cell;
        let mut summary =
            Table::new("Predicted on 12 sentences", vec!["r".into()]).keyed("summary");
        summary.push_row(vec![Cell::Num(0.5)]);
        summary.notes.push("a note".into());
        let a = Table::new("clip a", vec!["P".into()]).keyed("profile").for_item("a");
        let b = Table::new("clip b", vec!["P".into()]).keyed("profile").for_item("b");
        let plain = Table::new("no key", vec![]);
        let doc = json_document(&[&summary, &a, &b, &plain]);
        assert_eq!(doc["summary"]["title"], "Predicted on 12 sentences");
        assert_eq!(doc["summary"]["columns"][0], "r");
        assert_eq!(doc["summary"]["rows"][0]["r"], 0.5);
        assert_eq!(doc["summary"]["notes"][0], "a note");
        assert_eq!(doc["profile"][1]["item"], "b");
        assert_eq!(doc["table_4"]["title"], "no key");
        summary.push_row(vec![Cell::Num(f64::NAN)]);
        let mut out = Vec::new();
        let e = write_tables(&[&summary], TableFormat::Json, &mut out).unwrap_err().to_string();
        assert!(e.contains("row 2, column `r`: NaN is not a figure"), "{e}");
        assert!(out.is_empty());
    }

    #[test]
    fn control_characters_in_names_are_escaped() {
        assert_eq!(terminal_safe("s1 ok"), "s1 ok");
        assert_eq!(terminal_safe("evil\x1b[2J\nfake\u{9b}"), "evil\\x1b[2J\\nfake\\u{9b}");
        assert_eq!(terminal_safe("gpj.\u{202e}exe"), "gpj.\\u{202e}exe");
        let mut buf = Vec::new();
        {
            let mut w = TerminalSafe::new(&mut buf);
            w.write_all(b"clip \x1b[2J\tok\n").unwrap();
            // A C1 control split across two writes is still caught.
            w.write_all(&[0xc2]).unwrap();
            w.write_all(&[0x9b, b'\n']).unwrap();
        }
        assert_eq!(String::from_utf8(buf).unwrap(), "clip \\x1b[2J\tok\n\\u{9b}\n");
    }
    use crate::fit::FrameFit;

    fn fit(frame: usize, failed: Option<&str>, rms: f64) -> FrameFit {
        FrameFit {
            reproj_rms_px: rms,
            failed: failed.map(String::from),
            ..FrameFit::unposed(frame)
        }
    }

    #[test]
    fn plural_and_ranges() {
        assert_eq!(plural(1, "landmark"), "1 landmark");
        assert_eq!(plural(0, "frame"), "0 frames");
        assert_eq!(plural(14, "landmark"), "14 landmarks");
        assert_eq!(frame_ranges(&[9, 0, 1, 2, 3, 7, 10, 11]), "0-3, 7, 9-11");
        assert_eq!(frame_ranges(&[]), "");
    }

    #[test]
    fn all_failed_median_is_a_dash_not_nan() {
        let fits = vec![fit(0, Some("x"), 0.0), fit(1, Some("x"), 0.0)];
        assert_eq!(median_reprojection(&fits), None);
        assert_eq!(rms_text(median_reprojection(&fits)), "—");
        let ok = vec![fit(0, None, 1.0), fit(1, None, 3.0), fit(2, Some("x"), 0.0)];
        assert_eq!(rms_text(median_reprojection(&ok)), "3.00 px");
    }

    #[test]
    fn identical_failures_print_once() {
        let why = "too few usable landmarks (2 of 2)";
        let fits: Vec<FrameFit> = (0..120).map(|i| fit(i, Some(why), 0.0)).collect();
        let lines = failure_lines("c", &fits);
        assert_eq!(lines, [format!("c: 120 frames failed (0-119): {why}")]);
        let one = failure_lines("c", &[fit(4, Some("odd"), 0.0), fit(5, None, 1.0)]);
        assert_eq!(one, ["c: frame 4 failed: odd"]);
    }
}

/// How video and head trajectories are put on one scale (`--normalise`); the clap face of
/// [`crate::workflow::Normalisation`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum)]
pub enum NormaliseArg {
    /// Min–max per sequence, video and head separately (the published method: shapes of
    /// trajectories, so a head of other proportions can still be judged).
    #[default]
    MinMax,
    /// The reference-length ratios as they are (same-person heads, known truth).
    None,
}

impl From<NormaliseArg> for crate::workflow::Normalisation {
    fn from(a: NormaliseArg) -> Self {
        match a {
            NormaliseArg::MinMax => Self::MinMax,
            NormaliseArg::None => Self::None,
        }
    }
}
