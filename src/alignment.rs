//! Phoneme alignments: timed phone intervals from a forced aligner, ARPAbet normalisation
//! for grouping, and which video frames each phone covers.

use serde::{Deserialize, Serialize};

/// One phone interval, times in seconds, covering `[start, end)`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Phone {
    pub start: f64,
    pub end: f64,
    pub label: String,
}

/// The phones of one utterance, in time order, non-overlapping.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Alignment {
    pub phones: Vec<Phone>,
}

/// Longest span a phone may end at, in seconds: [`MAX_FRAME`](crate::landmarks::MAX_FRAME)
/// frames at 1 fps, the slowest rate lipmap accepts. Frame tables are sized by the last
/// phone's end × fps, so an end past this is a corrupt file, not a recording.
pub const MAX_PHONE_END_S: f64 = crate::landmarks::MAX_FRAME as f64;

impl Alignment {
    /// Checks every phone's times: finite, `0 ≤ start ≤ end ≤ max_end_s`.
    ///
    /// # Errors
    /// A message naming the first phone at fault (1-based) and its label.
    pub fn check_times(&self, max_end_s: f64) -> Result<(), String> {
        for (i, p) in self.phones.iter().enumerate() {
            let fault = if !(p.start.is_finite() && p.end.is_finite()) {
                "non-finite times"
            } else if p.start < 0.0 {
                "a negative start"
            } else if p.end < p.start {
                "an end before its start"
            } else if p.end > max_end_s {
                "an end past the longest clip lipmap accepts"
            } else {
                continue;
            };
            return Err(format!(
                "phone {} ({:?}, {}–{} s) has {fault}",
                i + 1,
                p.label,
                p.start,
                p.end
            ));
        }
        Ok(())
    }
}

/// Labels aligners use for silence and pauses; grouped together as `sil`.
pub const SILENCE_LABELS: [&str; 8] = ["", "sil", "sp", "spn", "pau", "#", "<sil>", "h#"];

/// The label used for grouping: ARPAbet stress digits stripped (`AA1` -> `AA`), upper-cased
/// when it is ARPAbet, silence variants folded to `sil`; IPA and other labels pass through.
pub fn grouping_label(label: &str) -> String {
    let trimmed = label.trim();
    if SILENCE_LABELS.iter().any(|s| s.eq_ignore_ascii_case(trimmed)) {
        return "sil".to_string();
    }
    let is_arpabet = !trimmed.is_empty() && trimmed.chars().all(|c| c.is_ascii_alphanumeric());
    if is_arpabet {
        trimmed.trim_end_matches(|c: char| c.is_ascii_digit()).to_ascii_uppercase()
    } else {
        trimmed.to_string()
    }
}

impl Alignment {
    /// The phone interval containing time `t` (seconds), if any.
    pub fn phone_at(&self, t: f64) -> Option<&Phone> {
        let i = self.phones.partition_point(|p| p.end <= t);
        self.phones.get(i).filter(|p| p.start <= t && t < p.end)
    }

    /// Frame numbers whose timestamps `frame / fps` fall inside `[start, end)`.
    pub fn frames_of(phone: &Phone, fps: f64) -> std::ops::Range<usize> {
        let first = (phone.start * fps - 1e-9).ceil().max(0.0) as usize;
        let end = (phone.end * fps - 1e-9).ceil().max(0.0) as usize;
        first..end.max(first)
    }

    /// End time of the last phone, 0 when empty.
    pub fn duration(&self) -> f64 {
        self.phones.last().map_or(0.0, |p| p.end)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grouping_strips_stress_and_folds_silence() {
        assert_eq!(grouping_label("AA1"), "AA");
        assert_eq!(grouping_label("uw0"), "UW");
        assert_eq!(grouping_label("sp"), "sil");
        assert_eq!(grouping_label("ɪ"), "ɪ");
    }

    #[test]
    fn frames_cover_half_open_interval() {
        let p = Phone { start: 0.5, end: 1.0, label: "AA".into() };
        assert_eq!(Alignment::frames_of(&p, 10.0), 5..10);
    }
}
