//! Low/middle/high class bounds per index: the published table, a user's table, or bounds
//! from a corpus's box plots; and the class of a value against them.

use super::{BoxPlot, FacialIndex, FacialIndices, box_plot};
use serde::{Deserialize, Serialize};
use std::fmt;

/// An index value's class against its bounds.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum IndexClass {
    Low,
    Middle,
    High,
}

impl IndexClass {
    /// `"low"`, `"middle"` or `"high"`.
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Low => "low",
            Self::Middle => "middle",
            Self::High => "high",
        }
    }
}

impl fmt::Display for IndexClass {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// Class bounds of one index: `low` below `low`, `high` above `high`, middle in between
/// (both ends inclusive).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct IndexBounds {
    pub index: FacialIndex,
    pub low: f64,
    pub high: f64,
}

impl IndexBounds {
    /// The class of `value`; `None` for NaN.
    pub fn classify(&self, value: f64) -> Option<IndexClass> {
        if value.is_nan() {
            None
        } else if value < self.low {
            Some(IndexClass::Low)
        } else if value > self.high {
            Some(IndexClass::High)
        } else {
            Some(IndexClass::Middle)
        }
    }
}

/// A table of class bounds. [`Default`] is the published table ([`DEFAULT_BOUNDS_CSV`]); a
/// user's table (CSV or TOML, see [`BoundsTable::from_csv_str`],
/// [`BoundsTable::from_toml_str`]; `io::bounds_table` reads the file) or one computed from a
/// corpus ([`BoundsTable::from_corpus`]) replaces it. Indices the table does not list have no
/// class.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct BoundsTable {
    pub bounds: Vec<IndexBounds>,
}

impl Default for BoundsTable {
    /// The published table ([`DEFAULT_BOUNDS_CSV`]).
    fn default() -> Self {
        super::DEFAULT_BOUNDS.clone()
    }
}

/// A problem in a bounds table: where (1-based line and/or field) and what.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{}{}{message}", line.map(|l| format!("line {l}: ")).unwrap_or_default(), field.as_ref().map(|f| format!("field `{f}`: ")).unwrap_or_default())]
pub struct BoundsError {
    pub line: Option<usize>,
    pub field: Option<String>,
    pub message: String,
}

impl BoundsError {
    fn at(line: Option<usize>, field: Option<&str>, message: impl Into<String>) -> Self {
        Self { line, field: field.map(str::to_string), message: message.into() }
    }
}

impl BoundsTable {
    /// The bounds of one index, if the table has them.
    pub fn get(&self, index: FacialIndex) -> Option<&IndexBounds> {
        self.bounds.iter().find(|b| b.index == index)
    }

    /// The class of `value` for `index`; `None` when the table lacks the index or for NaN.
    pub fn classify(&self, index: FacialIndex, value: f64) -> Option<IndexClass> {
        self.get(index).and_then(|b| b.classify(value))
    }

    fn validate(&self, lines: &[Option<usize>]) -> Result<(), BoundsError> {
        for (k, b) in self.bounds.iter().enumerate() {
            let line = lines.get(k).copied().flatten();
            if !b.low.is_finite() || !b.high.is_finite() || b.low > b.high {
                return Err(BoundsError::at(
                    line,
                    Some(b.index.key()),
                    format!("bounds must be finite with low <= high, got {} and {}", b.low, b.high),
                ));
            }
            if self.bounds[..k].iter().any(|o| o.index == b.index) {
                return Err(BoundsError::at(line, Some(b.index.key()), "index listed twice"));
            }
        }
        Ok(())
    }

    /// Parses a CSV table with a header naming the columns `index`, `low`, `high` (any order,
    /// extra columns ignored); `index` takes a key or a name (`vertical mouth height`).
    ///
    /// # Errors
    /// A [`BoundsError`] naming the 1-based line and field: unknown index, bad number,
    /// low > high, duplicates, missing columns.
    pub fn from_csv_str(text: &str) -> Result<Self, BoundsError> {
        let mut reader = csv::ReaderBuilder::new()
            .trim(csv::Trim::All)
            .comment(Some(b'#'))
            .from_reader(text.as_bytes());
        let headers =
            reader.headers().map_err(|e| BoundsError::at(Some(1), None, e.to_string()))?.clone();
        let col = |name: &str| {
            headers
                .iter()
                .position(|h| h.eq_ignore_ascii_case(name))
                .ok_or_else(|| BoundsError::at(Some(1), Some(name), "missing column"))
        };
        let (ci, cl, ch) = (col("index")?, col("low")?, col("high")?);
        let mut bounds = Vec::new();
        let mut lines = Vec::new();
        for rec in reader.records() {
            let rec = rec.map_err(|e| {
                let line = e.position().map(|p| p.line() as usize);
                BoundsError::at(line, None, e.to_string())
            })?;
            let line = rec.position().map(|p| p.line() as usize);
            let field = |c: usize, name: &str| {
                rec.get(c).ok_or_else(|| BoundsError::at(line, Some(name), "missing value"))
            };
            let index = FacialIndex::parse(field(ci, "index")?).ok_or_else(|| {
                BoundsError::at(line, Some("index"), format!("unknown index `{}`", &rec[ci]))
            })?;
            let num = |c: usize, name: &str| -> Result<f64, BoundsError> {
                let s = field(c, name)?;
                s.parse::<f64>()
                    .map_err(|_| BoundsError::at(line, Some(name), format!("not a number: `{s}`")))
            };
            bounds.push(IndexBounds { index, low: num(cl, "low")?, high: num(ch, "high")? });
            lines.push(line);
        }
        let table = Self { bounds };
        table.validate(&lines)?;
        Ok(table)
    }

    /// The table as CSV (`index,low,high`, keys), readable by [`BoundsTable::from_csv_str`].
    pub fn to_csv_string(&self) -> String {
        let mut s = String::from("index,low,high\n");
        for b in &self.bounds {
            s.push_str(&format!("{},{},{}\n", b.index.key(), b.low, b.high));
        }
        s
    }

    /// Parses a TOML table: `[[bounds]]` entries with `index = "facial"`, `low`, `high`.
    ///
    /// # Errors
    /// A [`BoundsError`] with the 1-based line of TOML's error span, or the offending index.
    pub fn from_toml_str(text: &str) -> Result<Self, BoundsError> {
        let table: Self = toml::from_str(text).map_err(|e| {
            let line = e.span().map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1);
            BoundsError::at(line, None, e.message().to_string())
        })?;
        table.validate(&[])?;
        Ok(table)
    }

    /// The table as TOML, readable by [`BoundsTable::from_toml_str`].
    pub fn to_toml_string(&self) -> String {
        toml::to_string(self).unwrap_or_default()
    }

    /// Bounds from many speakers' neutral-frame indices by the box-plot rule, with the
    /// per-index [`BoxPlot`]s.
    ///
    /// For each index: the quartiles Q1, Q3 of all speakers' values (linear interpolation
    /// between order statistics, Hyndman–Fan type 7, numpy's default); IQR = Q3 − Q1; the
    /// whiskers reach the most extreme values within Q1 − 1.5·IQR and Q3 + 1.5·IQR (Tukey),
    /// and values beyond them are outliers. The class bounds are the box edges: **low =
    /// Q1, high = Q3**, so the middle class is the central half of the corpus and low/high
    /// the lower/upper quarter; outliers are still classed low or high, and are counted in
    /// the box plot so a user can see a corpus that needs cleaning.
    ///
    /// # Errors
    /// When fewer than 4 speakers have a finite value for some index (quartiles of fewer
    /// points say nothing).
    pub fn from_corpus(samples: &[FacialIndices]) -> Result<(Self, Vec<BoxPlot>), BoundsError> {
        let mut bounds = Vec::new();
        let mut plots = Vec::new();
        for index in FacialIndex::ALL {
            let values: Vec<f64> = samples.iter().map(|s| s.get(index)).collect();
            let plot = box_plot(&values).filter(|b| b.n >= 4).ok_or_else(|| {
                BoundsError::at(None, Some(index.key()), "fewer than 4 finite values")
            })?;
            bounds.push(IndexBounds { index, low: plot.q1, high: plot.q3 });
            plots.push(plot);
        }
        Ok((Self { bounds }, plots))
    }
}
