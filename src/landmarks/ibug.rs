//! The iBUG-68 convention (0-based everywhere in lipmap): names, anatomical groups and the
//! cumulative landmark sets F1..F5 used to choose which points drive a fit.

use serde::{Deserialize, Serialize};
use std::fmt;
use std::ops::Range;
use std::str::FromStr;

/// Number of points in the iBUG-68 markup.
pub const N_LANDMARKS: usize = 68;

/// Anatomical groups, as index ranges (0-based, end exclusive).
pub const JAW: Range<usize> = 0..17;
pub const RIGHT_BROW: Range<usize> = 17..22;
pub const LEFT_BROW: Range<usize> = 22..27;
pub const NOSE_BRIDGE: Range<usize> = 27..31;
pub const LOWER_NOSE: Range<usize> = 31..36;
pub const RIGHT_EYE: Range<usize> = 36..42;
pub const LEFT_EYE: Range<usize> = 42..48;
pub const OUTER_LIP: Range<usize> = 48..60;
pub const INNER_LIP: Range<usize> = 60..68;

/// Named points used by the measures (0-based).
pub mod point {
    pub const GNATHION: usize = 8;
    pub const NASION: usize = 27;
    pub const NOSE_TIP: usize = 30;
    pub const SUBNASALE: usize = 33;
    pub const RIGHT_EXOCANTHION: usize = 36;
    pub const RIGHT_ENDOCANTHION: usize = 39;
    pub const LEFT_ENDOCANTHION: usize = 42;
    pub const LEFT_EXOCANTHION: usize = 45;
    pub const RIGHT_CHEILION: usize = 48;
    pub const LABIALE_SUPERIUS: usize = 51;
    pub const LEFT_CHEILION: usize = 54;
    pub const LABIALE_INFERIUS: usize = 57;
    pub const INNER_LIP_RIGHT: usize = 60;
    pub const STOMION_UPPER: usize = 62;
    pub const INNER_LIP_LEFT: usize = 64;
    pub const STOMION_LOWER: usize = 66;
}

/// A named group of points that can be moved together (TUI) or reported together.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Group {
    pub name: &'static str,
    pub range: Range<usize>,
}

pub const GROUPS: [Group; 9] = [
    Group { name: "jaw", range: JAW },
    Group { name: "right brow", range: RIGHT_BROW },
    Group { name: "left brow", range: LEFT_BROW },
    Group { name: "nose bridge", range: NOSE_BRIDGE },
    Group { name: "lower nose", range: LOWER_NOSE },
    Group { name: "right eye", range: RIGHT_EYE },
    Group { name: "left eye", range: LEFT_EYE },
    Group { name: "outer lip", range: OUTER_LIP },
    Group { name: "inner lip", range: INNER_LIP },
];

/// The group a point belongs to.
pub fn group_of(index: usize) -> Option<&'static Group> {
    GROUPS.iter().find(|g| g.range.contains(&index))
}

/// A short human name for a 0-based iBUG point, e.g. `inner lip top` for 62.
pub fn landmark_name(index: usize) -> String {
    use point::*;
    let special = match index {
        GNATHION => Some("chin (gnathion)"),
        NASION => Some("nasion"),
        NOSE_TIP => Some("nose tip"),
        SUBNASALE => Some("subnasale"),
        RIGHT_EXOCANTHION => Some("right eye outer corner"),
        RIGHT_ENDOCANTHION => Some("right eye inner corner"),
        LEFT_ENDOCANTHION => Some("left eye inner corner"),
        LEFT_EXOCANTHION => Some("left eye outer corner"),
        RIGHT_CHEILION => Some("right mouth corner"),
        LABIALE_SUPERIUS => Some("upper lip top"),
        LEFT_CHEILION => Some("left mouth corner"),
        LABIALE_INFERIUS => Some("lower lip bottom"),
        INNER_LIP_RIGHT => Some("inner lip right corner"),
        STOMION_UPPER => Some("inner lip top"),
        INNER_LIP_LEFT => Some("inner lip left corner"),
        STOMION_LOWER => Some("inner lip bottom"),
        _ => None,
    };
    match (special, group_of(index)) {
        (Some(s), _) => s.to_string(),
        (None, Some(g)) => format!("{} {}", g.name, index - g.range.start + 1),
        (None, None) => format!("point {index}"),
    }
}

/// Cumulative landmark sets for fitting: F1 lips; F2 + nose; F3 + eyes; F4 + brows; F5 + jaw.
#[derive(
    Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize, Default,
)]
pub enum LandmarkSet {
    F1,
    F2,
    F3,
    #[default]
    F4,
    F5,
}

impl LandmarkSet {
    pub const ALL: [LandmarkSet; 5] = [Self::F1, Self::F2, Self::F3, Self::F4, Self::F5];

    /// Whether the 0-based point takes part in a fit with this set.
    pub fn contains(self, index: usize) -> bool {
        let lips = OUTER_LIP.start..INNER_LIP.end;
        let nose = NOSE_BRIDGE.start..LOWER_NOSE.end;
        let eyes = RIGHT_EYE.start..LEFT_EYE.end;
        let brows = RIGHT_BROW.start..LEFT_BROW.end;
        let in_set = |s: LandmarkSet| self >= s;
        lips.contains(&index)
            || (in_set(Self::F2) && nose.contains(&index))
            || (in_set(Self::F3) && eyes.contains(&index))
            || (in_set(Self::F4) && brows.contains(&index))
            || (in_set(Self::F5) && JAW.contains(&index))
    }

    /// The 0-based points of this set, ascending.
    pub fn indices(self) -> Vec<usize> {
        (0..N_LANDMARKS).filter(|&i| self.contains(i)).collect()
    }
}

impl fmt::Display for LandmarkSet {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{self:?}")
    }
}

impl FromStr for LandmarkSet {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.trim().to_ascii_uppercase().as_str() {
            "F1" => Ok(Self::F1),
            "F2" => Ok(Self::F2),
            "F3" => Ok(Self::F3),
            "F4" => Ok(Self::F4),
            "F5" => Ok(Self::F5),
            other => Err(format!("unknown landmark set `{other}` (expected F1..F5)")),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn set_sizes_are_cumulative() {
        let sizes: Vec<usize> = LandmarkSet::ALL.iter().map(|s| s.indices().len()).collect();
        assert_eq!(sizes, vec![20, 29, 41, 51, 68]);
    }

    #[test]
    fn names_cover_every_point() {
        assert_eq!(landmark_name(62), "inner lip top");
        assert_eq!(landmark_name(0), "jaw 1");
        assert_eq!(landmark_name(49), "outer lip 2");
    }
}
