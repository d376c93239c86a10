//! The phoneme → viseme class table used to group per-phoneme errors: ARPAbet phones (stress
//! stripped by `grouping_label`), IPA symbols mapped to ARPAbet where the mapping is plain.
//!
//! The default grouping is the 13-class table of Neti et al. (2000), "Audio-visual speech
//! recognition", final workshop report, CLSP, Johns Hopkins University (widely reused in
//! lip-reading work): four vowel classes, eight consonant classes and silence. Its
//! placements are kept as published, including /hh/ with the open vowels and /w/ with the
//! velars; phones it does not list are added where their articulation is unambiguous
//! (AXR with ER, IX with IH, UX with UW, DX with T/D, EM with M, ENG/NX with NG, WH with W).
//! A user can supply another table (serde: a list of classes with their phones).

use crate::alignment::grouping_label;
use serde::{Deserialize, Serialize};

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

/// The default classes: (id, description, phones).
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

impl Default for VisemeTable {
    fn default() -> Self {
        let classes = NETI_2000
            .iter()
            .map(|(id, d, phones)| VisemeClass {
                id: id.to_string(),
                description: d.to_string(),
                phones: phones.split_whitespace().map(str::to_string).collect(),
            })
            .collect();
        Self { classes }
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

    #[test]
    fn table_round_trips_through_json() {
        let t = VisemeTable::default();
        let s = serde_json::to_string(&t).unwrap();
        assert_eq!(serde_json::from_str::<VisemeTable>(&s).unwrap(), t);
    }
}
