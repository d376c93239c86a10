//! The phone inventory: one key per phone, whatever symbol set an aligner wrote it in (IPA,
//! ARPAbet with or without stress digits, Festival, HTK/TIMIT labels). Per-phoneme tables,
//! viseme classes, quality prediction and speech group phones by [`PhoneInventory::key_of`];
//! the labels themselves are kept as written for display.
//!
//! The table ships as `data/phones.csv` (its header comments give the conventions chosen) and
//! is embedded at build time; a user's file in the same format replaces it. Lookup order, each
//! step only when the one before found nothing: an empty label is silence; the label as an
//! IPA symbol (case matters: IPA `i` is not ARPAbet's nothing-called-`I`); the label as an
//! ARPAbet/Festival/HTK label, case ignored, trailing stress digits dropped; the IPA symbol
//! with length and stress marks, modifier letters and combining diacritics removed (`ˈuː` →
//! `u`, `pʰ` → `p`, `n̩` → `n`); the centre phone of an HTK/HTS context label (`s-ih+n` →
//! `ih`). A label found nowhere is its own key, as written.

use std::collections::BTreeMap;
use std::sync::LazyLock;

/// The key every silence and pause label maps to.
pub const SILENCE_KEY: &str = "sil";

/// One phone of the inventory.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct InventoryPhone {
    /// The key phones are grouped by (`AA`, `sil`, …).
    pub key: String,
    /// IPA symbols, matched exactly; the first is the phone's IPA name.
    pub ipa: Vec<String>,
    /// Other labels (ARPAbet variants, Festival, HTK, TIMIT), matched ignoring case.
    pub labels: Vec<String>,
}

/// A phone inventory. [`Default`] is `data/phones.csv`.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct PhoneInventory {
    phones: Vec<InventoryPhone>,
    /// IPA symbol → index into `phones`.
    by_ipa: BTreeMap<String, usize>,
    /// Lower-cased key or label → index into `phones`.
    by_label: BTreeMap<String, usize>,
}

/// The built-in table as shipped in `data/`.
pub const DEFAULT_PHONES_CSV: &str = include_str!("../../data/phones.csv");

static DEFAULT_INVENTORY: LazyLock<PhoneInventory> = LazyLock::new(|| {
    PhoneInventory::from_csv_str(DEFAULT_PHONES_CSV).expect("the embedded table parses (tested)")
});

impl Default for PhoneInventory {
    fn default() -> Self {
        DEFAULT_INVENTORY.clone()
    }
}

/// Which lookup map a name goes into.
#[derive(Clone, Copy)]
enum Lookup {
    Ipa,
    Label,
}

/// A problem in a phone table: the 1-based line, and what.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("line {line}: {message}")]
pub struct InventoryError {
    pub line: usize,
    pub message: String,
}

impl PhoneInventory {
    /// Parses the CSV table: `#` comment lines, the header `phone,ipa,labels`, then one phone
    /// a line with its IPA symbols and other labels space-separated (either may be empty).
    ///
    /// # Errors
    /// An [`InventoryError`] naming the line: a wrong header, a row without three fields, an
    /// empty or repeated key, a symbol or label given to two phones or an IPA symbol spelling
    /// another phone's key or label (it could then mean either), a key or label ending in a
    /// digit (lookup drops stress digits), no `sil` row (silences need a key), or no phones.
    ///
    /// ```
    /// let t = lipmap::alignment::PhoneInventory::from_csv_str(
    ///     "phone,ipa,labels\nsil,,pau\nAH,ʌ ə,ax\n",
    /// )
    /// .unwrap();
    /// assert_eq!(t.key_of("ə"), "AH");
    /// assert_eq!(t.key_of("AX0"), "AH");
    /// assert_eq!(t.key_of("PAU"), "sil");
    /// ```
    pub fn from_csv_str(text: &str) -> Result<Self, InventoryError> {
        let err = |line: usize, message: String| InventoryError { line, message };
        let crate::table_text::CsvRows { rows, last_line } =
            crate::table_text::csv_rows(text, "phone,ipa,labels")
                .map_err(|(line, message)| err(line, message))?;
        let mut inv =
            Self { phones: Vec::new(), by_ipa: BTreeMap::new(), by_label: BTreeMap::new() };
        let mut lines = Vec::new();
        for (line, row) in rows {
            let f: Vec<&str> = row.splitn(3, ',').map(str::trim).collect();
            let [key, ipa, labels] = f[..] else {
                return Err(err(line, "expected three fields: phone,ipa,labels".into()));
            };
            if key.is_empty() || key.contains(char::is_whitespace) {
                return Err(err(line, format!("phone `{key}`: a key is one non-empty word")));
            }
            let phone = InventoryPhone {
                key: key.to_string(),
                ipa: ipa.split_whitespace().map(str::to_string).collect(),
                labels: labels.split_whitespace().map(str::to_string).collect(),
            };
            let i = inv.phones.len();
            let says = |what: &str, name: &str, whose: Option<String>| match (what, whose) {
                (_, None) => format!("{what} `{name}` of `{key}` is listed twice"),
                ("phone", Some(o)) => format!("phone `{key}` is already a label of `{o}`"),
                (_, Some(o)) => format!("{what} `{name}` of `{key}` already names `{o}`"),
            };
            let names = std::iter::once(("phone", key))
                .chain(phone.labels.iter().map(|l| ("label", l.as_str())));
            for (what, name) in names {
                if name.ends_with(|c: char| c.is_ascii_digit()) {
                    return Err(err(
                        line,
                        format!(
                            "{what} `{name}` ends in a digit (stress digits are dropped before lookup)"
                        ),
                    ));
                }
                inv.claim(Lookup::Label, &name.to_lowercase(), i)
                    .map_err(|whose| err(line, says(what, name, whose)))?;
            }
            for s in &phone.ipa {
                inv.claim(Lookup::Ipa, s, i)
                    .map_err(|whose| err(line, says("IPA symbol", s, whose)))?;
            }
            inv.phones.push(phone);
            lines.push(line);
        }
        // IPA symbols are looked up first, so one that spells another phone's key or label
        // would take that label away from it.
        for (i, p) in inv.phones.iter().enumerate() {
            for name in std::iter::once(&p.key).chain(&p.labels) {
                if let Some(&o) = inv.by_ipa.get(name.as_str()).filter(|&&o| o != i) {
                    let line = lines[i].max(lines[o]);
                    let owner = &inv.phones[o].key;
                    let msg = format!(
                        "`{name}` is a label of `{}` and an IPA symbol of `{owner}`",
                        p.key
                    );
                    return Err(err(line, msg));
                }
            }
        }
        if inv.phones.is_empty() {
            return Err(err(last_line, "no phones".into()));
        }
        if !inv.phones.iter().any(|p| p.key == SILENCE_KEY) {
            return Err(err(last_line, format!("no `{SILENCE_KEY}` row (silences need a key)")));
        }
        Ok(inv)
    }

    /// Records that `name` in one lookup map names phone `i`, unless a phone has it already:
    /// then gives that phone's key, or `None` when it is phone `i` itself.
    fn claim(&mut self, lookup: Lookup, name: &str, i: usize) -> Result<(), Option<String>> {
        let map = match lookup {
            Lookup::Ipa => &mut self.by_ipa,
            Lookup::Label => &mut self.by_label,
        };
        match map.get(name) {
            Some(&o) if o == i => Err(None),
            Some(&o) => Err(Some(self.phones[o].key.clone())),
            None => {
                map.insert(name.to_string(), i);
                Ok(())
            }
        }
    }

    /// The phones, in table order.
    pub fn phones(&self) -> &[InventoryPhone] {
        &self.phones
    }

    /// The inventory phone a label names, by the lookup order of the module notes.
    pub fn phone_of(&self, label: &str) -> Option<&InventoryPhone> {
        self.index_of(label.trim()).map(|i| &self.phones[i])
    }

    /// The key a label is grouped by: its inventory phone's key, else the label as written
    /// (trimmed). Stress digits, case and symbol set do not matter; the label itself is kept
    /// for display.
    ///
    /// ```
    /// let t = lipmap::alignment::PhoneInventory::default();
    /// assert_eq!(t.key_of("AA1"), "AA");
    /// assert_eq!(t.key_of("ˈɑː"), "AA");
    /// assert_eq!(t.key_of("i"), "IY");
    /// assert_eq!(t.key_of("sp"), "sil");
    /// assert_eq!(t.key_of("œ"), "œ");
    /// ```
    pub fn key_of(&self, label: &str) -> String {
        match self.phone_of(label) {
            Some(p) => p.key.clone(),
            None => label.trim().to_string(),
        }
    }

    /// Whether a label is a silence or pause.
    pub fn is_silence(&self, label: &str) -> bool {
        self.phone_of(label).is_some_and(|p| p.key == SILENCE_KEY)
    }

    fn index_of(&self, label: &str) -> Option<usize> {
        if label.is_empty() {
            return self.phones.iter().position(|p| p.key == SILENCE_KEY);
        }
        if let Some(&i) = self.by_ipa.get(label) {
            return Some(i);
        }
        let unstressed = label.trim_end_matches(|c: char| c.is_ascii_digit());
        if let Some(&i) = self.by_label.get(&unstressed.to_lowercase()) {
            return Some(i);
        }
        let bare: String = label.chars().filter(|&c| !is_ipa_mark(c)).collect();
        if !bare.is_empty()
            && let Some(&i) = self.by_ipa.get(&bare)
        {
            return Some(i);
        }
        let centre = context_centre(label)?;
        if centre == label { None } else { self.index_of(centre) }
    }
}

/// Length and stress marks, modifier letters and combining diacritics: marks on a phone that
/// do not change which phone of English it is. `ASCII :` and `'` stand in for `ː` and `ˈ` in
/// hand-typed transcriptions.
fn is_ipa_mark(c: char) -> bool {
    matches!(c, ':' | '\'' | '\u{02B0}'..='\u{02FF}' | '\u{0300}'..='\u{036F}')
}

/// The centre phone of an HTK triphone (`l-c+r`, `l-c`, `c+r`) or HTS full-context label
/// (`a^b-c+d=e@…`): after the last `-` before the first `+`. `None` when the label has neither.
fn context_centre(label: &str) -> Option<&str> {
    if !label.contains(['-', '+']) {
        return None;
    }
    let left = label.split('+').next().unwrap_or(label);
    let centre = left.rsplit('-').next().unwrap_or(left);
    (!centre.is_empty()).then_some(centre)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The 39 CMUdict ARPAbet phones.
    const CMU: &str = "AA AE AH AO AW AY B CH D DH EH ER EY F G HH IH IY JH K L M N NG OW OY P R \
                       S SH T TH UH UW V W Y Z ZH";

    fn assert_keys(t: &PhoneInventory, cases: &[(&str, &str)]) {
        for &(label, key) in cases {
            assert_eq!(t.key_of(label), key, "{label}");
        }
    }

    #[test]
    fn every_cmu_phone_is_a_key_with_an_ipa_name() {
        let t = PhoneInventory::default();
        for p in CMU.split_whitespace() {
            let phone = t.phone_of(p).unwrap_or_else(|| panic!("{p} missing"));
            assert_eq!(phone.key, p);
            assert!(!phone.ipa.is_empty(), "{p} has no IPA symbol");
            assert_eq!(t.key_of(&phone.ipa[0]), p, "{p}'s IPA name maps back");
        }
        assert_eq!(t.phones().len(), 39 + 2);
    }

    #[test]
    fn arpabet_stress_and_case_are_dropped_for_lookup() {
        let t = PhoneInventory::default();
        assert_keys(&t, &[("AA1", "AA"), ("uw0", "UW"), ("Ah2", "AH"), ("ZH", "ZH")]);
    }

    #[test]
    fn ipa_keeps_its_case_and_sheds_its_marks() {
        let t = PhoneInventory::default();
        // praat's mary.TextGrid: "m ə r i r o l d θ ə b œ r l".
        let mary: Vec<String> =
            "m ə r i r o l d θ ə b œ r l".split(' ').map(|l| t.key_of(l)).collect();
        assert_eq!(mary.join(" "), "M AH R IY R OW L D TH AH B œ R L");
        assert_keys(
            &t,
            &[
                ("ˈuː", "UW"),
                ("iː", "IY"),
                ("ɪ", "IH"),
                ("eɪ", "EY"),
                ("aʊ", "AW"),
                ("t͡ʃ", "CH"),
                ("pʰ", "P"),
                ("n̩", "N"),
                ("ɜ˞", "ER"),
                ("ɾ", "T"),
                ("j", "Y"),
                ("ʔ", "Q"),
            ],
        );
    }

    #[test]
    fn festival_htk_and_timit_labels_fold_to_cmu_keys() {
        let t = PhoneInventory::default();
        // Festival's segments of "bin blue at f two now" (radio phone set, lower case).
        let festival: Vec<String> =
            "pau b ih n b l uw ae t eh f t uw n aw pau".split(' ').map(|l| t.key_of(l)).collect();
        assert_eq!(festival.join(" "), "sil B IH N B L UW AE T EH F T UW N AW sil");
        assert_keys(
            &t,
            &[
                ("ax", "AH"),
                ("axr", "ER"),
                ("ix", "IH"),
                ("dx", "T"),
                ("bcl", "B"),
                ("h#", "sil"),
                ("SIL", "sil"),
                ("+NSN+", "sil"),
                ("ax-h", "AH"),
                ("s-ih+n", "IH"),
                ("sil-b+ih", "B"),
                ("x^x-pau+b=ih@x_x/A:0_0_0", "sil"),
            ],
        );
    }

    proptest::proptest! {
        #![proptest_config(proptest::prelude::ProptestConfig::with_cases(256))]

        /// Any label gets a key, and a label the table names keeps its phone's key.
        #[test]
        fn any_label_gets_a_key(label in "\\PC{0,12}") {
            let t = PhoneInventory::default();
            let key = t.key_of(&label);
            if let Some(p) = t.phone_of(&label) {
                proptest::prop_assert_eq!(&p.key, &key);
            } else {
                proptest::prop_assert_eq!(key.as_str(), label.trim());
            }
        }

        /// Any text parses into a table or an error, and a parsed table's keys are their own.
        #[test]
        fn any_table_text_parses_or_errs(rows in proptest::collection::vec("[a-zA-Zɑə#0-9 ,:+-]{0,16}", 0..8)) {
            let text = format!("phone,ipa,labels\nsil,,\n{}", rows.join("\n"));
            if let Ok(t) = PhoneInventory::from_csv_str(&text) {
                for p in t.phones() {
                    proptest::prop_assert_eq!(&t.key_of(&p.key), &p.key);
                }
            }
        }
    }

    #[test]
    fn silences_and_unknown_labels() {
        let t = PhoneInventory::default();
        for s in ["", "  ", "sil", "sp", "pau", "#", "<sil>", "_"] {
            assert!(t.is_silence(s), "{s:?}");
        }
        assert!(!t.is_silence("B"));
        // Unknown labels keep their own spelling (no case folding).
        assert_eq!(t.key_of(" PT "), "PT");
        assert_eq!(t.key_of("x"), "x");
        assert_eq!(t.key_of("œ"), "œ");
        assert_eq!(t.key_of("a-"), "a-");
        assert!(!t.is_silence("œ"));
    }

    #[test]
    fn bad_tables_say_where() {
        let e = |text: &str| PhoneInventory::from_csv_str(text).unwrap_err().to_string();
        assert_eq!(e(""), "line 1: empty file");
        assert!(e("phone,ipa\n").contains("expected the header"));
        assert_eq!(
            e("phone,ipa,labels\nsil,,\nAA\n"),
            "line 3: expected three fields: phone,ipa,labels"
        );
        assert_eq!(
            e("phone,ipa,labels\nsil,,\nAA,ɑ,\nAO,ɑ,\n"),
            "line 4: IPA symbol `ɑ` of `AO` already names `AA`"
        );
        assert_eq!(
            e("phone,ipa,labels\nsil,,\nAH,,ax\nAX,,\n"),
            "line 4: phone `AX` is already a label of `AH`"
        );
        assert_eq!(
            e("phone,ipa,labels\nsil,,pau pau\n"),
            "line 2: label `pau` of `sil` is listed twice"
        );
        assert_eq!(e("phone,ipa,labels\nAA,ɑ,\n"), "line 2: no `sil` row (silences need a key)");
        assert!(e("phone,ipa,labels\n,ɑ,\n").contains("a key is one non-empty word"));
        assert_eq!(
            e("phone,ipa,labels\nsil,,\nAA,ɑ A,\nA,,\n"),
            "line 4: `A` is a label of `A` and an IPA symbol of `AA`"
        );
        assert_eq!(
            e("phone,ipa,labels\nsil,,\nT,,t2\n"),
            "line 3: label `t2` ends in a digit (stress digits are dropped before lookup)"
        );
        // Case tells IPA from ARPAbet: IPA `a` and label `A` may name two phones.
        let t = PhoneInventory::from_csv_str("phone,ipa,labels\nsil,,\nAE,a,\nAA,,A\n").unwrap();
        assert_eq!((t.key_of("a"), t.key_of("A")), ("AE".to_string(), "AA".to_string()));
    }
}
