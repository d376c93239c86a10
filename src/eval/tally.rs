//! An evaluation built one sentence at a time: what the tables need of each utterance and
//! its clip's fits (a row per sentence, running sums per phoneme and viseme, the worst frames
//! so far), so a corpus is evaluated in memory bounded by its largest clip plus a row per
//! sentence, never by the whole corpus's trajectories and fits.
//!
//! Adding utterances in order and finishing gives exactly the tables of the whole-corpus
//! functions ([`super::sentence_table`], [`super::phoneme_rmse`], [`super::viseme_rmse`],
//! [`super::worst_frames_by_error`], [`super::worst_frames_by_residual`]): the same sums in
//! the same order, the same ties.

use super::Utterance;
use super::report::SentenceRow;
use super::rmse::{GroupRmse, GroupSums, finish_groups, phoneme_key, viseme_key};
use super::visemes::VisemeTable;
use super::worst::{WorstFit, WorstFrame, add_worst_fits, add_worst_frames};
use crate::alignment::PhoneInventory;
use crate::fit::FrameFit;
use crate::measure::Measure;
use std::collections::BTreeMap;

/// The evaluation of the sentences added so far.
#[derive(Clone, Debug, Default)]
pub struct Tally {
    n_worst: usize,
    sentences: Vec<SentenceRow>,
    phonemes: BTreeMap<String, GroupSums>,
    visemes: BTreeMap<String, GroupSums>,
    /// The worst frames so far of W, H and P.
    worst: [Vec<WorstFrame>; 3],
    worst_fits: Vec<WorstFit>,
}

impl Tally {
    /// An empty tally keeping the `n_worst` worst frames of each kind.
    pub fn new(n_worst: usize) -> Self {
        Self { n_worst, ..Self::default() }
    }

    /// Adds one utterance as it is compared (already normalised), its phones grouped by
    /// their keys in `phones` and classes in `visemes`.
    pub fn add_utterance(&mut self, u: &Utterance, phones: &PhoneInventory, visemes: &VisemeTable) {
        self.sentences.push(SentenceRow::of(u));
        GroupSums::add(u, &phoneme_key(phones), &mut self.phonemes);
        GroupSums::add(u, &viseme_key(phones, visemes), &mut self.visemes);
        for (k, m) in Measure::ALL.into_iter().enumerate() {
            add_worst_frames(&mut self.worst[k], u, m, self.n_worst);
        }
    }

    /// Adds the fits of clip `clip` to the worst fits.
    pub fn add_fits(&mut self, clip: &str, fits: &[FrameFit]) {
        add_worst_fits(&mut self.worst_fits, clip, fits, self.n_worst);
    }

    /// One row per sentence added, in order.
    pub fn sentences(&self) -> &[SentenceRow] {
        &self.sentences
    }

    /// RMSE per phoneme, sorted by phoneme.
    pub fn phonemes(&self) -> Vec<GroupRmse> {
        finish_groups(&self.phonemes)
    }

    /// RMSE per viseme class, sorted by class.
    pub fn visemes(&self) -> Vec<GroupRmse> {
        finish_groups(&self.visemes)
    }

    /// The `n_worst` worst frames by measure error, W, H and P pooled, worst first.
    pub fn worst_frames(&self) -> Vec<WorstFrame> {
        let mut worst: Vec<WorstFrame> = self.worst.concat();
        worst.sort_by(|a, b| b.error.abs().total_cmp(&a.error.abs()));
        worst.truncate(self.n_worst);
        worst
    }

    /// The `n_worst` worst frames by fit residual, failed fits first.
    pub fn worst_fits(&self) -> &[WorstFit] {
        &self.worst_fits
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::alignment::{Alignment, Phone};
    use crate::eval::{phoneme_rmse, viseme_rmse, worst_frames_by_error, worst_frames_by_residual};
    use crate::measure::Trajectory;

    fn utt(name: &str, shift: f64) -> Utterance {
        let ph = |s: f64, e: f64, l: &str| Phone { start: s, end: e, label: l.into() };
        let alignment =
            Alignment { phones: vec![ph(0.0, 0.3, "B"), ph(0.3, 0.6, "AA1"), ph(0.6, 0.9, "UW")] };
        let series = |k: f64| (0..9).map(|f| Some((f as f64 * k + shift).sin())).collect();
        let video = Trajectory { w: series(0.7), h: series(0.3), p: vec![] };
        let head = Trajectory { w: series(0.9), h: series(0.31), p: vec![] };
        Utterance { name: name.into(), speaker: None, alignment, fps: 10.0, video, head }
    }

    #[test]
    fn a_tally_gives_the_whole_corpus_tables() {
        let us: Vec<Utterance> = (0..5).map(|k| utt(&format!("s{k}"), k as f64 * 0.37)).collect();
        let phones = PhoneInventory::default();
        let visemes = VisemeTable::default();
        let fit =
            |frame: usize, rms: f64| FrameFit { reproj_rms_px: rms, ..FrameFit::unposed(frame) };
        let fits: Vec<Vec<FrameFit>> = (0..5)
            .map(|k| (0..9).map(|f| fit(f, ((f * 7 + k * 3) % 5) as f64)).collect())
            .collect();
        let mut t = Tally::new(4);
        for (u, f) in us.iter().zip(&fits) {
            t.add_utterance(u, &phones, &visemes);
            t.add_fits(&u.name, f);
        }
        assert_eq!(t.phonemes(), phoneme_rmse(&us, &phones));
        assert_eq!(t.visemes(), viseme_rmse(&us, &phones, &visemes));
        let mut worst: Vec<WorstFrame> =
            Measure::ALL.iter().flat_map(|&m| worst_frames_by_error(&us, m, 4)).collect();
        worst.sort_by(|a, b| b.error.abs().total_cmp(&a.error.abs()));
        worst.truncate(4);
        assert_eq!(t.worst_frames(), worst);
        let named: Vec<(&str, &[FrameFit])> =
            us.iter().zip(&fits).map(|(u, f)| (u.name.as_str(), f.as_slice())).collect();
        assert_eq!(t.worst_fits(), worst_frames_by_residual(&named, 4).as_slice());
        assert_eq!(
            crate::eval::report::sentence_table_of(t.sentences()),
            crate::eval::report::sentence_table(&us)
        );
    }
}
