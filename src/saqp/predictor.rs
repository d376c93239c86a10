//! A trained quality predictor for one synthesizer: the context statistics of the whole
//! corpus, the SATF parameters, ω_m, ξ and the GP, so a new timed phone sequence gets a
//! predicted Likert score with its standard deviation. Serde; files are written by the
//! application layer.

use super::SaqpError;
use super::context::{ContextLevel, ContextStats};
use super::corpus::Corpus;
use super::cv::{CvOptions, CvReport, cross_validate_prepared};
use super::gp::{GaussianProcess, GpPrediction};
use super::prepared::{PhoneSet, Prepared};
use super::satf::{SatfParams, fit_trajectory};
use super::synth::{External, SynthKind};
use crate::alignment::Phone;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// How to train: the cross-validation that chooses λ, W's order and ω_m and fits the GP,
/// and which synthesizer to keep.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainOptions {
    pub cv: CvOptions,
    pub synth: SynthKind,
}

/// A trained predictor.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Predictor {
    pub synth: SynthKind,
    pub satf: SatfParams,
    pub omega_m: f64,
    pub xi: f64,
    /// Frame rate durations are counted in (the corpus's).
    pub fps: f64,
    pub gp: GaussianProcess,
    phones: PhoneSet,
    stats: ContextStats,
}

impl Predictor {
    /// Checks a predictor read from a file before it is used, so a hand-edited or damaged
    /// model is refused with the field at fault instead of failing deep in a solve.
    ///
    /// # Errors
    /// The first inconsistency found, naming the field.
    pub fn validate(&self) -> Result<(), String> {
        self.satf.check().map_err(|m| format!("satf: {m}"))?;
        if !(self.fps.is_finite() && (1.0..=1000.0).contains(&self.fps)) {
            return Err(format!(
                "fps {} is not between 1 and 1000",
                crate::math::short_number(self.fps)
            ));
        }
        if ![self.xi, self.omega_m].iter().all(|v| v.is_finite() && *v > 0.0) {
            return Err("xi and omega_m must be positive".into());
        }
        self.gp.validate()?;
        self.stats.validate()
    }
}

/// Trains a predictor: runs the cross-validation and keeps `options.synth`'s model, with
/// context statistics from every sentence of the corpus. Returns the report too.
///
/// # Errors
/// As [`super::cross_validate`]; `options.synth` not among the synthesizers learned.
pub fn train(
    corpus: &Corpus,
    external: &HashMap<String, External>,
    options: &TrainOptions,
) -> Result<(Predictor, CvReport), SaqpError> {
    let prepared = Prepared::new(corpus)?;
    let report = cross_validate_prepared(corpus, &prepared, external, &options.cv)?;
    let synth =
        report.synths.iter().find(|s| s.synth == options.synth).ok_or_else(|| {
            SaqpError::Option(format!("{} was not learned", options.synth.name()))
        })?;
    let all: Vec<usize> = (0..prepared.sentences.len()).collect();
    let stats = ContextStats::build(
        prepared.basis.dims(),
        &prepared.phones,
        all.iter().map(|&s| {
            let s = &prepared.sentences[s];
            (&s.ids[..], &s.samples[..])
        }),
        options.cv.context,
    );
    let predictor = Predictor {
        synth: synth.synth,
        satf: report.satf,
        omega_m: synth.omega_m,
        xi: synth.xi,
        fps: corpus.sentences[0].fps,
        gp: synth.gp.clone(),
        phones: prepared.phones.clone(),
        stats,
    };
    Ok((predictor, report))
}

impl Predictor {
    /// E of a timed phone sequence against the training corpus, the predicted Likert score
    /// for it, and the phones the corpus never saw.
    ///
    /// # Errors
    /// `TooFewPhones`, `AllPhonesUnseen` (named `name`), a corrupted model.
    pub fn predict(
        &self,
        name: &str,
        phones: &[Phone],
        inventory: &crate::alignment::PhoneInventory,
        visemes: &crate::eval::VisemeTable,
    ) -> Result<QualityEstimate, SaqpError> {
        let mut set = self.phones.clone();
        let ids = set.intern_all(phones, inventory, visemes);
        let fit = fit_trajectory(name, &self.stats, &set, &ids, phones, self.fps, self.satf)?;
        let p = self.gp.predict(&[fit.e])?;
        // A phone backed off past its own statistics is fitted to a viseme's or the whole
        // corpus's loose spread, which lowers E: the prediction is then too kind, so say so.
        let mut unseen: Vec<String> = Vec::new();
        for (&id, level) in ids.iter().zip(&fit.levels) {
            let label = set.label(id);
            if *level > ContextLevel::Monophone
                && label != "sil"
                && !unseen.iter().any(|u| u == label)
            {
                unseen.push(label.to_string());
            }
        }
        Ok(QualityEstimate { e: fit.e, prediction: p[0], unseen })
    }
}

/// A predicted quality.
#[derive(Clone, Debug, PartialEq)]
pub struct QualityEstimate {
    /// The SATF error of the sequence against the training corpus.
    pub e: f64,
    /// Predicted Likert score (1 worst – 5 best) and its standard deviation.
    pub prediction: GpPrediction,
    /// Phone labels (grouping labels) without statistics of their own in the corpus.
    pub unseen: Vec<String>,
}
