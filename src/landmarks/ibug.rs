//! The iBUG-68 convention: names, anatomical groups and the cumulative landmark sets F1..F5
//! used to choose which points drive a fit.
//!
//! Inside lipmap a point is its 0-based index (0..67); people read the points 1-based (1–68,
//! as the 300-W annotation figure, eos's map files and most papers number them), so every
//! message, table and screen shows a point through [`PointNo`] (`PointNo(62)` prints `63`)
//! and reads one typed by a person through [`parse_point_no`]. Files keep their own
//! conventions (docs/session-format.md lists them).
//!
//! The group ranges and named points below are the markup's convention, which the measures
//! and fitting sets rely on; the names shown to users and the display groups are data
//! (`data/ibug68.csv`, embedded at build time).

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

/// A 0-based iBUG point as people read it: its `Display` is the 1-based number (1–68).
///
/// ```
/// use lipmap::landmarks::ibug::PointNo;
/// assert_eq!(format!("point {}", PointNo(62)), "point 63");
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct PointNo(pub usize);

impl fmt::Display for PointNo {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}", self.0 + 1)
    }
}

/// A run of 0-based points as people read them, `49–68` for `48..68`.
pub fn point_range(range: &Range<usize>) -> String {
    format!("{}–{}", PointNo(range.start), PointNo(range.end.saturating_sub(1)))
}

/// A point number typed by a person (1–68) as its 0-based index.
///
/// # Errors
/// Text that is not a whole number from 1 to 68, in words for a status line.
///
/// ```
/// use lipmap::landmarks::ibug::parse_point_no;
/// assert_eq!(parse_point_no(" 63 "), Ok(62));
/// assert!(parse_point_no("0").is_err());
/// ```
pub fn parse_point_no(text: &str) -> Result<usize, String> {
    match text.trim().parse::<usize>() {
        Ok(n @ 1..=N_LANDMARKS) => Ok(n - 1),
        _ => Err(format!("`{}` is not a point number (1–{N_LANDMARKS})", text.trim())),
    }
}

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
pub struct Group<'a> {
    pub name: &'a str,
    pub range: Range<usize>,
}

/// Point names and groups as shipped in `data/` (a user's file in the same format, e.g. in
/// another language, may replace them: the names in use reach whoever shows them as a
/// [`LandmarkNames`] argument).
pub const DEFAULT_NAMES_CSV: &str = include_str!("../../data/ibug68.csv");

/// The names and groups of the 68 points, borrowed from the CSV text they were parsed from.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct LandmarkNames<'a> {
    /// Consecutive runs of points, in point order.
    pub groups: Vec<Group<'a>>,
    /// A point's own name; `None` names it by its group and place in it.
    pub names: Vec<Option<&'a str>>,
}

/// A problem in a landmark-names file: the 1-based line and what.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("line {line}: {message}")]
pub struct NamesError {
    pub line: usize,
    pub message: String,
}

impl LandmarkNames<'static> {
    /// The names shipped in `data/` ([`DEFAULT_NAMES_CSV`]).
    pub fn builtin() -> Self {
        Self::from_csv_str(DEFAULT_NAMES_CSV).expect("the embedded table parses (tested)")
    }
}

impl<'a> LandmarkNames<'a> {
    /// Parses `index,group,name` rows (a header line first; `#` lines and blank lines are
    /// skipped; `name` may be empty and may hold commas): one row per point, indices 0..67 in
    /// order, each group one run of consecutive points.
    ///
    /// # Errors
    /// A [`NamesError`] naming the line: a wrong header, a missing field, an index out of
    /// order, an empty group, a group split in two runs, or not 68 rows.
    pub fn from_csv_str(text: &'a str) -> Result<Self, NamesError> {
        let err = |line: usize, message: String| NamesError { line, message };
        let crate::table_text::CsvRows { rows, last_line } =
            crate::table_text::csv_rows(text, "index,group,name")
                .map_err(|(line, message)| err(line, message))?;
        let mut groups: Vec<Group<'a>> = Vec::new();
        let mut names = Vec::new();
        for (line, row) in rows {
            let mut f = row.splitn(3, ',').map(str::trim);
            let (Some(index), Some(group), Some(name)) = (f.next(), f.next(), f.next()) else {
                return Err(err(line, "expected three fields: index,group,name".into()));
            };
            let i = names.len();
            if index.parse::<usize>().ok() != Some(i) {
                return Err(err(line, format!("index `{index}`: expected {i}")));
            }
            if i >= N_LANDMARKS {
                return Err(err(line, format!("more than {N_LANDMARKS} points")));
            }
            if group.is_empty() {
                return Err(err(line, "empty group".into()));
            }
            if let Some(g) = groups.last_mut().filter(|g| g.name == group) {
                g.range.end = i + 1;
            } else if groups.iter().any(|g| g.name == group) {
                return Err(err(line, format!("group `{group}` is split in two runs")));
            } else {
                groups.push(Group { name: group, range: i..i + 1 });
            }
            names.push((!name.is_empty()).then_some(name));
        }
        if names.len() != N_LANDMARKS {
            return Err(err(last_line, format!("{} points, expected {N_LANDMARKS}", names.len())));
        }
        Ok(Self { groups, names })
    }

    /// The display group point `index` belongs to.
    pub fn group_of(&self, index: usize) -> Option<&Group<'a>> {
        self.groups.iter().find(|g| g.range.contains(&index))
    }

    /// A short human name for a 0-based iBUG point, e.g. `inner lip top` for 62: the point's
    /// own name, else its group's name and 1-based place in it; `point N` (1-based) for an
    /// index past the table.
    pub fn name(&self, index: usize) -> String {
        if let Some(Some(n)) = self.names.get(index) {
            return n.to_string();
        }
        match self.group_of(index) {
            Some(g) => format!("{} {}", g.name, index - g.range.start + 1),
            None => format!("point {}", PointNo(index)),
        }
    }

    /// A 0-based point as a list or panel shows it: its 1-based number and its name,
    /// `63 inner lip top` for 62.
    pub fn label(&self, index: usize) -> String {
        format!("{} {}", PointNo(index), self.name(index))
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
    fn the_embedded_names_are_the_ibug_convention() {
        let names = LandmarkNames::from_csv_str(DEFAULT_NAMES_CSV).unwrap();
        let expected = [
            ("jaw", JAW),
            ("right brow", RIGHT_BROW),
            ("left brow", LEFT_BROW),
            ("nose bridge", NOSE_BRIDGE),
            ("lower nose", LOWER_NOSE),
            ("right eye", RIGHT_EYE),
            ("left eye", LEFT_EYE),
            ("outer lip", OUTER_LIP),
            ("inner lip", INNER_LIP),
        ]
        .map(|(name, range)| Group { name, range });
        assert_eq!(names.groups, expected);
        assert_eq!(LandmarkNames::builtin(), names);
        use point::*;
        let named = [
            (GNATHION, "chin (gnathion)"),
            (NASION, "nasion"),
            (NOSE_TIP, "nose tip"),
            (SUBNASALE, "subnasale"),
            (RIGHT_EXOCANTHION, "right eye outer corner"),
            (RIGHT_ENDOCANTHION, "right eye inner corner"),
            (LEFT_ENDOCANTHION, "left eye inner corner"),
            (LEFT_EXOCANTHION, "left eye outer corner"),
            (RIGHT_CHEILION, "right mouth corner"),
            (LABIALE_SUPERIUS, "upper lip top"),
            (LEFT_CHEILION, "left mouth corner"),
            (LABIALE_INFERIUS, "lower lip bottom"),
            (INNER_LIP_RIGHT, "inner lip right corner"),
            (STOMION_UPPER, "inner lip top"),
            (INNER_LIP_LEFT, "inner lip left corner"),
            (STOMION_LOWER, "inner lip bottom"),
        ];
        for i in 0..N_LANDMARKS {
            let own = named.iter().find(|n| n.0 == i).map(|n| n.1);
            assert_eq!(names.names[i], own, "point {i}");
        }
        assert_eq!(LandmarkNames::builtin().name(68), "point 69");
    }

    #[test]
    fn a_replacement_file_renames_and_bad_files_say_where() {
        let rows: String = (0..N_LANDMARKS).map(|i| format!("{i},g{},\n", i / 34)).collect();
        let text = format!("# two halves\nindex,group,name\n{rows}");
        let names = LandmarkNames::from_csv_str(&text).unwrap();
        assert_eq!(names.name(40), "g1 7");
        assert_eq!(names.groups.len(), 2);
        let renamed = text.replace("62,g1,", "62,g1,stomion, upper");
        assert_eq!(LandmarkNames::from_csv_str(&renamed).unwrap().name(62), "stomion, upper");
        let e = LandmarkNames::from_csv_str(&text.replace("5,g0,", "6,g0,")).unwrap_err();
        assert_eq!((e.line, e.message.as_str()), (8, "index `6`: expected 5"));
        let e = LandmarkNames::from_csv_str(&text.replace("40,g1,", "40,g0,")).unwrap_err();
        assert_eq!(e.to_string(), "line 43: group `g0` is split in two runs");
        let e = LandmarkNames::from_csv_str(&text.replace("67,g1,\n", "")).unwrap_err();
        assert_eq!(e.to_string(), "line 69: 67 points, expected 68");
        assert!(LandmarkNames::from_csv_str("idx,group,name\n").is_err());
        assert!(LandmarkNames::from_csv_str(&text.replace("3,g0,", "3")).is_err());
    }

    #[test]
    fn names_cover_every_point() {
        let names = LandmarkNames::builtin();
        assert_eq!(names.name(62), "inner lip top");
        assert_eq!(names.name(0), "jaw 1");
        assert_eq!(names.name(49), "outer lip 2");
        assert_eq!(names.group_of(49).map(|g| g.name), Some("outer lip"));
        assert_eq!(names.group_of(68), None);
        assert_eq!(names.label(62), "63 inner lip top");
        assert_eq!(names.label(0), "1 jaw 1");
    }

    #[test]
    fn people_number_points_from_one() {
        assert_eq!(PointNo(0).to_string(), "1");
        assert_eq!(PointNo(67).to_string(), "68");
        assert_eq!(point_range(&INNER_LIP), "61–68");
        assert_eq!(point_range(&(OUTER_LIP.start..INNER_LIP.end)), "49–68");
        assert_eq!(parse_point_no("1"), Ok(0));
        assert_eq!(parse_point_no("68"), Ok(67));
        for bad in ["0", "69", "-1", "x", ""] {
            assert!(parse_point_no(bad).unwrap_err().contains("1–68"), "{bad}");
        }
    }
}
