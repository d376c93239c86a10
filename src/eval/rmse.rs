//! RMSE between the video's and the head's W, H, P trajectories: per sentence, per phoneme
//! (over the frames inside each occurrence, then averaged over occurrences) and per viseme.
//!
//! Frames where either trajectory has no value are skipped; a phone whose interval holds no
//! frame with both values contributes no occurrence for that measure.

use super::visemes::VisemeTable;
use super::{PerMeasure, Utterance};
use crate::alignment::{Alignment, PhoneInventory};
use crate::measure::Measure;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::ops::Range;

/// RMSE of `estimate` against `reference` over `frames` (clipped to the data), skipping
/// frames where either is `None` or non-finite. `None` when no frame has both.
///
/// ```
/// let a = [Some(0.0), Some(1.0), None, Some(2.0)];
/// let b = [Some(1.0), Some(1.0), Some(5.0), Some(3.0)];
/// // Errors 1, 0, (skipped), 1 → √(2/3).
/// let r = lipmap::eval::rmse::rmse_over(&a, &b, 0..4).unwrap();
/// assert!((r - (2.0f64 / 3.0).sqrt()).abs() < 1e-12);
/// ```
pub fn rmse_over(
    reference: &[Option<f64>],
    estimate: &[Option<f64>],
    frames: Range<usize>,
) -> Option<f64> {
    let end = frames.end.min(reference.len()).min(estimate.len());
    let (sum, n) = (frames.start.min(end)..end)
        .filter_map(|k| match (reference[k], estimate[k]) {
            (Some(a), Some(b)) if a.is_finite() && b.is_finite() => Some((b - a) * (b - a)),
            _ => None,
        })
        .fold((0.0, 0usize), |(s, n), e| (s + e, n + 1));
    (n > 0).then(|| (sum / n as f64).sqrt())
}

/// RMSE of one measure over a whole utterance.
pub fn measure_rmse(u: &Utterance, m: Measure) -> Option<f64> {
    rmse_over(u.video.series(m), u.head.series(m), 0..usize::MAX)
}

/// W, H and P RMSE of one sentence over all its frames.
pub fn sentence_rmse(u: &Utterance) -> PerMeasure {
    PerMeasure::from_fn(|m| measure_rmse(u, m))
}

/// The RMSE of a group of phone occurrences (a phoneme or a viseme class).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct GroupRmse {
    /// Phoneme (grouping label) or viseme class id.
    pub label: String,
    /// Occurrences (phone intervals) found, whether or not they held measured frames.
    pub occurrences: usize,
    /// Occurrences that contributed a value, per measure (W, H, P).
    pub counted: [usize; 3],
    /// Mean over contributing occurrences of each occurrence's RMSE.
    pub rmse: PerMeasure,
}

/// The running sums of a group's occurrence RMSEs: what [`group_rmse`] needs of each
/// utterance, so utterances can be added one at a time and dropped ([`GroupSums::add`]).
#[derive(Clone, Debug, Default, PartialEq)]
pub struct GroupSums {
    occurrences: usize,
    /// Occurrences with a value, per measure.
    counted: [usize; 3],
    /// Sum and count of the finite values, per measure (the mean skips non-finite ones, as
    /// `eval::mean_of` does).
    sum: [f64; 3],
    finite: [usize; 3],
}

impl GroupSums {
    fn push(&mut self, v: PerMeasure) {
        self.occurrences += 1;
        for (k, m) in Measure::ALL.into_iter().enumerate() {
            if let Some(x) = v.get(m) {
                self.counted[k] += 1;
                if x.is_finite() {
                    self.sum[k] += x;
                    self.finite[k] += 1;
                }
            }
        }
    }

    /// Adds every phone of `u` to its group `key(label)` (phones whose key is `None` are
    /// skipped): each occurrence's RMSE over the frames inside its interval.
    pub fn add(
        u: &Utterance,
        key: &dyn Fn(&str) -> Option<String>,
        groups: &mut BTreeMap<String, GroupSums>,
    ) {
        if !(u.fps.is_finite() && u.fps > 0.0) {
            return;
        }
        for phone in &u.alignment.phones {
            let Some(k) = key(&phone.label) else { continue };
            let frames = Alignment::frames_of(phone, u.fps);
            let v = PerMeasure::from_fn(|m| {
                rmse_over(u.video.series(m), u.head.series(m), frames.clone())
            });
            groups.entry(k).or_default().push(v);
        }
    }

    /// The group's row: the plain mean over its occurrences.
    pub fn finish(&self, label: String) -> GroupRmse {
        let mean = |k: usize| (self.finite[k] > 0).then(|| self.sum[k] / self.finite[k] as f64);
        GroupRmse {
            label,
            occurrences: self.occurrences,
            counted: self.counted,
            rmse: PerMeasure { w: mean(0), h: mean(1), p: mean(2) },
        }
    }
}

/// The rows of groups summed with [`GroupSums::add`], sorted by label.
pub fn finish_groups(groups: &BTreeMap<String, GroupSums>) -> Vec<GroupRmse> {
    groups.iter().map(|(label, g)| g.finish(label.clone())).collect()
}

/// RMSE per group over many utterances: each occurrence's RMSE over the frames inside its
/// interval, then the plain mean over occurrences (so a long phone weighs as much as a short
/// one, as in the published per-phoneme tables). Groups sorted by label.
pub fn group_rmse(
    utterances: &[Utterance],
    key: &dyn Fn(&str) -> Option<String>,
) -> Vec<GroupRmse> {
    let mut groups = BTreeMap::new();
    for u in utterances {
        GroupSums::add(u, key, &mut groups);
    }
    finish_groups(&groups)
}

/// RMSE per phoneme, phones grouped by their key in `phones` (stress digits, case and symbol
/// set dropped, silences folded to `sil`) over many utterances.
pub fn phoneme_rmse(utterances: &[Utterance], phones: &PhoneInventory) -> Vec<GroupRmse> {
    group_rmse(utterances, &phoneme_key(phones))
}

/// The phoneme row a phone label counts in: its key in `phones`.
pub fn phoneme_key(phones: &PhoneInventory) -> impl Fn(&str) -> Option<String> + '_ {
    |l| Some(phones.key_of(l))
}

/// The viseme row a phone label counts in: the class of its key in `table`, `?` when the
/// table does not know it (so it stays visible).
pub fn viseme_key<'a>(
    phones: &'a PhoneInventory,
    table: &'a VisemeTable,
) -> impl Fn(&str) -> Option<String> + 'a {
    |l| Some(table.class_of(&phones.key_of(l)).unwrap_or("?").to_string())
}

/// RMSE per viseme class of `table` (phones by their key in `phones`): the mean over every
/// occurrence of the class's phones. Phones the table does not know are grouped as `?` so
/// they stay visible.
pub fn viseme_rmse(
    utterances: &[Utterance],
    phones: &PhoneInventory,
    table: &VisemeTable,
) -> Vec<GroupRmse> {
    group_rmse(utterances, &viseme_key(phones, table))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::alignment::Phone;
    use crate::measure::Trajectory;

    fn utt() -> Utterance {
        let ph = |s: f64, e: f64, l: &str| Phone { start: s, end: e, label: l.into() };
        // 10 fps: B covers frames 0..2, AA 2..5, B again 5..6, P 6..8.
        let alignment = Alignment {
            phones: vec![
                ph(0.0, 0.2, "B"),
                ph(0.2, 0.5, "AA1"),
                ph(0.5, 0.6, "b"),
                ph(0.6, 0.8, "P"),
            ],
        };
        let video = Trajectory { w: vec![Some(1.0); 8], h: vec![Some(0.0); 8], p: vec![] };
        let head_w = [2.0, 2.0, 1.0, 1.0, 4.0, 1.5, 1.0, 1.0];
        let head = Trajectory {
            w: head_w.iter().copied().map(Some).collect(),
            h: vec![Some(0.0), None, Some(0.0), Some(0.0), Some(0.0), None, None, None],
            p: vec![],
        };
        Utterance { name: "s1".into(), speaker: None, alignment, fps: 10.0, video, head }
    }

    #[test]
    fn sentence_rmse_by_hand() {
        let r = sentence_rmse(&utt());
        // W errors 1,1,0,0,3,0.5,0,0: Σe² = 11.25 over 8.
        assert!((r.w.unwrap() - (11.25f64 / 8.0).sqrt()).abs() < 1e-12);
        assert_eq!(r.h, Some(0.0));
        assert_eq!(r.p, None);
    }

    #[test]
    fn phoneme_rmse_averages_occurrences() {
        let g = phoneme_rmse(&[utt()], &PhoneInventory::default());
        let labels: Vec<&str> = g.iter().map(|g| g.label.as_str()).collect();
        assert_eq!(labels, ["AA", "B", "P"]);
        let b = &g[1];
        // Occurrence 1 (frames 0,1): RMSE 1; occurrence 2 (frame 5): 0.5 → mean 0.75.
        assert_eq!(b.occurrences, 2);
        assert!((b.rmse.w.unwrap() - 0.75).abs() < 1e-12);
        // H: occurrence 2 has no head value, so only occurrence 1 counts.
        assert_eq!(b.counted, [2, 1, 0]);
        let aa = &g[0];
        assert!((aa.rmse.w.unwrap() - (9.0f64 / 3.0).sqrt()).abs() < 1e-12);
        assert_eq!(g[2].rmse.h, None);
    }

    #[test]
    fn viseme_rmse_pools_class_occurrences() {
        let g = viseme_rmse(&[utt(), utt()], &PhoneInventory::default(), &VisemeTable::default());
        let e = g.iter().find(|g| g.label == "E").unwrap();
        // Bilabials: B (1), B (0.5), P (0) per utterance, twice → mean 0.5.
        assert_eq!(e.occurrences, 6);
        assert!((e.rmse.w.unwrap() - 0.5).abs() < 1e-12);
        assert!(g.iter().any(|g| g.label == "V1"));
    }

    #[test]
    fn rmse_handles_empty_and_out_of_range() {
        assert_eq!(rmse_over(&[Some(1.0)], &[None], 0..1), None);
        assert_eq!(rmse_over(&[Some(1.0)], &[Some(2.0)], 5..9), None);
        let mut u = utt();
        u.fps = 0.0;
        assert!(phoneme_rmse(&[u], &PhoneInventory::default()).is_empty());
    }

    #[test]
    fn ipa_and_arpabet_spellings_of_one_phone_share_a_row() {
        let mut ipa = utt();
        for (p, l) in ipa.alignment.phones.iter_mut().zip(["b", "ɑː", "b", "p"]) {
            p.label = l.into();
        }
        let phones = PhoneInventory::default();
        let both = phoneme_rmse(&[utt(), ipa.clone()], &phones);
        let labels: Vec<&str> = both.iter().map(|g| g.label.as_str()).collect();
        assert_eq!(labels, ["AA", "B", "P"]);
        assert_eq!(both[1].occurrences, 4);
        // Lower-case IPA keeps its case where the inventory lacks the phone.
        ipa.alignment.phones[1].label = "i".into();
        ipa.alignment.phones[3].label = "œ".into();
        let g = phoneme_rmse(&[ipa], &phones);
        let labels: Vec<&str> = g.iter().map(|g| g.label.as_str()).collect();
        assert_eq!(labels, ["B", "IY", "œ"]);
    }
}
