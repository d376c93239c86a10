//! How well a corpus covers a phone sequence in context: the predictor's second input beside
//! E, and the context match the concatenative synthesizer selects its units by.
//!
//! A phone's recorded occurrences (its own, or its viseme class's when the corpus never
//! recorded it) are compared with the target by their neighbours two phones either way
//! ([`CONTEXT_WEIGHTS`]): the same phone agrees fully, one of the same viseme class in part.
//! The coverage of a sequence is the mean, over its speech phones, of the mean agreement of
//! the [`super::synth::CONCAT_UNITS`] best occurrences, as a share of full agreement.
//!
//! Why E needs it beside it: the SATF backs a context missing from the corpus off to looser
//! statistics, whose wider variances make E *smaller* exactly where a synthesizer that
//! replays recorded context does worst. The training pairs come from sub-corpora of 10–90 %
//! of the training sentences, the held-out ones from all of them, so without a measure of
//! coverage the mapping learned from E is biased on the held-out sentences (on the demo
//! seeds 1–8 and 1001–1006 the concatenative predictor's RMSE ratio was 0.85 on E alone).

use super::prepared::PhoneSet;
use super::satf::SatfFit;
use super::synth::CONCAT_UNITS;
use std::collections::HashMap;

/// What a quality predictor sees of a phone sequence, in the order of
/// [`predictor_inputs`]'s values.
pub const INPUT_NAMES: [&str; 2] = ["E", "coverage"];

/// The predictor's inputs for `ids` ([`INPUT_NAMES`]): E of its SATF fit, and its coverage
/// by the corpus `index` holds.
pub fn predictor_inputs(
    fit: &SatfFit,
    index: &ContextIndex,
    phones: &PhoneSet,
    ids: &[u16],
) -> Vec<f64> {
    vec![fit.e, index.coverage(phones, ids)]
}

/// How much agreement of the phone `offset` places away counts: the nearer neighbours
/// double the farther.
pub const CONTEXT_WEIGHTS: [(isize, f64); 4] = [(-2, 0.5), (-1, 1.0), (1, 1.0), (2, 0.5)];
/// The agreement of a context matched in full: the weights' sum.
pub const FULL_AGREEMENT: f64 = 3.0;
/// Agreement of two different phones of one viseme class (they look alike on the lips).
const SAME_VISEME: f64 = 0.4;

/// Recorded phone sequences indexed by phone and by viseme class.
#[derive(Clone, Debug)]
pub struct ContextIndex<'a> {
    sequences: Vec<&'a [u16]>,
    /// Phone id → (sequence, position) of each occurrence, in corpus order.
    occurrences: HashMap<u16, Vec<(usize, usize)>>,
    by_viseme: HashMap<u16, Vec<(usize, usize)>>,
}

/// The phone `offset` places from position `j`, if the sequence has one there.
fn neighbour(v: &[u16], j: usize, offset: isize) -> Option<u16> {
    j.checked_add_signed(offset).and_then(|k| v.get(k)).copied()
}

impl<'a> ContextIndex<'a> {
    /// Indexes `sequences` (phone ids of `phones`).
    pub fn new(phones: &PhoneSet, sequences: Vec<&'a [u16]>) -> Self {
        let mut occurrences: HashMap<u16, Vec<(usize, usize)>> = HashMap::new();
        let mut by_viseme: HashMap<u16, Vec<(usize, usize)>> = HashMap::new();
        for (s, ids) in sequences.iter().enumerate() {
            for (i, &id) in ids.iter().enumerate() {
                occurrences.entry(id).or_default().push((s, i));
                if let Some(v) = phones.viseme(id) {
                    by_viseme.entry(v).or_default().push((s, i));
                }
            }
        }
        Self { sequences, occurrences, by_viseme }
    }

    /// The phone ids of sequence `s`.
    pub fn sequence(&self, s: usize) -> &'a [u16] {
        self.sequences[s]
    }

    /// The occurrences phone `id` may be matched with: its own, else its viseme class's
    /// (none when the corpus has neither).
    pub fn candidates(&self, phones: &PhoneSet, id: u16) -> &[(usize, usize)] {
        self.occurrences
            .get(&id)
            .or_else(|| phones.viseme(id).and_then(|v| self.by_viseme.get(&v)))
            .map_or(&[], Vec::as_slice)
    }

    /// How far the neighbours of phone `i` of `ids` agree with those of occurrence
    /// `(s, j)`: 0 to [`FULL_AGREEMENT`]. A sentence end agrees with a sentence end.
    pub fn agreement(
        &self,
        phones: &PhoneSet,
        ids: &[u16],
        i: usize,
        (s, j): (usize, usize),
    ) -> f64 {
        let other = self.sequences[s];
        let same = |a: Option<u16>, b: Option<u16>| match (a, b) {
            (Some(a), Some(b)) if a == b => 1.0,
            (Some(a), Some(b))
                if phones.viseme(a).is_some() && phones.viseme(a) == phones.viseme(b) =>
            {
                SAME_VISEME
            }
            (None, None) => 1.0,
            _ => 0.0,
        };
        CONTEXT_WEIGHTS
            .iter()
            .map(|&(o, w)| w * same(neighbour(ids, i, o), neighbour(other, j, o)))
            .sum()
    }

    /// The coverage of `ids` (see the module): 0 (no speech phone, or none recorded) to 1
    /// (every speech phone recorded [`CONCAT_UNITS`] times in its full context).
    pub fn coverage(&self, phones: &PhoneSet, ids: &[u16]) -> f64 {
        let speech: Vec<usize> = (0..ids.len()).filter(|&i| phones.is_speech(ids[i])).collect();
        if speech.is_empty() {
            return 0.0;
        }
        let total: f64 = speech
            .iter()
            .map(|&i| {
                let mut best: Vec<f64> = self
                    .candidates(phones, ids[i])
                    .iter()
                    .map(|&at| self.agreement(phones, ids, i, at))
                    .collect();
                best.sort_by(|a, b| b.total_cmp(a));
                best.truncate(CONCAT_UNITS);
                // Fewer occurrences than units: the missing ones agree not at all.
                best.iter().sum::<f64>() / (CONCAT_UNITS as f64 * FULL_AGREEMENT)
            })
            .sum();
        total / speech.len() as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn set_and_ids(sentences: &[&[&str]]) -> (PhoneSet, Vec<Vec<u16>>) {
        let (mut set, table) = (PhoneSet::default(), crate::eval::VisemeTable::default());
        let ids = sentences
            .iter()
            .map(|labels| {
                labels.iter().map(|l| set.intern(l, &Default::default(), &table)).collect()
            })
            .collect();
        (set, ids)
    }

    #[test]
    fn coverage_grows_with_the_context_the_corpus_holds() {
        let (set, ids) = set_and_ids(&[
            &["sil", "B", "IH", "N", "sil"],
            &["sil", "B", "IH", "N", "sil"],
            &["sil", "B", "IH", "N", "sil"],
            &["sil", "P", "UW", "T", "sil"],
            // The target sequences.
            &["sil", "B", "IH", "N", "sil"],
            &["sil", "M", "UW", "N", "sil"],
            &["sil", "Z", "AO", "sil"],
        ]);
        let index = ContextIndex::new(&set, ids[..4].iter().map(Vec::as_slice).collect());
        // Recorded three times in full context: complete coverage.
        assert!((index.coverage(&set, &ids[4]) - 1.0).abs() < 1e-12);
        let partial = index.coverage(&set, &ids[5]);
        assert!(partial > 0.0 && partial < 1.0, "{partial}");
        // Neither Z nor AO was recorded, nor any phone of their viseme classes.
        assert!(index.coverage(&set, &ids[6]) < partial);
        assert_eq!(index.coverage(&set, &ids[0][..1]), 0.0, "silence alone");
        // M was never recorded: its candidates are the bilabials B and P. Against B of
        // `sil B IH N sil` by hand: the ends agree (0.5), sil (1), UW and IH not (0), N
        // (0.5).
        let m = 1;
        assert_eq!(index.candidates(&set, ids[5][m]).len(), 4);
        assert!((index.agreement(&set, &ids[5], m, (0, 1)) - 2.0).abs() < 1e-12);
        // Against P of `sil P UW T sil`: ends, sil and UW agree, N and T share a class.
        let nt = if set.viseme(ids[5][3]) == set.viseme(ids[3][3]) { 0.5 * 0.4 } else { 0.0 };
        assert!((index.agreement(&set, &ids[5], m, (3, 1)) - (2.5 + nt)).abs() < 1e-12);
    }
}
