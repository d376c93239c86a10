//! The phoneme → viseme class table used to group per-phoneme errors. It lists phone keys of
//! the phone inventory ([`crate::alignment::PhoneInventory`], `data/phones.csv`), so IPA,
//! ARPAbet, Festival and HTK labels reach it through
//! [`PhoneInventory::key_of`](crate::alignment::PhoneInventory::key_of).
//!
//! The default grouping is the 13-class table of Neti et al. (2000), "Audio-visual speech
//! recognition", final workshop report, CLSP, Johns Hopkins University (widely reused in
//! lip-reading work): four vowel classes, eight consonant classes and silence. Its
//! placements are kept as published, including /hh/ with the open vowels and /w/ with the
//! velars; phones it does not list are added where their articulation is unambiguous
//! (AXR with ER, IX with IH, UX with UW, DX with T/D, EM with M, ENG/NX with NG, WH with W);
//! the built-in inventory folds those into CMUdict's phones, so they matter only to a user's
//! inventory that keeps them apart. The table ships as `data/visemes.toml`, embedded at build time; a user's file in the
//! same format replaces it (`io::viseme_table` reads it).

use serde::{Deserialize, Serialize};
use std::sync::LazyLock;

/// One viseme class: an id (table column / row label), a description, its phone keys.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct VisemeClass {
    pub id: String,
    pub description: String,
    /// Phone inventory keys (upper-case ARPAbet in the built-in inventory; `sil` for silence).
    pub phones: Vec<String>,
}

/// A phoneme → viseme table. [`Default`] is Neti et al. (2000), see the module docs.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct VisemeTable {
    pub classes: Vec<VisemeClass>,
}

/// The default table as shipped in `data/` (Neti et al. 2000, see the module docs); a user's
/// file in the same format replaces it ([`VisemeTable::from_toml_str`]).
pub const DEFAULT_VISEMES_TOML: &str = include_str!("../../data/visemes.toml");

/// [`DEFAULT_VISEMES_TOML`] parsed once.
static DEFAULT_TABLE: LazyLock<VisemeTable> = LazyLock::new(|| {
    VisemeTable::from_toml_str(DEFAULT_VISEMES_TOML).expect("the embedded table parses (tested)")
});

impl Default for VisemeTable {
    fn default() -> Self {
        DEFAULT_TABLE.clone()
    }
}

/// A problem in a viseme table: the 1-based line when known, and what.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{}{message}", line.map(|l| format!("line {l}: ")).unwrap_or_default())]
pub struct VisemeTableError {
    pub line: Option<usize>,
    pub message: String,
}

impl VisemeTable {
    /// Parses a TOML table: `[[classes]]` entries with `id`, `description` and `phones` (a
    /// list of phone inventory keys, `sil` for silence).
    ///
    /// # Errors
    /// A [`VisemeTableError`] with TOML's line, or naming the class at fault: no classes, an
    /// empty or repeated id, a class without phones, a phone in two classes (a phone must
    /// have one class, or its errors would count twice).
    ///
    /// ```
    /// let t = lipmap::eval::VisemeTable::from_toml_str(
    ///     "[[classes]]\nid = \"E\"\ndescription = \"bilabials\"\nphones = [\"P\", \"B\", \"M\"]\n",
    /// )
    /// .unwrap();
    /// assert_eq!(t.class_of("B"), Some("E"));
    /// ```
    pub fn from_toml_str(text: &str) -> Result<Self, VisemeTableError> {
        let table: Self = toml::from_str(text).map_err(|e| {
            let line = e.span().map(|s| text[..s.start.min(text.len())].matches('\n').count() + 1);
            VisemeTableError { line, message: e.message().to_string() }
        })?;
        let fail = |message: String| Err(VisemeTableError { line: None, message });
        if table.classes.is_empty() {
            return fail("no classes".into());
        }
        for (k, c) in table.classes.iter().enumerate() {
            if c.id.trim().is_empty() {
                return fail(format!("class {}: empty id", k + 1));
            }
            if table.classes[..k].iter().any(|o| o.id == c.id) {
                return fail(format!("class `{}` listed twice", c.id));
            }
            if c.phones.is_empty() {
                return fail(format!("class `{}` has no phones", c.id));
            }
            for p in &c.phones {
                if let Some(o) = table.classes[..=k].iter().find(|o| {
                    o.phones.iter().filter(|q| *q == p).count() > usize::from(o.id == c.id)
                }) {
                    return fail(format!("phone `{p}` is in class `{}` and `{}`", o.id, c.id));
                }
            }
        }
        Ok(table)
    }

    /// The table as TOML, readable by [`VisemeTable::from_toml_str`].
    pub fn to_toml_string(&self) -> String {
        toml::to_string(self).unwrap_or_default()
    }
}

impl VisemeTable {
    /// The class id of a phone inventory key, `None` when the table lacks it. A label as an
    /// aligner wrote it goes through the inventory first.
    ///
    /// ```
    /// let (t, phones) = (lipmap::eval::VisemeTable::default(), lipmap::alignment::PhoneInventory::default());
    /// assert_eq!(t.class_of("B"), Some("E"));
    /// assert_eq!(t.class_of(&phones.key_of("uw1")), Some("V2"));
    /// assert_eq!(t.class_of(&phones.key_of("ʃ")), Some("D"));
    /// ```
    pub fn class_of(&self, key: &str) -> Option<&str> {
        self.classes.iter().find(|c| c.phones.iter().any(|p| p == key)).map(|c| c.id.as_str())
    }

    /// The description of a class id.
    pub fn description(&self, id: &str) -> Option<&str> {
        self.classes.iter().find(|c| c.id == id).map(|c| c.description.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::alignment::PhoneInventory;

    /// Every phone of the built-in inventory (CMUdict's 39 and silence) is in one class; the
    /// glottal stop, which Neti et al. do not place, in none.
    #[test]
    fn every_inventory_phone_but_the_glottal_stop_has_exactly_one_class() {
        let (t, phones) = (VisemeTable::default(), PhoneInventory::default());
        for p in phones.phones() {
            let n = t.classes.iter().filter(|c| c.phones.contains(&p.key)).count();
            assert_eq!(n, usize::from(p.key != "Q"), "{} is in {n} classes", p.key);
        }
        assert_eq!(t.classes.len(), 13);
    }

    #[test]
    fn labels_in_any_symbol_set_reach_their_class_through_the_inventory() {
        let (t, phones) = (VisemeTable::default(), PhoneInventory::default());
        let class = |label: &str| t.class_of(&phones.key_of(label));
        for p in ["P", "b", "M0", "m", "bcl"] {
            assert_eq!(class(p), Some("E"), "{p}");
        }
        for (label, id) in [
            ("OW0", "V2"),
            ("pau", "S"),
            ("", "S"),
            ("F", "G"),
            ("ɪ", "V4"),
            ("eɪ", "V3"),
            ("ð", "F"),
            ("θ", "F"),
            ("j", "A"),
            ("iː", "V4"),
            ("h", "V1"),
            ("ə", "V1"),
            ("o", "V2"),
        ] {
            assert_eq!(class(label), Some(id), "{label}");
        }
        assert_eq!(class("XYZ"), None);
        assert_eq!(class("œ"), None);
    }

    /// The table as first published in the code, before it moved to `data/`.
    const NETI_2000: [(&str, &str, &str); 13] = [
        ("S", "silence", "sil"),
        ("V1", "open and rounding vowels", "AO AH AA ER OY AW HH AXR"),
        ("V2", "rounded vowels", "UW UH OW UX"),
        ("V3", "spread open vowels", "AE EH EY AY"),
        ("V4", "spread close vowels", "IH IY AX IX"),
        ("A", "alveolar semivowels", "L EL R Y"),
        ("B", "alveolar fricatives", "S Z"),
        ("C", "alveolar stops and nasals", "T D N EN DX"),
        ("D", "palato-alveolars", "SH ZH CH JH"),
        ("E", "bilabials", "P B M EM"),
        ("F", "dentals", "TH DH"),
        ("G", "labio-dentals", "F V"),
        ("H", "velars (and /w/)", "NG K G W ENG NX WH"),
    ];

    #[test]
    fn the_embedded_table_is_neti_2000() {
        let expected = VisemeTable {
            classes: NETI_2000
                .iter()
                .map(|(id, d, phones)| VisemeClass {
                    id: id.to_string(),
                    description: d.to_string(),
                    phones: phones.split_whitespace().map(str::to_string).collect(),
                })
                .collect(),
        };
        assert_eq!(VisemeTable::from_toml_str(DEFAULT_VISEMES_TOML).unwrap(), expected);
        assert_eq!(VisemeTable::default(), expected);
        let round = VisemeTable::from_toml_str(&expected.to_toml_string()).unwrap();
        assert_eq!(round, expected);
    }

    #[test]
    fn bad_tables_say_where() {
        let class = |id: &str, phones: &str| {
            format!("[[classes]]\nid = \"{id}\"\ndescription = \"\"\nphones = [{phones}]\n")
        };
        let e = VisemeTable::from_toml_str("[[classes]]\nid = 3\n").unwrap_err();
        assert_eq!(e.line, Some(2), "{e}");
        let twice = class("A", "\"P\"") + &class("B", "\"B\", \"P\"");
        let e = VisemeTable::from_toml_str(&twice).unwrap_err();
        assert_eq!(e.to_string(), "phone `P` is in class `A` and `B`");
        let e =
            VisemeTable::from_toml_str(&(class("A", "\"P\"") + &class("A", "\"B\""))).unwrap_err();
        assert_eq!(e.to_string(), "class `A` listed twice");
        let e = VisemeTable::from_toml_str(&class("A", "\"P\", \"P\"")).unwrap_err();
        assert_eq!(e.to_string(), "phone `P` is in class `A` and `A`");
        assert!(VisemeTable::from_toml_str(&class("A", "")).is_err());
        assert!(VisemeTable::from_toml_str("").is_err());
    }

    #[test]
    fn table_round_trips_through_json() {
        let t = VisemeTable::default();
        let s = serde_json::to_string(&t).unwrap();
        assert_eq!(serde_json::from_str::<VisemeTable>(&s).unwrap(), t);
    }
}
