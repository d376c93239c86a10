//! The 12 facial indices (×100 distance ratios on a neutral frame), their low/middle/high
//! class bounds (data: published defaults, user tables, or box-plot bounds from a corpus), the
//! speaker–head matching verdict, and the default choice of the neutral frame.
//!
//! Points (0-based iBUG): nasion = mid(39, 42), endocanthion 39/42, exocanthion 36/45,
//! alare 31/35, subnasale 33, labiale superius 51, stomion 1 = 62, stomion 2 = 66, labiale
//! inferius 57, gnathion 8, cheilion 48/54, zygion ≈ 0/16. Distances D1..D13 and the
//! published bounds are those of R. Algadhy, PhD thesis, Sheffield 2020, §3 (Table 3.5, after
//! Roelofse et al.); the bounds ship as `data/facial_index_bounds.csv`.

use super::{MeasureError, Series};
use crate::alignment::{Alignment, grouping_label};
use crate::landmarks::FrameLandmarks;
use crate::math::{DVector, Point2};
use crate::model::LandmarkMap;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::sync::LazyLock;

/// One of the 12 facial indices.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum FacialIndex {
    Facial,
    Intercanthal,
    Nasal,
    Nasofacial,
    NoseFaceWidth,
    LipArea,
    VerticalMouthHeight,
    UpperLipThickness,
    LowerLipThickness,
    MouthWidth,
    ChinSize,
    NoseUpperLip,
}

impl FacialIndex {
    /// All 12, in the published order.
    pub const ALL: [FacialIndex; 12] = [
        Self::Facial,
        Self::Intercanthal,
        Self::Nasal,
        Self::Nasofacial,
        Self::NoseFaceWidth,
        Self::LipArea,
        Self::VerticalMouthHeight,
        Self::UpperLipThickness,
        Self::LowerLipThickness,
        Self::MouthWidth,
        Self::ChinSize,
        Self::NoseUpperLip,
    ];

    /// Position in [`FacialIndex::ALL`].
    pub fn position(self) -> usize {
        self as usize
    }

    /// The snake_case key used in bounds files (`vertical_mouth_height`).
    pub fn key(self) -> &'static str {
        match self {
            Self::Facial => "facial",
            Self::Intercanthal => "intercanthal",
            Self::Nasal => "nasal",
            Self::Nasofacial => "nasofacial",
            Self::NoseFaceWidth => "nose_face_width",
            Self::LipArea => "lip_area",
            Self::VerticalMouthHeight => "vertical_mouth_height",
            Self::UpperLipThickness => "upper_lip_thickness",
            Self::LowerLipThickness => "lower_lip_thickness",
            Self::MouthWidth => "mouth_width",
            Self::ChinSize => "chin_size",
            Self::NoseUpperLip => "nose_upper_lip",
        }
    }

    /// A human name for tables (`vertical mouth height`).
    pub fn name(self) -> String {
        self.key().replace('_', " ")
    }

    /// The ratio `(numerator, denominator)` as 1-based distance numbers: D1/D2 for facial.
    pub fn ratio(self) -> (usize, usize) {
        match self {
            Self::Facial => (1, 2),
            Self::Intercanthal => (4, 3),
            Self::Nasal => (6, 5),
            Self::Nasofacial => (5, 1),
            Self::NoseFaceWidth => (6, 2),
            Self::LipArea => (7, 8),
            Self::VerticalMouthHeight => (7, 1),
            Self::UpperLipThickness => (9, 1),
            Self::LowerLipThickness => (10, 1),
            Self::MouthWidth => (8, 3),
            Self::ChinSize => (11, 1),
            Self::NoseUpperLip => (12, 13),
        }
    }

    /// Parses a key or name, ignoring case and treating spaces, hyphens and `–` as `_`
    /// (`"Nose-face width"` → `NoseFaceWidth`).
    pub fn parse(s: &str) -> Option<Self> {
        let norm: String = s
            .trim()
            .chars()
            .map(|c| if c == ' ' || c == '-' || c == '–' { '_' } else { c.to_ascii_lowercase() })
            .collect();
        Self::ALL.into_iter().find(|i| i.key() == norm)
    }

    /// The default class bounds (low below the first, high above the second): the
    /// published table, embedded from `data/facial_index_bounds.csv`.
    pub fn published_bounds(self) -> (f64, f64) {
        let b = DEFAULT_BOUNDS.get(self).expect("the embedded table lists every index (tested)");
        (b.low, b.high)
    }
}

/// The default class-bound table, as shipped in `data/` (a user's file replaces it).
pub const DEFAULT_BOUNDS_CSV: &str = include_str!("../../data/facial_index_bounds.csv");

/// [`DEFAULT_BOUNDS_CSV`] parsed once.
static DEFAULT_BOUNDS: LazyLock<BoundsTable> = LazyLock::new(|| {
    BoundsTable::from_csv_str(DEFAULT_BOUNDS_CSV).expect("the embedded table parses (tested)")
});

impl fmt::Display for FacialIndex {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.name())
    }
}

/// Landmarks of the distances (0-based iBUG).
mod lm {
    pub const ZYGION_R: usize = 0;
    pub const ZYGION_L: usize = 16;
    pub const GNATHION: usize = 8;
    pub const EXO_R: usize = 36;
    pub const EXO_L: usize = 45;
    pub const ENDO_R: usize = 39;
    pub const ENDO_L: usize = 42;
    pub const ALARE_R: usize = 31;
    pub const ALARE_L: usize = 35;
    pub const SUBNASALE: usize = 33;
    pub const LABIALE_SUP: usize = 51;
    pub const STOMION_1: usize = 62;
    pub const STOMION_2: usize = 66;
    pub const LABIALE_INF: usize = 57;
    pub const CHEILION_R: usize = 48;
    pub const CHEILION_L: usize = 54;
}

/// The distances D1..D13 (`d[0]` = D1) in the points' units.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FacialDistances {
    pub d: [f64; 13],
}

impl FacialDistances {
    /// Distance D`k` (1-based, 1..=13).
    ///
    /// # Panics
    /// When `k` is not in 1..=13 (a programming error: the numbers are fixed).
    pub fn get(&self, k: usize) -> f64 {
        self.d[k - 1]
    }
}

/// D1..D13 from 68 points (`None` = unavailable), in the points' units.
///
/// # Errors
/// `MissingLandmark` for an absent point, `NonFinite` for NaN coordinates.
pub fn facial_distances(points: &[Option<Point2>]) -> Result<FacialDistances, MeasureError> {
    use lm::*;
    let p = |i: usize| -> Result<Point2, MeasureError> {
        let q = points.get(i).copied().flatten().ok_or(MeasureError::MissingLandmark(i))?;
        if q.x.is_finite() && q.y.is_finite() { Ok(q) } else { Err(MeasureError::NonFinite) }
    };
    let dist = |a: Point2, b: Point2| (a - b).norm();
    let nasion = nalgebra::center(&p(ENDO_R)?, &p(ENDO_L)?);
    let d = [
        dist(p(GNATHION)?, nasion),
        dist(p(ZYGION_R)?, p(ZYGION_L)?),
        dist(p(EXO_R)?, p(EXO_L)?),
        dist(p(ENDO_R)?, p(ENDO_L)?),
        dist(nasion, p(SUBNASALE)?),
        dist(p(ALARE_R)?, p(ALARE_L)?),
        dist(p(LABIALE_SUP)?, p(LABIALE_INF)?),
        dist(p(CHEILION_R)?, p(CHEILION_L)?),
        dist(p(LABIALE_SUP)?, p(STOMION_1)?),
        dist(p(STOMION_2)?, p(LABIALE_INF)?),
        dist(p(LABIALE_INF)?, p(GNATHION)?),
        dist(p(SUBNASALE)?, p(LABIALE_SUP)?),
        dist(p(SUBNASALE)?, p(GNATHION)?),
    ];
    Ok(FacialDistances { d })
}

/// The 12 index values (×100), `values[i]` for `FacialIndex::ALL[i]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FacialIndices {
    pub values: [f64; 12],
}

impl FacialIndices {
    /// The value of one index.
    pub fn get(&self, index: FacialIndex) -> f64 {
        self.values[index.position()]
    }
}

/// The 12 indices from distances: `100 · D_num / D_den`.
///
/// # Errors
/// `DegenerateReference` when a denominator distance is zero (coincident points).
pub fn indices_from_distances(d: &FacialDistances) -> Result<FacialIndices, MeasureError> {
    let mut values = [0.0; 12];
    for (v, index) in values.iter_mut().zip(FacialIndex::ALL) {
        let (num, den) = index.ratio();
        let den = d.get(den);
        if den.is_nan() || den <= 1e-12 {
            return Err(MeasureError::DegenerateReference(den));
        }
        *v = 100.0 * d.get(num) / den;
    }
    Ok(FacialIndices { values })
}

/// The 12 facial indices of 68 points (`None` = unavailable): video landmarks of a neutral
/// frame, or a head's frontal landmark projection (`mesh::frontal_landmarks`).
///
/// # Errors
/// As [`facial_distances`] and [`indices_from_distances`].
///
/// ```
/// # use lipmap::math::Point2;
/// // Any face: indices are ratios, so scaling the points leaves them unchanged.
/// let pts: Vec<_> = (0..68)
///     .map(|i| Some(Point2::new((i as f64 * 1.3).sin() * 50.0, i as f64)))
///     .collect();
/// let a = lipmap::measure::facial_indices(&pts).unwrap();
/// let scaled: Vec<_> = pts.iter().map(|p| p.map(|p| Point2::new(p.x * 3.0, p.y * 3.0))).collect();
/// let b = lipmap::measure::facial_indices(&scaled).unwrap();
/// assert!((a.values[0] - b.values[0]).abs() < 1e-9);
/// ```
pub fn facial_indices(points: &[Option<Point2>]) -> Result<FacialIndices, MeasureError> {
    indices_from_distances(&facial_distances(points)?)
}

/// The indices whose points are all present, NaN for the others: a head whose landmark map
/// leaves points unmapped (eos's SFM map has no face contour, so no zygion: facial and
/// nose–face width are NaN, the other ten are computed). NaN values have no class
/// ([`BoundsTable::classify`]) and raise no matching warning. Same distances as
/// [`facial_distances`]; a unit test checks the two agree on complete points.
pub fn facial_indices_partial(points: &[Option<Point2>]) -> FacialIndices {
    use lm::*;
    let p =
        |i: usize| points.get(i).copied().flatten().filter(|q| q.x.is_finite() && q.y.is_finite());
    let dist = |a: Option<Point2>, b: Option<Point2>| match (a, b) {
        (Some(a), Some(b)) => (a - b).norm(),
        _ => f64::NAN,
    };
    let nasion = p(ENDO_R).zip(p(ENDO_L)).map(|(a, b)| nalgebra::center(&a, &b));
    let d = FacialDistances {
        d: [
            dist(p(GNATHION), nasion),
            dist(p(ZYGION_R), p(ZYGION_L)),
            dist(p(EXO_R), p(EXO_L)),
            dist(p(ENDO_R), p(ENDO_L)),
            dist(nasion, p(SUBNASALE)),
            dist(p(ALARE_R), p(ALARE_L)),
            dist(p(LABIALE_SUP), p(LABIALE_INF)),
            dist(p(CHEILION_R), p(CHEILION_L)),
            dist(p(LABIALE_SUP), p(STOMION_1)),
            dist(p(STOMION_2), p(LABIALE_INF)),
            dist(p(LABIALE_INF), p(GNATHION)),
            dist(p(SUBNASALE), p(LABIALE_SUP)),
            dist(p(SUBNASALE), p(GNATHION)),
        ],
    };
    let mut values = [f64::NAN; 12];
    for (v, index) in values.iter_mut().zip(FacialIndex::ALL) {
        let (num, den) = index.ratio();
        let den = d.get(den);
        if den > 1e-12 {
            *v = 100.0 * d.get(num) / den;
        }
    }
    FacialIndices { values }
}

/// [`facial_indices_partial`] of a head shape's frontal landmark projection.
pub fn shape_indices_partial(shape: &DVector, map: &LandmarkMap) -> FacialIndices {
    facial_indices_partial(&super::mesh::frontal_landmarks(shape, map))
}

/// The facial indices of one tracked frame (visible points only).
///
/// # Errors
/// As [`facial_indices`]; occluded points count as missing.
pub fn frame_indices(frame: &FrameLandmarks) -> Result<FacialIndices, MeasureError> {
    facial_indices(&super::mouth::visible_points(frame))
}

/// The facial indices of a head shape (flat model-space `x0 y0 z0 …`, typically its
/// neutral pose or the model mean) on the frontal projection of its mapped landmark
/// vertices: the head side of the speaker–head match.
///
/// # Errors
/// As [`facial_indices`]; an unmapped landmark counts as missing.
pub fn shape_indices(shape: &DVector, map: &LandmarkMap) -> Result<FacialIndices, MeasureError> {
    facial_indices(&super::mesh::frontal_landmarks(shape, map))
}

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
        DEFAULT_BOUNDS.clone()
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

/// A Tukey box plot of one sample.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct BoxPlot {
    /// Number of finite values used.
    pub n: usize,
    pub q1: f64,
    pub median: f64,
    pub q3: f64,
    /// Q3 − Q1.
    pub iqr: f64,
    /// The smallest value ≥ Q1 − 1.5·IQR.
    pub lower_whisker: f64,
    /// The largest value ≤ Q3 + 1.5·IQR.
    pub upper_whisker: f64,
    /// Values outside the whiskers.
    pub n_outliers: usize,
}

/// Quantile `q` in [0, 1] of sorted values, Hyndman–Fan type 7 (numpy's default).
fn quantile_sorted(sorted: &[f64], q: f64) -> f64 {
    let h = (sorted.len() - 1) as f64 * q;
    let lo = h.floor() as usize;
    let hi = (lo + 1).min(sorted.len() - 1);
    sorted[lo] + (h - lo as f64) * (sorted[hi] - sorted[lo])
}

/// The box plot of the finite values of `values`; `None` when there are none.
///
/// ```
/// let b = lipmap::measure::indices::box_plot(&[1.0, 2.0, 3.0, 4.0, 100.0]).unwrap();
/// assert_eq!((b.q1, b.median, b.q3), (2.0, 3.0, 4.0));
/// assert_eq!((b.upper_whisker, b.n_outliers), (4.0, 1));
/// ```
pub fn box_plot(values: &[f64]) -> Option<BoxPlot> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let (q1, median, q3) =
        (quantile_sorted(&v, 0.25), quantile_sorted(&v, 0.5), quantile_sorted(&v, 0.75));
    let iqr = q3 - q1;
    let (lo_fence, hi_fence) = (q1 - 1.5 * iqr, q3 + 1.5 * iqr);
    let inside: Vec<f64> = v.iter().copied().filter(|&x| x >= lo_fence && x <= hi_fence).collect();
    Some(BoxPlot {
        n: v.len(),
        q1,
        median,
        q3,
        iqr,
        lower_whisker: inside.first().copied().unwrap_or(q1),
        upper_whisker: inside.last().copied().unwrap_or(q3),
        n_outliers: v.len() - inside.len(),
    })
}

/// One row of a speaker–head comparison.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct IndexComparison {
    pub index: FacialIndex,
    pub speaker: f64,
    pub speaker_class: Option<IndexClass>,
    pub head: f64,
    pub head_class: Option<IndexClass>,
}

/// A reason a head is a poor match for a speaker.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum MatchWarning {
    /// Vertical-mouth-height classes are low vs high (either way): the published finding
    /// is that such pairs animate badly.
    VerticalMouthHeightOpposite { speaker: IndexClass, head: IndexClass },
    /// The speaker's mouth-width class is low (narrow) and the head's high (wide).
    NarrowMouthOnWide { speaker: f64, head: f64 },
}

impl fmt::Display for MatchWarning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::VerticalMouthHeightOpposite { speaker, head } => write!(
                f,
                "vertical mouth height: speaker is {speaker}, head is {head} (opposite classes animate badly)"
            ),
            Self::NarrowMouthOnWide { speaker, head } => write!(
                f,
                "narrow mouth mapped onto a wide one (mouth width index {speaker:.2} vs {head:.2})"
            ),
        }
    }
}

/// The comparison of a speaker's and a head's indices, and the warnings.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MatchVerdict {
    pub rows: Vec<IndexComparison>,
    pub warnings: Vec<MatchWarning>,
}

impl MatchVerdict {
    /// No warning was raised.
    pub fn is_good_match(&self) -> bool {
        self.warnings.is_empty()
    }
}

/// Compares a speaker's neutral-frame indices with a head's (its neutral pose's mapped
/// landmark vertices, frontal projection), classing both with `bounds`.
///
/// Warns when the vertical-mouth-height classes are low vs high in either direction, and
/// when a narrow (low) mouth-width speaker is mapped onto a wide (high) head.
pub fn match_speaker_head(
    speaker: &FacialIndices,
    head: &FacialIndices,
    bounds: &BoundsTable,
) -> MatchVerdict {
    let rows: Vec<IndexComparison> = FacialIndex::ALL
        .into_iter()
        .map(|index| IndexComparison {
            index,
            speaker: speaker.get(index),
            speaker_class: bounds.classify(index, speaker.get(index)),
            head: head.get(index),
            head_class: bounds.classify(index, head.get(index)),
        })
        .collect();
    let row = |i: FacialIndex| rows[i.position()];
    let mut warnings = Vec::new();
    let vmh = row(FacialIndex::VerticalMouthHeight);
    if let (Some(s), Some(h)) = (vmh.speaker_class, vmh.head_class) {
        let opposite = matches!(
            (s, h),
            (IndexClass::Low, IndexClass::High) | (IndexClass::High, IndexClass::Low)
        );
        if opposite {
            warnings.push(MatchWarning::VerticalMouthHeightOpposite { speaker: s, head: h });
        }
    }
    let mw = row(FacialIndex::MouthWidth);
    if mw.speaker_class == Some(IndexClass::Low) && mw.head_class == Some(IndexClass::High) {
        warnings.push(MatchWarning::NarrowMouthOnWide { speaker: mw.speaker, head: mw.head });
    }
    MatchVerdict { rows, warnings }
}

/// The frame chosen as neutral, and whether it lies inside a silence interval.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct NeutralFrame {
    pub frame: usize,
    pub in_silence: bool,
}

/// The default neutral frame: the frame with the smallest mouth opening `h` (a per-frame
/// series such as the normalised H trajectory) among frames inside silence intervals
/// (labels that group to `sil`, frames by [`Alignment::frames_of`]); ties go to the earliest
/// frame. When no silence frame has a value, the smallest opening over the whole clip, with
/// `in_silence = false` so the caller can tell the user. `None` when `h` has no value.
pub fn choose_neutral_frame(h: &Series, alignment: &Alignment, fps: f64) -> Option<NeutralFrame> {
    let smallest = |frames: &mut dyn Iterator<Item = usize>| -> Option<usize> {
        let mut best: Option<(usize, f64)> = None;
        for f in frames {
            if let Some(v) = h.get(f).copied().flatten().filter(|v| v.is_finite())
                && best.is_none_or(|(_, b)| v < b)
            {
                best = Some((f, v));
            }
        }
        best.map(|(f, _)| f)
    };
    let mut silence = Vec::new();
    if fps.is_finite() && fps > 0.0 {
        for p in alignment.phones.iter().filter(|p| grouping_label(&p.label) == "sil") {
            silence.extend(Alignment::frames_of(p, fps));
        }
    }
    silence.sort_unstable();
    silence.dedup();
    if let Some(frame) = smallest(&mut silence.into_iter()) {
        return Some(NeutralFrame { frame, in_silence: true });
    }
    smallest(&mut (0..h.len())).map(|frame| NeutralFrame { frame, in_silence: false })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::alignment::Phone;

    fn sample_points() -> Vec<Option<Point2>> {
        let mut pts: Vec<Option<Point2>> = vec![None; 68];
        let set = |pts: &mut Vec<Option<Point2>>, i: usize, x: f64, y: f64| {
            pts[i] = Some(Point2::new(x, y))
        };
        set(&mut pts, 0, -70.0, 0.0);
        set(&mut pts, 16, 70.0, 0.0);
        set(&mut pts, 8, 0.0, 120.0);
        set(&mut pts, 36, -45.0, 0.0);
        set(&mut pts, 45, 45.0, 0.0);
        set(&mut pts, 39, -15.0, 0.0);
        set(&mut pts, 42, 15.0, 0.0);
        set(&mut pts, 31, -20.0, 45.0);
        set(&mut pts, 35, 20.0, 45.0);
        set(&mut pts, 33, 0.0, 50.0);
        set(&mut pts, 51, 0.0, 65.0);
        set(&mut pts, 62, 0.0, 70.0);
        set(&mut pts, 66, 0.0, 72.0);
        set(&mut pts, 57, 0.0, 82.0);
        set(&mut pts, 48, -25.0, 72.0);
        set(&mut pts, 54, 25.0, 72.0);
        pts
    }

    #[test]
    fn distances_and_indices_by_hand() {
        let d = facial_distances(&sample_points()).unwrap();
        let want = [120.0, 140.0, 90.0, 30.0, 50.0, 40.0, 17.0, 50.0, 5.0, 10.0, 38.0, 15.0, 70.0];
        for (k, w) in want.iter().enumerate() {
            assert!((d.d[k] - w).abs() < 1e-12, "D{} = {} != {w}", k + 1, d.d[k]);
        }
        let ix = indices_from_distances(&d).unwrap();
        assert!((ix.get(FacialIndex::Facial) - 100.0 * 120.0 / 140.0).abs() < 1e-9);
        assert!((ix.get(FacialIndex::Intercanthal) - 100.0 * 30.0 / 90.0).abs() < 1e-9);
        assert!((ix.get(FacialIndex::VerticalMouthHeight) - 100.0 * 17.0 / 120.0).abs() < 1e-9);
        assert!((ix.get(FacialIndex::NoseUpperLip) - 100.0 * 15.0 / 70.0).abs() < 1e-9);
        assert!((ix.get(FacialIndex::MouthWidth) - 100.0 * 50.0 / 90.0).abs() < 1e-9);
    }

    #[test]
    fn head_shape_uses_frontal_projection() {
        // The sample face as a mesh: z must not matter, vertex k = landmark k.
        let pts = sample_points();
        let mut flat = Vec::new();
        for (k, p) in pts.iter().enumerate() {
            let p = p.unwrap_or(Point2::new(k as f64, -(k as f64)));
            flat.extend([p.x, p.y, (k % 5) as f64 * 7.0]);
        }
        let map = LandmarkMap { to_vertex: (0..68).map(|i| (i, i)).collect() };
        let a = shape_indices(&DVector::from_vec(flat), &map).unwrap();
        assert_eq!(a, facial_indices(&pts).unwrap());
        let mut partial = map.clone();
        partial.to_vertex.remove(&8);
        let zeros = DVector::zeros(68 * 3);
        assert_eq!(shape_indices(&zeros, &partial), Err(MeasureError::MissingLandmark(8)));
    }

    #[test]
    fn partial_indices_agree_and_leave_missing_ones_nan() {
        let pts = sample_points();
        assert_eq!(facial_indices_partial(&pts), facial_indices(&pts).unwrap());
        let mut no_zygion = pts.clone();
        no_zygion[0] = None;
        let v = facial_indices_partial(&no_zygion);
        assert!(v.get(FacialIndex::Facial).is_nan() && v.get(FacialIndex::NoseFaceWidth).is_nan());
        assert_eq!(
            v.get(FacialIndex::MouthWidth),
            facial_indices(&pts).unwrap().get(FacialIndex::MouthWidth)
        );
    }

    #[test]
    fn missing_point_and_zero_denominator() {
        let mut pts = sample_points();
        pts[57] = None;
        assert_eq!(facial_distances(&pts), Err(MeasureError::MissingLandmark(57)));
        let mut pts = sample_points();
        pts[16] = pts[0];
        assert!(matches!(facial_indices(&pts), Err(MeasureError::DegenerateReference(_))));
    }

    #[test]
    fn the_embedded_bounds_are_the_published_table() {
        // The published bounds as they stood in code before they moved to `data/`.
        let published = [
            (FacialIndex::Facial, 83.68, 89.52),
            (FacialIndex::Intercanthal, 33.59, 35.50),
            (FacialIndex::Nasal, 73.55, 95.97),
            (FacialIndex::Nasofacial, 42.23, 47.49),
            (FacialIndex::NoseFaceWidth, 28.91, 32.66),
            (FacialIndex::LipArea, 29.79, 35.53),
            (FacialIndex::VerticalMouthHeight, 13.58, 16.22),
            (FacialIndex::UpperLipThickness, 3.93, 5.61),
            (FacialIndex::LowerLipThickness, 9.23, 11.44),
            (FacialIndex::MouthWidth, 49.18, 54.80),
            (FacialIndex::ChinSize, 22.79, 27.18),
            (FacialIndex::NoseUpperLip, 25.88, 29.08),
        ];
        let expected = BoundsTable {
            bounds: published.map(|(index, low, high)| IndexBounds { index, low, high }).to_vec(),
        };
        assert_eq!(BoundsTable::from_csv_str(DEFAULT_BOUNDS_CSV).unwrap(), expected);
        assert_eq!(BoundsTable::default(), expected);
        for (index, low, high) in published {
            assert_eq!(index.published_bounds(), (low, high));
        }
    }

    #[test]
    fn classification_is_inclusive_in_the_middle() {
        let t = BoundsTable::default();
        let b = t.get(FacialIndex::VerticalMouthHeight).unwrap();
        assert_eq!((b.low, b.high), (13.58, 16.22));
        assert_eq!(t.classify(FacialIndex::VerticalMouthHeight, 13.57), Some(IndexClass::Low));
        assert_eq!(t.classify(FacialIndex::VerticalMouthHeight, 13.58), Some(IndexClass::Middle));
        assert_eq!(t.classify(FacialIndex::VerticalMouthHeight, 16.23), Some(IndexClass::High));
        assert_eq!(t.classify(FacialIndex::Facial, f64::NAN), None);
        assert_eq!(t.bounds.len(), 12);
    }

    #[test]
    fn csv_and_toml_round_trip_and_errors() {
        let t = BoundsTable::default();
        assert_eq!(BoundsTable::from_csv_str(&t.to_csv_string()).unwrap(), t);
        assert_eq!(BoundsTable::from_toml_str(&t.to_toml_string()).unwrap(), t);
        let user = "# my corpus\nlow,index,high\n1,Vertical mouth height,2\n3,nose-face width,4\n";
        let u = BoundsTable::from_csv_str(user).unwrap();
        assert_eq!(u.bounds.len(), 2);
        assert_eq!(u.classify(FacialIndex::NoseFaceWidth, 5.0), Some(IndexClass::High));
        assert_eq!(u.classify(FacialIndex::Facial, 5.0), None);
        let e = BoundsTable::from_csv_str("index,low,high\nfacial,1,2\nnosy,1,2\n").unwrap_err();
        assert_eq!((e.line, e.field.as_deref()), (Some(3), Some("index")));
        let e = BoundsTable::from_csv_str("index,low,high\nfacial,x,2\n").unwrap_err();
        assert_eq!((e.line, e.field.as_deref()), (Some(2), Some("low")));
        let e = BoundsTable::from_csv_str("index,low,high\nfacial,3,2\n").unwrap_err();
        assert_eq!(e.line, Some(2));
        let e = BoundsTable::from_csv_str("index,low,high\nfacial,1,2\nfacial,1,2\n").unwrap_err();
        assert!(e.message.contains("twice"));
        assert!(BoundsTable::from_csv_str("index,low\nfacial,1\n").is_err());
        let e =
            BoundsTable::from_toml_str("[[bounds]]\nindex = \"facial\"\nlow = \"a\"\nhigh = 2\n")
                .unwrap_err();
        assert_eq!(e.line, Some(3));
    }

    #[test]
    fn box_plot_rule_matches_hand_quartiles() {
        // 1..=8 and 40: type-7 quartiles of 9 values are the 3rd and 7th: 3 and 7.
        let mut v: Vec<f64> = (1..=8).map(f64::from).collect();
        v.push(40.0);
        let b = box_plot(&v).unwrap();
        assert_eq!((b.q1, b.median, b.q3, b.iqr), (3.0, 5.0, 7.0, 4.0));
        // Fences −3 and 13: 40 is an outlier, the upper whisker stops at 8.
        assert_eq!((b.lower_whisker, b.upper_whisker, b.n_outliers), (1.0, 8.0, 1));
        // Even count, interpolated: [1,2,3,4] → Q1 = 1.75, Q3 = 3.25.
        let b = box_plot(&[4.0, 1.0, 3.0, 2.0]).unwrap();
        assert_eq!((b.q1, b.q3), (1.75, 3.25));
        assert!(box_plot(&[f64::NAN]).is_none());
    }

    #[test]
    fn corpus_bounds_are_box_edges() {
        let samples: Vec<FacialIndices> =
            (1..=9).map(|k| FacialIndices { values: [k as f64; 12] }).collect();
        let (t, plots) = BoundsTable::from_corpus(&samples).unwrap();
        let b = t.get(FacialIndex::ChinSize).unwrap();
        assert_eq!((b.low, b.high), (3.0, 7.0));
        assert_eq!(plots.len(), 12);
        assert!(BoundsTable::from_corpus(&samples[..3]).is_err());
    }

    #[test]
    fn verdict_warns_on_opposite_mouth_height_and_narrow_on_wide() {
        let t = BoundsTable::default();
        let mut speaker = FacialIndices { values: [0.0; 12] };
        let mut head = speaker;
        for i in FacialIndex::ALL {
            let (lo, hi) = i.published_bounds();
            speaker.values[i.position()] = 0.5 * (lo + hi);
            head.values[i.position()] = 0.5 * (lo + hi);
        }
        assert!(match_speaker_head(&speaker, &head, &t).is_good_match());
        speaker.values[FacialIndex::VerticalMouthHeight.position()] = 12.0;
        head.values[FacialIndex::VerticalMouthHeight.position()] = 18.0;
        let v = match_speaker_head(&speaker, &head, &t);
        assert_eq!(v.warnings.len(), 1);
        // Either way round.
        let v = match_speaker_head(&head, &speaker, &t);
        assert!(matches!(v.warnings[0], MatchWarning::VerticalMouthHeightOpposite { .. }));
        // Low vs middle is not flagged.
        head.values[FacialIndex::VerticalMouthHeight.position()] = 15.0;
        assert!(match_speaker_head(&speaker, &head, &t).is_good_match());
        speaker.values[FacialIndex::MouthWidth.position()] = 45.0;
        head.values[FacialIndex::MouthWidth.position()] = 60.0;
        let v = match_speaker_head(&speaker, &head, &t);
        assert!(matches!(v.warnings[..], [MatchWarning::NarrowMouthOnWide { .. }]));
        // Wide onto narrow is not what the published finding warns about.
        assert!(match_speaker_head(&head, &speaker, &t).is_good_match());
    }

    #[test]
    fn neutral_frame_is_smallest_opening_in_silence() {
        let al = Alignment {
            phones: vec![
                Phone { start: 0.0, end: 0.3, label: "sil".into() },
                Phone { start: 0.3, end: 0.6, label: "M".into() },
                Phone { start: 0.6, end: 1.0, label: "sp".into() },
            ],
        };
        // 10 fps: silence frames 0..3 and 6..10; frame 4 (in /m/) is the global minimum.
        let h: Series =
            [0.3, 0.2, 0.25, 0.5, 0.0, 0.4, 0.3, 0.1, 0.1, 0.2].into_iter().map(Some).collect();
        assert_eq!(
            choose_neutral_frame(&h, &al, 10.0),
            Some(NeutralFrame { frame: 7, in_silence: true })
        );
        let none = Alignment { phones: vec![Phone { start: 0.0, end: 1.0, label: "AA1".into() }] };
        assert_eq!(
            choose_neutral_frame(&h, &none, 10.0),
            Some(NeutralFrame { frame: 4, in_silence: false })
        );
        assert_eq!(choose_neutral_frame(&vec![None; 3], &al, 10.0), None);
    }
}
