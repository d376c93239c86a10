//! The phone inventory on real aligners' output (`../shared/data/speech`, skipped with a notice
//! when absent): praat's and eSpeak's IPA, Festival's segments and pocketsphinx's ARPAbet of one
//! GRID sentence map to the same keys; praatio's ARPAbet `bobby` matches pocketsphinx's; the
//! IPA `mary` keeps every English phone. And the phone set SAQP builds sees IPA and ARPAbet
//! spellings of one phone as one phone.

use lipmap::alignment::{Alignment, PhoneInventory};
use lipmap::io::alignment_format::read_alignment;
use lipmap::saqp::PhoneSet;
use lipmap::testdata::shared;

/// The keys of `labels`, silences dropped.
fn keys<'a>(labels: impl IntoIterator<Item = &'a str>) -> String {
    let inv = PhoneInventory::default();
    labels
        .into_iter()
        .filter(|l| !inv.is_silence(l))
        .map(|l| inv.key_of(l))
        .collect::<Vec<_>>()
        .join(" ")
}

fn alignment_keys(a: &Alignment) -> String {
    keys(a.phones.iter().map(|p| p.label.as_str()))
}

/// The phone labels of a pocketsphinx JSON alignment (`[{w, phones: [{p, b, d}]}]`).
fn pocketsphinx_labels(text: &str) -> Vec<String> {
    let words: serde_json::Value = serde_json::from_str(text).unwrap();
    let mut labels = Vec::new();
    for w in words.as_array().unwrap() {
        for p in w["phones"].as_array().into_iter().flatten() {
            labels.push(p["p"].as_str().unwrap().to_string());
        }
    }
    labels
}

/// The phonemes of eSpeak NG's event listing (`start_ms end_ms phoneme`, `W` word lines, `#`
/// comments).
fn espeak_labels(text: &str) -> Vec<String> {
    text.lines()
        .filter(|l| !l.starts_with(['#', 'W']))
        .filter_map(|l| {
            let f: Vec<&str> = l.split_whitespace().collect();
            (f.len() >= 2).then(|| f.get(2).copied().unwrap_or("").to_string())
        })
        .collect()
}

const BIN_BLUE: &str = "B IH N B L UW AE T EH F T UW N AW";

#[test]
fn four_aligners_of_one_sentence_give_the_same_phones() {
    let Some(dir) = shared("data/speech/generated") else { return };
    let praat = read_alignment(&dir.join("praat_bin_blue.TextGrid"), None).unwrap();
    assert_eq!(alignment_keys(&praat), BIN_BLUE, "praat (IPA)");
    let festival = read_alignment(&dir.join("festival_segs.txt"), None).unwrap();
    assert_eq!(alignment_keys(&festival), BIN_BLUE, "Festival");
    let espeak =
        espeak_labels(&std::fs::read_to_string(dir.join("espeak_bin_blue_phonemes.txt")).unwrap());
    assert!(espeak.iter().any(|l| l == "ɾ") && espeak.iter().any(|l| l == "uː"), "{espeak:?}");
    assert_eq!(keys(espeak.iter().map(String::as_str)), BIN_BLUE, "eSpeak (IPA)");
    let ps = pocketsphinx_labels(
        &std::fs::read_to_string(dir.join("ps_festival_bin_blue.json")).unwrap(),
    );
    assert_eq!(keys(ps.iter().map(String::as_str)), BIN_BLUE, "pocketsphinx");
}

#[test]
fn arpabet_with_stress_matches_a_second_aligner_and_ipa_keeps_english_phones() {
    let Some(dir) = shared("data/speech") else { return };
    let bobby = read_alignment(&dir.join("praatio_examples/bobby_phones.TextGrid"), None).unwrap();
    assert!(bobby.phones.iter().any(|p| p.label == "AA1"), "stress digits kept as written");
    assert_eq!(alignment_keys(&bobby), "B AA B IY R IH PT DH AH L EH JH ER");
    let ps =
        pocketsphinx_labels(&std::fs::read_to_string(dir.join("generated/ps_bobby.json")).unwrap());
    // The TextGrid's annotator typed `PT` for /p t/; everything else agrees.
    assert_eq!(keys(ps.iter().map(String::as_str)), alignment_keys(&bobby).replace("PT", "P T"));

    let mary = read_alignment(&dir.join("praatio_examples/mary.TextGrid"), None).unwrap();
    assert_eq!(alignment_keys(&mary), "M AH R IY R OW L D TH AH B œ R L");
    let inv = PhoneInventory::default();
    let outside: Vec<&str> = mary
        .phones
        .iter()
        .map(|p| p.label.as_str())
        .filter(|l| inv.phone_of(l).is_none())
        .collect();
    assert_eq!(outside, ["œ"], "only œ is not an English phone");
}

#[test]
fn saqp_phone_ids_join_ipa_and_arpabet_spellings() {
    let mut set = PhoneSet::default();
    let (inv, visemes) = (PhoneInventory::default(), lipmap::eval::VisemeTable::default());
    let mut intern = |l: &str| set.intern(l, &inv, &visemes);
    let corpus: Vec<u16> = ["AH0", "IY1", "OW0", "TH", "sil", "M"].map(&mut intern).to_vec();
    let ipa: Vec<u16> = ["ə", "i", "o", "θ", "", "m"].map(&mut intern).to_vec();
    let oe = intern("œ");
    assert_eq!(ipa, corpus);
    assert_eq!(set.label(ipa[0]), "AH");
    assert!(!corpus.contains(&oe));
    assert_eq!(set.label(oe), "œ");
}
