//! A trained quality predictor for one synthesizer: the context statistics of the whole
//! corpus, the SATF parameters, ω_m, ξ, the GP and the line beside it (one of them kept),
//! and how it fared on held-out sentences, so a new timed phone sequence gets a predicted
//! Likert score with its standard deviation, and the user hears when the predictor has no
//! skill. Serde; files are written by the application layer.

use super::SaqpError;
use super::calibration::{CalibrationKind, LinearCalibration, predict_with};
use super::context::{ContextLevel, ContextStats};
use super::corpus::Corpus;
use super::coverage::{ContextIndex, INPUT_NAMES, predictor_inputs};
use super::cv::{CvOptions, CvReport, cross_validate_prepared};
use super::gp::{GaussianProcess, GpPrediction};
use super::prepared::{PhoneSet, Prepared};
use super::satf::{SatfParams, fit_trajectory};
use super::skill::Skill;
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
    pub linear: LinearCalibration,
    /// Which of the two predicts.
    pub calibration: CalibrationKind,
    /// How the kept calibration fared on the cross-validation's held-out sentences.
    pub skill: Skill,
    phones: PhoneSet,
    stats: ContextStats,
    /// The phone ids of every corpus sentence, what the coverage input is measured against.
    sequences: Vec<Vec<u16>>,
}

/// Largest ω_m a model file may hold (the paper's grid is 1–5).
pub const MAX_OMEGA_M: f64 = 100.0;
/// Largest ξ a model file may hold: errors are in model units (millimetres for a model in
/// millimetres), and a face does not move a kilometre.
pub const MAX_XI: f64 = 1e6;

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
        if !(self.xi.is_finite() && self.xi > 0.0 && self.xi <= MAX_XI) {
            return Err(format!(
                "xi {} is not within 0–{}",
                crate::math::short_number(self.xi),
                crate::math::short_number(MAX_XI)
            ));
        }
        if !(self.omega_m.is_finite() && self.omega_m > 0.0 && self.omega_m <= MAX_OMEGA_M) {
            return Err(format!(
                "omega_m {} is not within 0–{MAX_OMEGA_M}",
                crate::math::short_number(self.omega_m)
            ));
        }
        self.gp.validate()?;
        let inputs = INPUT_NAMES.len();
        if self.gp.hyper.length_scales.len() != inputs {
            return Err(format!(
                "gp.hyper.length_scales: {} values for the {inputs} inputs ({})",
                self.gp.hyper.length_scales.len(),
                INPUT_NAMES.join(", ")
            ));
        }
        // Scores are on the 1–5 Likert scale, so are their mean and every prediction.
        let on_scale = |v: f64| v.is_finite() && (1.0 - 1e-9..=5.0 + 1e-9).contains(&v);
        if let Some(t) = self.gp.targets.iter().find(|t| !on_scale(**t)) {
            return Err(format!(
                "gp.targets: {} is not a 1–5 score",
                crate::math::short_number(*t)
            ));
        }
        let mean = self.gp.targets.iter().sum::<f64>() / self.gp.targets.len() as f64;
        if !on_scale(self.gp.target_mean) || (self.gp.target_mean - mean).abs() > 1e-6 {
            return Err(format!(
                "gp.target_mean {} is not the mean of the targets ({})",
                crate::math::short_number(self.gp.target_mean),
                crate::math::short_number(mean)
            ));
        }
        // E is a weighted sum of squares, the coverage a share.
        let in_range = |x: &Vec<f64>| x[0] >= 0.0 && (0.0..=1.0).contains(&x[1]);
        if !self.gp.inputs.iter().all(in_range) {
            return Err("gp.inputs: an E below 0 or a coverage outside 0–1".into());
        }
        self.linear.validate(inputs)?;
        // The line is the least-squares fit of the pairs the GP holds: refitted, it must
        // come out the same, so a damaged coefficient cannot scale a prediction off the
        // scale.
        let refit = LinearCalibration::fit(&self.gp.inputs, &self.gp.targets)
            .map_err(|e| format!("linear: {e}"))?;
        if !self.linear.agrees_with(&refit) {
            return Err(
                "linear.coefficients are not the least-squares line of the training pairs (gp.inputs, gp.targets)"
                    .into(),
            );
        }
        self.skill.validate()?;
        self.stats.validate()?;
        self.phones.validate()?;
        self.stats.validate_ids(self.phones.len())?;
        if self.sequences.is_empty() {
            return Err("sequences: no corpus sentence to measure coverage against".into());
        }
        if self.sequences.iter().flatten().any(|&id| usize::from(id) >= self.phones.len()) {
            return Err("sequences: a phone the model's phone set lacks".into());
        }
        Ok(())
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
        linear: synth.linear.clone(),
        calibration: synth.kept,
        skill: *synth.kept_skill(),
        phones: prepared.phones.clone(),
        stats,
        sequences: prepared.sentences.iter().map(|s| s.ids.clone()).collect(),
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
        let index = ContextIndex::new(&set, self.sequences.iter().map(Vec::as_slice).collect());
        let inputs_used = predictor_inputs(&fit, &index, &set, &ids);
        let p = predict_with(
            self.calibration,
            &self.gp,
            &self.linear,
            std::slice::from_ref(&inputs_used),
        )?;
        if !(p[0].mean.is_finite() && p[0].std().is_finite() && fit.e.is_finite()) {
            return Err(SaqpError::Gp(format!(
                "sentence `{name}`: the prediction is not a finite number (a damaged model?)"
            )));
        }
        // A phone backed off past its own statistics is fitted to a viseme's or the whole
        // corpus's loose spread, which lowers E: the prediction is then too kind, so say so.
        let mut unseen: Vec<String> = Vec::new();
        for (&id, level) in ids.iter().zip(&fit.levels) {
            let label = set.label(id);
            if *level > ContextLevel::Monophone
                && set.is_speech(id)
                && !unseen.iter().any(|u| u == label)
            {
                unseen.push(label.to_string());
            }
        }
        let extrapolated = INPUT_NAMES
            .iter()
            .enumerate()
            .filter(|&(k, _)| {
                // A tenth of the range either way is still among the training pairs' kind:
                // a corpus sentence itself, scored against every sentence and so against
                // its own occurrences too, sits just past the highest coverage.
                let (lo, hi) = self.input_range(k);
                let margin = 0.1 * (hi - lo);
                !(lo - margin..=hi + margin).contains(&inputs_used[k])
            })
            .map(|(_, name)| *name)
            .collect();
        Ok(QualityEstimate {
            e: fit.e,
            coverage: inputs_used[1],
            prediction: p[0],
            unseen,
            extrapolated,
        })
    }

    /// The smallest and largest value of input `k` ([`INPUT_NAMES`]) among the training
    /// pairs.
    pub fn input_range(&self, k: usize) -> (f64, f64) {
        self.gp
            .inputs
            .iter()
            .fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), x| (lo.min(x[k]), hi.max(x[k])))
    }
}

/// A predicted quality.
#[derive(Clone, Debug, PartialEq)]
pub struct QualityEstimate {
    /// The SATF error of the sequence against the training corpus.
    pub e: f64,
    /// Its coverage by the corpus ([`ContextIndex::coverage`]), the predictor's other input.
    pub coverage: f64,
    /// Predicted Likert score (1 worst – 5 best) and its standard deviation.
    pub prediction: GpPrediction,
    /// Phone labels (grouping labels) without statistics of their own in the corpus.
    pub unseen: Vec<String>,
    /// The inputs ([`INPUT_NAMES`]) outside the range the predictor was trained on (by more
    /// than a tenth of it): there the score is an extrapolation, less sure than its σ says.
    pub extrapolated: Vec<&'static str>,
}
