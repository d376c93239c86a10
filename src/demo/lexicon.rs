//! The GRID corpus grammar (command colour preposition letter digit adverb), an ARPAbet
//! lexicon of its whole vocabulary, and a phone-duration model that times a sentence.
//!
//! Pronunciations follow the CMU Pronouncing Dictionary's conventions (ARPAbet, stress digit
//! on vowels: 1 primary, 0 unstressed); where it lists variants the common American one is
//! used (`white` W AY1 T, `zero` Z IH1 R OW0). GRID's letter slot has every letter but W.
//!
//! Durations: a mean per phone class (after Klatt's segmental duration tables, rounded:
//! stressed vowels ~120 ms, diphthongs ~160 ms, unstressed vowels ~70 ms, stops ~75 ms,
//! fricatives ~95 ms, nasals and liquids ~65 ms, glides ~60 ms), lengthened ×1.2 in the last
//! syllable of a word and ×1.35 in the sentence's last word, with ±15 % uniform jitter. GRID
//! is read fast (about 3 words a second), which these values reproduce.

use crate::alignment::{Alignment, Phone};
use rand::Rng;

pub const COMMANDS: [&str; 4] = ["bin", "lay", "place", "set"];
pub const COLOURS: [&str; 4] = ["blue", "green", "red", "white"];
pub const PREPOSITIONS: [&str; 4] = ["at", "by", "in", "with"];
pub const LETTERS: [&str; 25] = [
    "a", "b", "c", "d", "e", "f", "g", "h", "i", "j", "k", "l", "m", "n", "o", "p", "q", "r", "s",
    "t", "u", "v", "x", "y", "z",
];
pub const DIGITS: [&str; 10] =
    ["zero", "one", "two", "three", "four", "five", "six", "seven", "eight", "nine"];
pub const ADVERBS: [&str; 4] = ["again", "now", "please", "soon"];

/// The six slots of a GRID sentence, in order.
pub const SLOTS: [&[&str]; 6] = [&COMMANDS, &COLOURS, &PREPOSITIONS, &LETTERS, &DIGITS, &ADVERBS];

/// The lexicon: every GRID word and its ARPAbet phones.
pub const LEXICON: &[(&str, &[&str])] = &[
    ("bin", &["B", "IH1", "N"]),
    ("lay", &["L", "EY1"]),
    ("place", &["P", "L", "EY1", "S"]),
    ("set", &["S", "EH1", "T"]),
    ("blue", &["B", "L", "UW1"]),
    ("green", &["G", "R", "IY1", "N"]),
    ("red", &["R", "EH1", "D"]),
    ("white", &["W", "AY1", "T"]),
    ("at", &["AE1", "T"]),
    ("by", &["B", "AY1"]),
    ("in", &["IH1", "N"]),
    ("with", &["W", "IH1", "DH"]),
    ("a", &["EY1"]),
    ("b", &["B", "IY1"]),
    ("c", &["S", "IY1"]),
    ("d", &["D", "IY1"]),
    ("e", &["IY1"]),
    ("f", &["EH1", "F"]),
    ("g", &["JH", "IY1"]),
    ("h", &["EY1", "CH"]),
    ("i", &["AY1"]),
    ("j", &["JH", "EY1"]),
    ("k", &["K", "EY1"]),
    ("l", &["EH1", "L"]),
    ("m", &["EH1", "M"]),
    ("n", &["EH1", "N"]),
    ("o", &["OW1"]),
    ("p", &["P", "IY1"]),
    ("q", &["K", "Y", "UW1"]),
    ("r", &["AA1", "R"]),
    ("s", &["EH1", "S"]),
    ("t", &["T", "IY1"]),
    ("u", &["Y", "UW1"]),
    ("v", &["V", "IY1"]),
    ("x", &["EH1", "K", "S"]),
    ("y", &["W", "AY1"]),
    ("z", &["Z", "IY1"]),
    ("zero", &["Z", "IH1", "R", "OW0"]),
    ("one", &["W", "AH1", "N"]),
    ("two", &["T", "UW1"]),
    ("three", &["TH", "R", "IY1"]),
    ("four", &["F", "AO1", "R"]),
    ("five", &["F", "AY1", "V"]),
    ("six", &["S", "IH1", "K", "S"]),
    ("seven", &["S", "EH1", "V", "AH0", "N"]),
    ("eight", &["EY1", "T"]),
    ("nine", &["N", "AY1", "N"]),
    ("again", &["AH0", "G", "EH1", "N"]),
    ("now", &["N", "AW1"]),
    ("please", &["P", "L", "IY1", "Z"]),
    ("soon", &["S", "UW1", "N"]),
];

/// The label of silence before and after a sentence.
pub const SILENCE: &str = "sil";

/// The ARPAbet phones of a GRID word (lower case), if it is in the vocabulary.
pub fn pronounce(word: &str) -> Option<&'static [&'static str]> {
    LEXICON.iter().find(|(w, _)| *w == word).map(|(_, p)| *p)
}

/// A random GRID sentence: one word per slot.
pub fn random_sentence(rng: &mut impl Rng) -> Vec<&'static str> {
    SLOTS.iter().map(|slot| slot[rng.random_range(0..slot.len())]).collect()
}

/// Mean duration (seconds) of a phone before context lengthening.
pub fn mean_duration(phone: &str) -> f64 {
    let base = phone.trim_end_matches(|c: char| c.is_ascii_digit());
    let unstressed = phone.ends_with('0');
    match base {
        "AY" | "AW" | "OY" | "EY" | "OW" => {
            if unstressed {
                0.09
            } else {
                0.16
            }
        }
        "AA" | "AE" | "AH" | "AO" | "EH" | "ER" | "IH" | "IY" | "UH" | "UW" => {
            if unstressed {
                0.07
            } else {
                0.12
            }
        }
        "P" | "B" | "T" | "D" | "K" | "G" => 0.075,
        "CH" | "JH" => 0.09,
        "F" | "V" | "TH" | "DH" | "S" | "Z" | "SH" | "ZH" | "HH" => 0.095,
        "M" | "N" | "NG" | "L" | "R" => 0.065,
        "W" | "Y" => 0.06,
        _ => 0.08,
    }
}

/// Duration of the silence before and after the sentence (seconds).
pub const LEAD_SILENCE: f64 = 0.25;
pub const TRAIL_SILENCE: f64 = 0.3;

/// Times the phones of `words` with the duration model, framed by silences.
///
/// # Errors
/// Returns the first word that is not in the GRID vocabulary.
pub fn time_sentence(words: &[&str], rng: &mut impl Rng) -> Result<Alignment, String> {
    let mut phones = vec![Phone { start: 0.0, end: LEAD_SILENCE, label: SILENCE.to_string() }];
    let mut t = LEAD_SILENCE;
    for (wi, word) in words.iter().enumerate() {
        let pron = pronounce(word).ok_or_else(|| format!("`{word}` is not a GRID word"))?;
        let last_vowel = pron.iter().rposition(|p| p.ends_with(|c: char| c.is_ascii_digit()));
        for (pi, p) in pron.iter().enumerate() {
            let mut d = mean_duration(p);
            if last_vowel.is_some_and(|v| pi >= v) {
                d *= 1.2;
            }
            if wi + 1 == words.len() {
                d *= 1.35;
            }
            d *= rng.random_range(0.85..1.15);
            // Round to milliseconds so files show clean times.
            let end = ((t + d) * 1000.0).round() / 1000.0;
            phones.push(Phone { start: t, end, label: p.to_string() });
            t = end;
        }
    }
    let end = ((t + TRAIL_SILENCE) * 1000.0).round() / 1000.0;
    phones.push(Phone { start: t, end, label: SILENCE.to_string() });
    Ok(Alignment { phones })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;

    #[test]
    fn every_slot_word_is_in_the_lexicon_and_w_is_not_a_letter() {
        for slot in SLOTS {
            for w in slot {
                assert!(pronounce(w).is_some(), "{w}");
            }
        }
        assert!(!LETTERS.contains(&"w"));
        assert_eq!(LEXICON.len(), 4 + 4 + 4 + 25 + 10 + 4);
    }

    #[test]
    fn sentences_are_contiguous_and_last_about_two_seconds() {
        let mut rng = rand::rngs::StdRng::seed_from_u64(7);
        for _ in 0..20 {
            let words = random_sentence(&mut rng);
            let a = time_sentence(&words, &mut rng).unwrap();
            assert!(a.phones.windows(2).all(|w| (w[0].end - w[1].start).abs() < 1e-12));
            assert!((1.3..3.5).contains(&a.duration()), "{words:?}: {}", a.duration());
        }
        assert!(time_sentence(&["bin", "purple"], &mut rng).is_err());
    }
}
