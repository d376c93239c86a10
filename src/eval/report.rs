//! The one generic [`Table`] (title, headers, rows of typed cells, notes) that the CLI prints
//! and the TUI draws, its writers (aligned text, CSV, JSON to any `impl Write`), and builders
//! turning evaluation and facial-index results into tables.

use super::rmse::GroupRmse;
use super::visemes::VisemeTable;
use super::worst::{WorstFit, WorstFrame};
use super::{PerMeasure, Utterance, rmse::sentence_rmse, stats};
use crate::measure::indices::{BoundsTable, FacialIndex, FacialIndices, MatchVerdict};
use crate::measure::{Measure, PoseComparison};
use serde::ser::{Serialize, SerializeMap, Serializer};
use std::io::{self, Write};

/// One table cell. Numbers keep their full value; formatting happens when writing.
#[derive(Clone, Debug, PartialEq)]
pub enum Cell {
    /// No value (a missing measure, a test that could not run): blank in text, empty in
    /// CSV, `null` in JSON.
    Empty,
    /// A number that does not exist (a failed fit's reprojection RMS): `—` in text, empty in
    /// CSV, `null` in JSON, so it cannot be read as a real 0.
    Missing,
    Text(String),
    Int(i64),
    Num(f64),
}

impl Cell {
    /// A number cell, or `Empty` for `None` and non-finite values.
    pub fn num(v: Option<f64>) -> Self {
        match v {
            Some(v) if v.is_finite() => Cell::Num(v),
            _ => Cell::Empty,
        }
    }

    /// A text cell.
    pub fn text(s: impl Into<String>) -> Self {
        Cell::Text(s.into())
    }

    /// The cell as text with `precision` decimals for real numbers (`""` when empty).
    pub fn display(&self, precision: usize) -> String {
        match self {
            Cell::Empty => String::new(),
            Cell::Missing => "—".into(),
            Cell::Text(s) => s.clone(),
            Cell::Int(i) => i.to_string(),
            Cell::Num(v) => format!("{v:.precision$}"),
        }
    }

    /// Whether the cell is right-aligned in text (numbers are).
    pub fn is_numeric(&self) -> bool {
        matches!(self, Cell::Int(_) | Cell::Num(_))
    }
}

impl Serialize for Cell {
    fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Cell::Empty | Cell::Missing => s.serialize_none(),
            Cell::Text(t) => s.serialize_str(t),
            Cell::Int(i) => s.serialize_i64(*i),
            Cell::Num(v) if v.is_finite() => s.serialize_f64(*v),
            Cell::Num(_) => s.serialize_none(),
        }
    }
}

/// A table: what every report in lipmap is, whatever renders it.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Table {
    /// The table's stable name (`sentences`, `summary`, …): what machine-readable output
    /// files it under, where `title` is for people and may carry counts and names.
    pub key: String,
    /// For a table repeated per clip, head or speaker: which one. Machine-readable output
    /// lists such tables under their key, each naming its item.
    pub item: Option<String>,
    pub title: String,
    pub headers: Vec<String>,
    /// Rows of `headers.len()` cells (shorter rows are padded with `Empty` when written).
    pub rows: Vec<Vec<Cell>>,
    /// Lines printed under the table (legend, warnings, test details).
    pub notes: Vec<String>,
    /// Decimals for real numbers in text output (CSV and JSON keep full precision).
    #[serde(skip)]
    pub precision: usize,
    /// Column headings for people where they differ from `headers` (`mouth weight ω_m` for
    /// `omega_m`): text output and the TUI show these, CSV and JSON keep `headers` as keys.
    #[serde(skip)]
    pub labels: Vec<(String, String)>,
}

impl Table {
    /// An empty table with headers and 3-decimal text output.
    pub fn new(title: impl Into<String>, headers: Vec<String>) -> Self {
        Self {
            key: String::new(),
            item: None,
            title: title.into(),
            headers,
            rows: Vec::new(),
            notes: Vec::new(),
            precision: 3,
            labels: Vec::new(),
        }
    }

    /// The table with column `header` shown to people as `label` (machine formats keep
    /// `header`).
    #[must_use]
    pub fn labelled(mut self, header: &str, label: &str) -> Self {
        self.labels.push((header.to_string(), label.to_string()));
        self
    }

    /// Column `c`'s heading as people read it: its label, else its header.
    pub fn heading(&self, c: usize) -> &str {
        let h = self.headers.get(c).map_or("", String::as_str);
        self.labels.iter().find(|(k, _)| k == h).map_or(h, |(_, l)| l.as_str())
    }

    /// Every column's heading as people read it ([`Table::heading`]).
    pub fn headings(&self) -> Vec<String> {
        (0..self.headers.len()).map(|c| self.heading(c).to_string()).collect()
    }

    /// The table with its stable key ([`Table::key`]).
    #[must_use]
    pub fn keyed(mut self, key: &str) -> Self {
        self.key = key.to_string();
        self
    }

    /// The table as one of a repeated kind, for `item` ([`Table::item`]).
    #[must_use]
    pub fn for_item(mut self, item: impl Into<String>) -> Self {
        self.item = Some(item.into());
        self
    }

    /// Appends a row.
    pub fn push_row(&mut self, row: Vec<Cell>) {
        self.rows.push(row);
    }

    /// Names what the table compared in its title (`conditions`, e.g. the landmark set, the
    /// normalisation and the pose comparison, [`crate::workflow::EvalConditions`]) and, when
    /// `pose` is given, the pose comparison W and H were made under in every W or H column
    /// header (`RMSE W [image plane]`), so no table, CSV column or chart built from it can be
    /// read as another comparison.
    pub fn name_conditions(&mut self, conditions: &str, pose: Option<PoseComparison>) {
        if !conditions.is_empty() {
            self.title = format!("{} — {conditions}", self.title);
        }
        let Some(pose) = pose else { return };
        let label = pose.short_label();
        for h in &mut self.headers {
            let names_wh = [Measure::W, Measure::H].iter().any(|m| {
                let m = m.as_str();
                h == m || h.ends_with(&format!(" {m}"))
            });
            if names_wh {
                *h = format!("{h} [{label}]");
            }
        }
    }

    /// Refuses a number cell that is NaN or ±inf (a computation gone wrong): no writer
    /// prints one as a figure. [`Cell::num`] makes such values empty; this catches the
    /// `Cell::Num` built directly.
    ///
    /// # Errors
    /// `InvalidData` naming the table, row and column.
    pub fn check_finite(&self) -> io::Result<()> {
        for (r, row) in self.rows.iter().enumerate() {
            for (c, cell) in row.iter().enumerate() {
                if let Cell::Num(v) = cell
                    && !v.is_finite()
                {
                    let column = self.headers.get(c).map_or("?", String::as_str);
                    return Err(io::Error::new(
                        io::ErrorKind::InvalidData,
                        format!(
                            "`{}`, row {}, column `{column}`: {v} is not a figure (a damaged \
                             model or a degenerate input upstream); nothing written",
                            self.title,
                            r + 1
                        ),
                    ));
                }
            }
        }
        Ok(())
    }

    fn cell(&self, r: usize, c: usize) -> &Cell {
        self.rows[r].get(c).unwrap_or(&Cell::Empty)
    }

    /// Every row's cells as display strings (`precision` decimals), padded to the header
    /// count: what a TUI table widget needs.
    pub fn formatted_rows(&self) -> Vec<Vec<String>> {
        (0..self.rows.len())
            .map(|r| {
                (0..self.headers.len()).map(|c| self.cell(r, c).display(self.precision)).collect()
            })
            .collect()
    }

    /// Per column: whether it holds numbers (right-aligned) rather than text.
    pub fn numeric_columns(&self) -> Vec<bool> {
        (0..self.headers.len())
            .map(|c| {
                let mut cells = (0..self.rows.len()).map(|r| self.cell(r, c));
                cells.clone().any(Cell::is_numeric)
                    && cells.all(|x| x.is_numeric() || matches!(x, Cell::Empty | Cell::Missing))
            })
            .collect()
    }

    /// Writes the table as aligned text: title, header, a rule, rows, then notes.
    /// Numbers are right-aligned, text left-aligned; widths count characters.
    ///
    /// # Errors
    /// Any error of the writer; a non-finite number ([`Table::check_finite`]).
    pub fn write_text(&self, w: &mut impl Write) -> io::Result<()> {
        self.check_finite()?;
        let rows = self.formatted_rows();
        let numeric = self.numeric_columns();
        let widths: Vec<usize> = (0..self.headers.len())
            .map(|c| {
                rows.iter()
                    .map(|r| r[c].chars().count())
                    .chain(std::iter::once(self.heading(c).chars().count()))
                    .max()
                    .unwrap_or(0)
            })
            .collect();
        let line = |w: &mut dyn Write, cells: &[String]| -> io::Result<()> {
            let mut out = String::new();
            for (c, s) in cells.iter().enumerate() {
                if c > 0 {
                    out.push_str("  ");
                }
                let pad = " ".repeat(widths[c] - s.chars().count());
                if numeric[c] {
                    out.push_str(&pad);
                    out.push_str(s);
                } else {
                    out.push_str(s);
                    out.push_str(&pad);
                }
            }
            writeln!(w, "{}", out.trim_end())
        };
        if !self.title.is_empty() {
            writeln!(w, "{}", self.title)?;
        }
        line(w, &self.headings())?;
        let total = widths.iter().sum::<usize>() + 2 * widths.len().saturating_sub(1);
        writeln!(w, "{}", "-".repeat(total))?;
        for r in &rows {
            line(w, r)?;
        }
        for n in &self.notes {
            writeln!(w, "{n}")?;
        }
        Ok(())
    }

    /// The aligned text as a string.
    pub fn to_text(&self) -> String {
        let mut buf = Vec::new();
        // Writing to a Vec fails only on a non-finite number, which is then what is shown.
        match self.write_text(&mut buf) {
            Ok(()) => String::from_utf8_lossy(&buf).into_owned(),
            Err(e) => e.to_string(),
        }
    }

    /// Writes the header and rows as CSV (numbers at full precision, empty cells empty);
    /// title and notes are left out so the file loads as plain data.
    ///
    /// # Errors
    /// Any error of the writer; a non-finite number ([`Table::check_finite`]).
    pub fn write_csv(&self, w: &mut impl Write) -> io::Result<()> {
        self.check_finite()?;
        let mut csv = csv::Writer::from_writer(w);
        csv.write_record(&self.headers).map_err(io::Error::other)?;
        for r in 0..self.rows.len() {
            let rec: Vec<String> = (0..self.headers.len())
                .map(|c| match self.cell(r, c) {
                    Cell::Num(v) if v.is_finite() => v.to_string(),
                    Cell::Missing => String::new(),
                    other => other.display(0),
                })
                .collect();
            csv.write_record(&rec).map_err(io::Error::other)?;
        }
        csv.flush()
    }

    /// Writes `{"title", "headers", "rows": [[…]], "notes"}` as pretty JSON; numbers are
    /// numbers, empty cells `null`.
    ///
    /// # Errors
    /// Any error of the writer; a non-finite number ([`Table::check_finite`]).
    pub fn write_json(&self, w: &mut impl Write) -> io::Result<()> {
        self.check_finite()?;
        serde_json::to_writer_pretty(&mut *w, self).map_err(io::Error::other)?;
        writeln!(w)
    }

    /// The rows as JSON objects keyed by header, for consumers that prefer records.
    pub fn to_json_records(&self) -> serde_json::Value {
        struct Rec<'a>(&'a Table, usize);
        impl Serialize for Rec<'_> {
            fn serialize<S: Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
                let mut m = s.serialize_map(Some(self.0.headers.len()))?;
                for (c, h) in self.0.headers.iter().enumerate() {
                    m.serialize_entry(h, self.0.cell(self.1, c))?;
                }
                m.end()
            }
        }
        let recs: Vec<Rec> = (0..self.rows.len()).map(|r| Rec(self, r)).collect();
        serde_json::to_value(recs).unwrap_or(serde_json::Value::Null)
    }
}

/// Which measures a table can compare: P only when some clip's video carries it (every
/// column compares video with head, so a head's P alone fills nothing).
fn measures_present(has_p: bool) -> Vec<Measure> {
    Measure::ALL.into_iter().filter(|m| *m != Measure::P || has_p).collect()
}

/// One sentence's row of the per-sentence table: RMSE, Pearson r and variance-normalised
/// MSE of W, H and P (the table keeps the columns some row can fill).
#[derive(Clone, Debug, PartialEq)]
pub struct SentenceRow {
    pub name: String,
    /// RMSE, r and NMSE, each of W, H, P.
    pub values: [PerMeasure; 3],
    /// Whether the video carries P.
    pub video_has_p: bool,
}

impl SentenceRow {
    /// The row of `u` (as compared: normalised or not).
    pub fn of(u: &Utterance) -> Self {
        let (v, h) = (&u.video, &u.head);
        Self {
            name: u.name.clone(),
            values: [
                sentence_rmse(u),
                PerMeasure::from_fn(|m| stats::pearson(v.series(m), h.series(m))),
                PerMeasure::from_fn(|m| stats::normalised_mse(v.series(m), h.series(m))),
            ],
            video_has_p: v.has_p(),
        }
    }
}

fn per_measure_cells(v: &PerMeasure, measures: &[Measure]) -> Vec<Cell> {
    measures.iter().map(|m| Cell::num(v.get(*m))).collect()
}

/// Per-sentence table: RMSE, Pearson r and variance-normalised MSE of W, H (and P), one
/// row per utterance and a final mean row.
pub fn sentence_table(utterances: &[Utterance]) -> Table {
    let rows: Vec<SentenceRow> = utterances.iter().map(SentenceRow::of).collect();
    sentence_table_of(&rows)
}

/// [`sentence_table`] of rows made with [`SentenceRow::of`].
pub fn sentence_table_of(rows: &[SentenceRow]) -> Table {
    let measures = measures_present(rows.iter().any(|r| r.video_has_p));
    let mut headers = vec!["sentence".to_string()];
    for kind in ["RMSE", "r", "NMSE"] {
        headers.extend(measures.iter().map(|m| format!("{kind} {m}")));
    }
    let mut t = Table::new("RMSE per sentence (video vs head)", headers);
    let mut sums: Vec<Vec<Option<f64>>> = vec![Vec::new(); 3 * measures.len()];
    for r in rows {
        let mut row = vec![Cell::text(&r.name)];
        let values: Vec<Option<f64>> =
            r.values.iter().flat_map(|v| measures.iter().map(|m| v.get(*m))).collect();
        for (k, v) in values.iter().enumerate() {
            sums[k].push(*v);
            row.push(Cell::num(*v));
        }
        t.push_row(row);
    }
    let mut mean = vec![Cell::text("mean")];
    mean.extend(sums.into_iter().map(|s| Cell::num(super::mean_of(s))));
    t.push_row(mean);
    t
}

/// Per-phoneme or per-viseme table from [`GroupRmse`] rows: label, occurrences, RMSE of each
/// measure. With a viseme table, a description column is added.
pub fn group_table(title: &str, groups: &[GroupRmse], visemes: Option<&VisemeTable>) -> Table {
    let has_p = groups.iter().any(|g| g.rmse.p.is_some());
    let measures: Vec<Measure> =
        Measure::ALL.into_iter().filter(|m| *m != Measure::P || has_p).collect();
    let mut headers = vec![if visemes.is_some() { "viseme" } else { "phone" }.to_string()];
    if visemes.is_some() {
        headers.push("description".into());
    }
    headers.push("n".into());
    headers.extend(measures.iter().map(|m| format!("RMSE {m}")));
    let mut t = Table::new(title, headers);
    for g in groups {
        let mut row = vec![Cell::text(&g.label)];
        if let Some(v) = visemes {
            row.push(Cell::text(v.description(&g.label).unwrap_or("not in table")));
        }
        row.push(Cell::Int(g.occurrences as i64));
        row.extend(per_measure_cells(&g.rmse, &measures));
        t.push_row(row);
    }
    t
}

/// The worst frames by measure error.
pub fn worst_error_table(frames: &[WorstFrame]) -> Table {
    let headers = ["rank", "sentence", "frame", "measure", "phone", "video", "head", "error"];
    let mut t = Table::new("worst frames by measure error", headers.map(String::from).to_vec());
    for (k, f) in frames.iter().enumerate() {
        t.push_row(vec![
            Cell::Int(k as i64 + 1),
            Cell::text(&f.utterance),
            Cell::Int(f.frame as i64),
            Cell::text(f.measure.as_str()),
            f.phone.as_ref().map_or(Cell::Empty, Cell::text),
            Cell::Num(f.video),
            Cell::Num(f.head),
            Cell::Num(f.error),
        ]);
    }
    t
}

/// The worst frames by reprojection RMS.
pub fn worst_fit_table(fits: &[WorstFit]) -> Table {
    let headers = ["rank", "clip", "frame", "reproj RMS px", "failed"];
    let rms = crate::glossary::names::REPROJECTION_RMS;
    let mut t =
        Table::new(format!("worst frames by {rms} (px)"), headers.map(String::from).to_vec())
            .labelled(headers[3], &format!("{rms} (px)"));
    for (k, f) in fits.iter().enumerate() {
        t.push_row(vec![
            Cell::Int(k as i64 + 1),
            Cell::text(&f.clip),
            Cell::Int(f.frame as i64),
            if f.failed.is_some() { Cell::Missing } else { Cell::num(Some(f.reproj_rms_px)) },
            f.failed.as_ref().map_or(Cell::Empty, Cell::text),
        ]);
    }
    t
}

/// The 12 facial indices of one face with their classes (`lipmap indices FILE`).
pub fn indices_table(title: &str, values: &FacialIndices, bounds: &BoundsTable) -> Table {
    let headers = ["index", "ratio", "value", "low <", "> high", "class"];
    let mut t = Table::new(title, headers.map(String::from).to_vec());
    t.precision = 2;
    for index in FacialIndex::ALL {
        let (num, den) = index.ratio();
        let b = bounds.get(index);
        let v = values.get(index);
        t.push_row(vec![
            Cell::text(index.name()),
            Cell::text(format!("D{num}/D{den}")),
            Cell::num(Some(v)),
            Cell::num(b.map(|b| b.low)),
            Cell::num(b.map(|b| b.high)),
            bounds.classify(index, v).map_or(Cell::Empty, |c| Cell::text(c.as_str())),
        ]);
    }
    t
}

/// Speaker vs head indices with classes, the verdict's warnings as notes
/// (`lipmap indices SESSION`, the TUI's matching panel).
pub fn verdict_table(verdict: &MatchVerdict) -> Table {
    let headers = ["index", "speaker", "class", "head", "class"];
    let mut t = Table::new("facial indices: speaker vs head", headers.map(String::from).to_vec());
    t.precision = 2;
    for r in &verdict.rows {
        let class = |c: Option<crate::measure::IndexClass>| {
            c.map_or(Cell::Empty, |c| Cell::text(c.as_str()))
        };
        t.push_row(vec![
            Cell::text(r.index.name()),
            Cell::num(Some(r.speaker)),
            class(r.speaker_class),
            Cell::num(Some(r.head)),
            class(r.head_class),
        ]);
    }
    if verdict.warnings.is_empty() {
        t.notes.push("verdict: good match (no warning)".into());
    } else {
        for w in &verdict.warnings {
            t.notes.push(format!("warning: {w}"));
        }
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measure::Trajectory;

    fn sample() -> Table {
        let mut t = Table::new("demo", vec!["name".into(), "W".into(), "n".into()]);
        t.push_row(vec![Cell::text("bin"), Cell::Num(0.12345), Cell::Int(3)]);
        t.push_row(vec![Cell::text("blue, at"), Cell::Empty, Cell::Int(12)]);
        t
    }

    #[test]
    fn text_is_aligned() {
        let s = sample().to_text();
        let want = "demo\n\
                    name          W   n\n\
                    -------------------\n\
                    bin       0.123   3\n\
                    blue, at         12\n";
        assert_eq!(s, want);
    }

    #[test]
    fn csv_quotes_and_keeps_precision() {
        let mut buf = Vec::new();
        sample().write_csv(&mut buf).unwrap();
        assert_eq!(String::from_utf8(buf).unwrap(), "name,W,n\nbin,0.12345,3\n\"blue, at\",,12\n");
    }

    #[test]
    fn json_has_numbers_and_nulls() {
        let mut buf = Vec::new();
        sample().write_json(&mut buf).unwrap();
        let v: serde_json::Value = serde_json::from_slice(&buf).unwrap();
        assert_eq!(v["rows"][0][1], serde_json::json!(0.12345));
        assert!(v["rows"][1][1].is_null());
        assert_eq!(v["headers"][2], "n");
        let r = sample().to_json_records();
        assert_eq!(r[1]["n"], 12);
    }

    #[test]
    fn writers_report_io_errors() {
        struct Broken;
        impl Write for Broken {
            fn write(&mut self, _: &[u8]) -> io::Result<usize> {
                Err(io::Error::new(io::ErrorKind::BrokenPipe, "closed"))
            }
            fn flush(&mut self) -> io::Result<()> {
                Ok(())
            }
        }
        assert!(sample().write_text(&mut Broken).is_err());
        assert!(sample().write_json(&mut Broken).is_err());
        assert!(sample().write_csv(&mut Broken).is_err());
    }

    #[test]
    fn a_failed_fit_shows_a_dash_not_zero() {
        let fits = [
            WorstFit { clip: "c".into(), frame: 0, reproj_rms_px: 0.0, failed: Some("x".into()) },
            WorstFit { clip: "c".into(), frame: 1, reproj_rms_px: 1.25, failed: None },
        ];
        let t = worst_fit_table(&fits);
        let text = t.to_text();
        assert!(!text.contains("0.000"), "{text}");
        assert_eq!(t.formatted_rows()[0][3], "—");
        assert_eq!(t.formatted_rows()[1][3], "1.250");
        assert!(t.numeric_columns()[3]);
        let mut csv = Vec::new();
        t.write_csv(&mut csv).unwrap();
        assert!(String::from_utf8(csv).unwrap().contains("1,c,0,,x\n"));
        assert!(t.to_json_records()[0]["reproj RMS px"].is_null());
    }

    #[test]
    fn sentence_table_has_p_only_when_a_clip_has_p() {
        let series = |v: &[f64]| v.iter().map(|&x| Some(x)).collect::<Vec<_>>();
        let head = Trajectory {
            w: series(&[1.0, 2.0, 3.0]),
            h: series(&[1.0, 3.0, 2.0]),
            p: series(&[0.5, 0.6, 0.7]),
        };
        let mut u = Utterance {
            name: "s".into(),
            speaker: None,
            alignment: Default::default(),
            fps: 25.0,
            video: Trajectory { p: Vec::new(), ..head.clone() },
            head,
        };
        // The fitted head always has a P; the video here has none: no P columns.
        let t = sentence_table(std::slice::from_ref(&u));
        assert!(t.headers.iter().all(|h| !h.ends_with(" P")), "{:?}", t.headers);
        u.video.p = series(&[0.4, 0.6, 0.9]);
        let t = sentence_table(&[u]);
        assert!(t.headers.contains(&"RMSE P".to_string()), "{:?}", t.headers);
    }

    #[test]
    fn indices_table_lists_all_twelve() {
        let v = FacialIndices { values: [15.0; 12] };
        let t = indices_table("speaker", &v, &BoundsTable::default());
        assert_eq!(t.rows.len(), 12);
        let vmh = &t.rows[FacialIndex::VerticalMouthHeight.position()];
        assert_eq!(vmh[5], Cell::text("middle"));
        assert_eq!(t.rows[0][5], Cell::text("low"));
    }
}
