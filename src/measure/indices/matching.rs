//! The speaker–head matching verdict: each index of speaker and head classed against the
//! bounds, with warnings where their classes differ.

use super::{BoundsTable, FacialIndex, FacialIndices, IndexClass};
use serde::{Deserialize, Serialize};
use std::fmt;

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
