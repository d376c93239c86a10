//! Phoneme alignments: timed phone intervals from a forced aligner, which video frames each
//! phone covers, and the phone inventory ([`inventory`]) that groups labels written in any
//! symbol set under one key.

pub mod inventory;

pub use inventory::{DEFAULT_PHONES_CSV, InventoryPhone, PhoneInventory, SILENCE_KEY};
use serde::{Deserialize, Serialize};

/// One phone interval, times in seconds, covering `[start, end)`. The label is kept as the
/// aligner wrote it (stress digits, IPA marks); grouping goes through
/// [`PhoneInventory::key_of`].
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

/// Shortest phone a phone file may hold, in seconds. Aligners work in 10 ms frames and no
/// phone is spoken in less than a few of them; a phone shorter than a millisecond (zero
/// long, or a thousand phones of a nanosecond) is a broken file, not speech.
pub const MIN_PHONE_S: f64 = 1e-3;

impl Phone {
    /// The rule for a phone read from a file: it lasts at least [`MIN_PHONE_S`] (so neither
    /// zero nor a negative time). Where a label must be written out (CSV, HTK, xlabel, unlike
    /// a TextGrid's empty interval, which is a silence), [`Phone::check_label`] too.
    ///
    /// # Errors
    /// A message naming the phone's label and times.
    pub fn check_duration(&self) -> Result<(), String> {
        let d = self.end - self.start;
        if d >= MIN_PHONE_S {
            return Ok(());
        }
        let what = if d < 0.0 {
            "ends before it starts".to_string()
        } else if d == 0.0 {
            "lasts no time".to_string()
        } else {
            format!(
                "lasts {} s, less than the {MIN_PHONE_S} s a phone takes",
                crate::math::short_number(d)
            )
        };
        Err(format!(
            "phone `{}` ({}–{} s) {what}",
            crate::io::pts::shorten(&self.label),
            self.start,
            self.end
        ))
    }

    /// A label that is not empty (nor only spaces).
    ///
    /// # Errors
    /// A message naming the phone's times.
    pub fn check_label(&self) -> Result<(), String> {
        if self.label.trim().is_empty() {
            return Err(format!("the phone at {}–{} s has an empty label", self.start, self.end));
        }
        Ok(())
    }
}

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
    fn frames_cover_half_open_interval() {
        let p = Phone { start: 0.5, end: 1.0, label: "AA".into() };
        assert_eq!(Alignment::frames_of(&p, 10.0), 5..10);
    }
}
