//! The 12 facial indices (×100 distance ratios on a neutral frame), their low/middle/high
//! class bounds (data: published defaults, user tables, or box-plot bounds from a corpus), the
//! speaker–head matching verdict, and the default choice of the neutral frame.
//!
//! Points (0-based iBUG): nasion = mid(39, 42), endocanthion 39/42, exocanthion 36/45,
//! alare 31/35, subnasale 33, labiale superius 51, stomion 1 = 62, stomion 2 = 66, labiale
//! inferius 57, gnathion 8, cheilion 48/54, zygion ≈ 0/16. Distances D1..D13 and the
//! published bounds are those of R. Algadhy, PhD thesis, Sheffield 2020, §3 (Table 3.5, after
//! Roelofse et al.); the bounds ship as `data/facial_index_bounds.csv`.
//!
//! One concern per file: [`distances`] (D1..D13 and the indices), [`bounds`] (class bounds),
//! [`box_plot`], [`matching`] (the verdict), [`neutral`] (the neutral frame).

mod bounds;
mod box_plot;
mod distances;
mod matching;
mod neutral;

pub use bounds::{BoundsError, BoundsTable, IndexBounds, IndexClass};
pub use box_plot::{BoxPlot, box_plot};
pub use distances::{
    FacialDistances, FacialIndices, facial_distances, facial_indices, facial_indices_partial,
    frame_indices, indices_from_distances, shape_indices, shape_indices_partial,
};
pub use matching::{IndexComparison, MatchVerdict, MatchWarning, match_speaker_head};
pub use neutral::{NeutralFrame, choose_neutral_frame};

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
pub const DEFAULT_BOUNDS_CSV: &str = include_str!("../../../data/facial_index_bounds.csv");

/// [`DEFAULT_BOUNDS_CSV`] parsed once.
pub(super) static DEFAULT_BOUNDS: LazyLock<BoundsTable> = LazyLock::new(|| {
    BoundsTable::from_csv_str(DEFAULT_BOUNDS_CSV).expect("the embedded table parses (tested)")
});

impl fmt::Display for FacialIndex {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.name())
    }
}

#[cfg(test)]
mod tests;
