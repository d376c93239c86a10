//! The phoneme → viseme class table used to group per-phoneme errors: ARPAbet phones (stress
//! stripped by `grouping_label`), IPA symbols mapped to ARPAbet where the mapping is plain.
//!
//! The default grouping is the 13-class table of Neti et al. (2000), "Audio-visual speech
//! recognition", final workshop report, CLSP, Johns Hopkins University (widely reused in
//! lip-reading work): four vowel classes, eight consonant classes and silence. Its
//! placements are kept as published, including /hh/ with the open vowels and /w/ with the
//! velars; phones it does not list are added where their articulation is unambiguous
//! (AXR with ER, IX with IH, UX with UW, DX with T/D, EM with M, ENG/NX with NG, WH with W).
//! The table ships as `data/visemes.toml`, embedded at build time; a user's file in the
//! same format replaces it (`io::viseme_table` reads it).

use crate::alignment::grouping_label;
use serde::{Deserialize, Serialize};
use std::sync::LazyLock;

/// One viseme class: an id (table column / row label), a description, its ARPAbet phones.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct VisemeClass {
    pub id: String,
    pub description: String,
    /// Upper-case ARPAbet without stress digits; `sil` for silence.
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
    /// list of upper-case ARPAbet phones without stress digits, `sil` for silence).
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
    /// assert_eq!(t.class_of("b"), Some("E"));
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

/// IPA (broad, General American / RP) → ARPAbet for the symbols with a plain equivalent.
const IPA_TO_ARPABET: [(&str, &str); 53] = [
    ("p", "P"),
    ("b", "B"),
    ("m", "M"),
    ("f", "F"),
    ("v", "V"),
    ("θ", "TH"),
    ("ð", "DH"),
    ("t", "T"),
    ("d", "D"),
    ("n", "N"),
    ("s", "S"),
    ("z", "Z"),
    ("ʃ", "SH"),
    ("ʒ", "ZH"),
    ("tʃ", "CH"),
    ("t͡ʃ", "CH"),
    ("ʧ", "CH"),
    ("dʒ", "JH"),
    ("d͡ʒ", "JH"),
    ("ʤ", "JH"),
    ("k", "K"),
    ("g", "G"),
    ("ɡ", "G"),
    ("ŋ", "NG"),
    ("l", "L"),
    ("ɫ", "L"),
    ("r", "R"),
    ("ɹ", "R"),
    ("ɾ", "DX"),
    ("j", "Y"),
    ("w", "W"),
    ("ʍ", "WH"),
    ("h", "HH"),
    ("ɑ", "AA"),
    ("ɒ", "AA"),
    ("a", "AA"),
    ("æ", "AE"),
    ("ʌ", "AH"),
    ("ə", "AX"),
    ("ɔ", "AO"),
    ("ɛ", "EH"),
    ("ɚ", "ER"),
    ("ɝ", "ER"),
    ("ɜ", "ER"),
    ("ɪ", "IH"),
    ("i", "IY"),
    ("u", "UW"),
    ("ʊ", "UH"),
    ("e", "EY"),
    ("o", "OW"),
    ("aɪ", "AY"),
    ("aʊ", "AW"),
    ("ɔɪ", "OY"),
];

/// IPA diphthongs written with a following glide symbol.
const IPA_DIPHTHONGS: [(&str, &str); 3] = [("eɪ", "EY"), ("oʊ", "OW"), ("əʊ", "OW")];

/// The ARPAbet phone for a label: ARPAbet passes through `grouping_label` (stress stripped,
/// upper-cased, silence → `sil`); IPA has length and stress marks removed and is looked up.
/// `None` for a symbol with no plain ARPAbet equivalent.
///
/// ```
/// use lipmap::eval::visemes::to_arpabet;
/// assert_eq!(to_arpabet("AA1").as_deref(), Some("AA"));
/// assert_eq!(to_arpabet("ˈuː").as_deref(), Some("UW"));
/// assert_eq!(to_arpabet("sp").as_deref(), Some("sil"));
/// ```
pub fn to_arpabet(label: &str) -> Option<String> {
    let g = grouping_label(label);
    if g == "sil" || ARPABET.contains(&g.as_str()) {
        return Some(g);
    }
    // Not ARPAbet (single IPA letters such as `j`, `i`, `a` upper-case into non-phones).
    let ipa: String =
        label.trim().chars().filter(|c| !matches!(c, 'ː' | 'ˑ' | 'ˈ' | 'ˌ' | ':')).collect();
    IPA_DIPHTHONGS
        .iter()
        .chain(IPA_TO_ARPABET.iter())
        .find(|(sym, _)| *sym == ipa)
        .map(|(_, a)| a.to_string())
}

/// ARPAbet phones recognised as such: the 39 of CMUdict plus TIMIT-style extras.
pub const ARPABET: [&str; 50] = [
    "AA", "AE", "AH", "AO", "AW", "AY", "B", "CH", "D", "DH", "EH", "ER", "EY", "F", "G", "HH",
    "IH", "IY", "JH", "K", "L", "M", "N", "NG", "OW", "OY", "P", "R", "S", "SH", "T", "TH", "UH",
    "UW", "V", "W", "Y", "Z", "ZH", "AX", "AXR", "IX", "UX", "DX", "EL", "EM", "EN", "NX", "ENG",
    "WH",
];

impl VisemeTable {
    /// The class id of a phone label (ARPAbet or IPA), `None` when the table lacks it.
    ///
    /// ```
    /// let t = lipmap::eval::VisemeTable::default();
    /// assert_eq!(t.class_of("B"), Some("E"));
    /// assert_eq!(t.class_of("uw1"), Some("V2"));
    /// assert_eq!(t.class_of("ʃ"), Some("D"));
    /// ```
    pub fn class_of(&self, label: &str) -> Option<&str> {
        let a = to_arpabet(label)?;
        self.classes.iter().find(|c| c.phones.contains(&a)).map(|c| c.id.as_str())
    }

    /// The description of a class id.
    pub fn description(&self, id: &str) -> Option<&str> {
        self.classes.iter().find(|c| c.id == id).map(|c| c.description.as_str())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The 39 CMU ARPAbet phones, all of which must have a class.
    const CMU: &str = "AA AE AH AO AW AY B CH D DH EH ER EY F G HH IH IY JH K L M N NG OW OY P R \
                       S SH T TH UH UW V W Y Z ZH";

    #[test]
    fn every_cmu_phone_has_exactly_one_class() {
        let t = VisemeTable::default();
        for p in CMU.split_whitespace() {
            let n = t.classes.iter().filter(|c| c.phones.iter().any(|q| q == p)).count();
            assert_eq!(n, 1, "{p} is in {n} classes");
        }
        assert_eq!(t.classes.len(), 13);
    }

    #[test]
    fn bilabials_rounded_and_silence() {
        let t = VisemeTable::default();
        for p in ["P", "b", "M0"] {
            assert_eq!(t.class_of(p), Some("E"), "{p}");
        }
        assert_eq!(t.class_of("OW0"), Some("V2"));
        assert_eq!(t.class_of("pau"), Some("S"));
        assert_eq!(t.class_of("F"), Some("G"));
        assert_eq!(t.class_of("XYZ"), None);
    }

    #[test]
    fn ipa_symbols_map_where_plain() {
        let t = VisemeTable::default();
        assert_eq!(t.class_of("m"), Some("E"));
        assert_eq!(t.class_of("ɪ"), Some("V4"));
        assert_eq!(t.class_of("eɪ"), Some("V3"));
        assert_eq!(t.class_of("ð"), Some("F"));
        assert_eq!(t.class_of("ʉ"), None);
        // Single IPA letters that are not ARPAbet phones once upper-cased.
        assert_eq!(t.class_of("j"), Some("A"));
        assert_eq!(t.class_of("iː"), Some("V4"));
        assert_eq!(t.class_of("h"), Some("V1"));
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
