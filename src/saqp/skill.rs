//! Whether a quality predictor has skill: its held-out RMSE beside that of a constant
//! predictor (the training mean), with a 95 % bootstrap interval of their ratio over the
//! held-out sentences. A predictor has skill only when the whole interval lies below 1, so
//! one that merely drew a lucky set of sentences, or does no better than the mean, is not
//! said to have any.

use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use serde::{Deserialize, Serialize};

/// Bootstrap resamples of the held-out sentences.
const RESAMPLES: usize = 2000;
/// Fewest held-out sentences a verdict is given on.
pub const MIN_SENTENCES: usize = 3;

/// A predictor's held-out errors against a constant's.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Skill {
    /// Held-out sentences scored.
    pub sentences: usize,
    /// Pearson r of predicted and ground-truth scores.
    pub pearson_r: f64,
    pub rmse: f64,
    /// RMSE of predicting the training mean for every sentence.
    pub rmse_constant: f64,
    /// `rmse / rmse_constant` and its 95 % bootstrap interval over the held-out sentences.
    pub ratio: f64,
    pub ratio_low: f64,
    pub ratio_high: f64,
}

/// The plain verdict on a [`Skill`].
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Verdict {
    /// The RMSE ratio's interval lies below 1.
    Skill,
    /// The ratio, or part of its interval, is 1 or more.
    NoSkill,
    /// Fewer than [`MIN_SENTENCES`] held-out sentences.
    TooFew,
}

impl Verdict {
    pub fn as_str(self) -> &'static str {
        match self {
            Verdict::Skill => "skill",
            Verdict::NoSkill => "no skill",
            Verdict::TooFew => "too few sentences",
        }
    }
}

impl Skill {
    /// Compares `predicted` with `truth` beside the constant `constant`; `seed` makes the
    /// bootstrap reproducible.
    pub fn assess(predicted: &[f64], truth: &[f64], constant: f64, seed: u64) -> Self {
        let n = predicted.len().min(truth.len());
        let err: Vec<f64> = (0..n).map(|i| (predicted[i] - truth[i]).powi(2)).collect();
        let base: Vec<f64> = (0..n).map(|i| (constant - truth[i]).powi(2)).collect();
        let ratio_of = |idx: &mut dyn Iterator<Item = usize>| {
            let (mut e, mut c) = (0.0, 0.0);
            for i in idx {
                e += err[i];
                c += base[i];
            }
            ratio(e, c)
        };
        let mean = |v: &[f64]| v.iter().sum::<f64>() / n.max(1) as f64;
        let ratio = ratio_of(&mut (0..n));
        let (mut low, mut high) = (ratio, ratio);
        if n >= MIN_SENTENCES {
            let mut rng = StdRng::seed_from_u64(seed);
            let mut draws: Vec<f64> = (0..RESAMPLES)
                .map(|_| ratio_of(&mut (0..n).map(|_| rng.random_range(0..n))))
                .collect();
            draws.sort_by(f64::total_cmp);
            low = draws[(0.025 * RESAMPLES as f64) as usize];
            high = draws[(0.975 * RESAMPLES as f64) as usize - 1];
        }
        Self {
            sentences: n,
            pearson_r: super::cv::pearson(&predicted[..n], &truth[..n]),
            rmse: mean(&err).sqrt(),
            rmse_constant: mean(&base).sqrt(),
            ratio,
            ratio_low: low,
            ratio_high: high,
        }
    }

    /// Skill when the ratio's whole interval is below 1.
    pub fn verdict(&self) -> Verdict {
        if self.sentences < MIN_SENTENCES {
            Verdict::TooFew
        } else if self.ratio < 1.0 && self.ratio_high < 1.0 {
            Verdict::Skill
        } else {
            Verdict::NoSkill
        }
    }

    pub fn has_skill(&self) -> bool {
        self.verdict() == Verdict::Skill
    }

    /// One line for people: `RMSE 0.92 × a constant's (95 % CI 0.80–1.05): no skill`.
    pub fn describe(&self) -> String {
        match self.verdict() {
            Verdict::TooFew => format!(
                "{} held-out sentences, too few to say whether it has skill",
                self.sentences
            ),
            v => format!(
                "held-out RMSE {:.2} × a constant's (95 % CI {:.2}–{:.2}) on {} sentences: {}",
                self.ratio,
                self.ratio_low,
                self.ratio_high,
                self.sentences,
                v.as_str()
            ),
        }
    }

    /// Checks a skill record read from a file: counts and figures finite and in range.
    ///
    /// # Errors
    /// The field at fault.
    pub fn validate(&self) -> Result<(), String> {
        let fields = [
            ("pearson_r", self.pearson_r, -1.0 - 1e-9, 1.0 + 1e-9),
            ("rmse", self.rmse, 0.0, 1e6),
            ("rmse_constant", self.rmse_constant, 0.0, 1e6),
            ("ratio", self.ratio, 0.0, 1e6),
            ("ratio_low", self.ratio_low, 0.0, 1e6),
            ("ratio_high", self.ratio_high, 0.0, 1e6),
        ];
        for (name, v, lo, hi) in fields {
            if !(v.is_finite() && (lo..=hi).contains(&v)) {
                return Err(format!(
                    "skill.{name} {} is not within {lo}–{hi}",
                    crate::math::short_number(v)
                ));
            }
        }
        if self.ratio_low > self.ratio_high {
            return Err("skill.ratio_low is above skill.ratio_high".into());
        }
        Ok(())
    }
}

/// `sqrt(e / c)`, the RMSE ratio from summed squared errors; 1 when both are 0, and a large
/// finite number when only the constant is exact (a constant target).
fn ratio(e: f64, c: f64) -> f64 {
    if c > 0.0 {
        (e / c).sqrt()
    } else if e > 0.0 {
        1e6
    } else {
        1.0
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_good_predictor_has_skill_and_a_constant_has_none() {
        let truth: Vec<f64> = (0..40).map(|i| 2.0 + (i as f64 * 0.7).sin()).collect();
        let good: Vec<f64> =
            truth.iter().enumerate().map(|(i, t)| t + 0.1 * (i as f64).cos()).collect();
        let s = Skill::assess(&good, &truth, 2.0, 1);
        assert_eq!(s.verdict(), Verdict::Skill, "{s:?}");
        assert!(s.ratio_low <= s.ratio && s.ratio <= s.ratio_high && s.ratio_high < 1.0);
        // The training mean itself: ratio exactly 1, never skill.
        let flat = vec![2.0; 40];
        let s = Skill::assess(&flat, &truth, 2.0, 1);
        assert!((s.ratio - 1.0).abs() < 1e-12);
        assert_eq!(s.verdict(), Verdict::NoSkill);
        assert!(s.describe().ends_with("no skill"), "{}", s.describe());
    }

    #[test]
    fn a_ratio_below_one_by_luck_is_not_skill() {
        // Noise as the prediction: on 12 sentences its ratio can dip below 1, but the
        // interval reaches past it.
        let truth: Vec<f64> = (0..12).map(|i| 3.0 + ((i * 7919) % 13) as f64 / 13.0).collect();
        let noise: Vec<f64> = (0..12).map(|i| 3.5 + ((i * 104_729) % 11) as f64 / 22.0).collect();
        let s = Skill::assess(&noise, &truth, 3.5, 7);
        assert!(s.ratio_high >= 1.0, "{s:?}");
        assert_ne!(s.verdict(), Verdict::Skill);
        assert_eq!(Skill::assess(&[1.0, 2.0], &[1.0, 2.0], 1.5, 1).verdict(), Verdict::TooFew);
    }

    #[test]
    fn a_damaged_record_is_refused_by_field() {
        let mut s = Skill::assess(&[1.0, 2.0, 3.0], &[1.1, 2.1, 2.9], 2.0, 1);
        assert_eq!(s.validate(), Ok(()));
        s.ratio_high = f64::INFINITY;
        assert!(s.validate().unwrap_err().starts_with("skill.ratio_high"));
    }
}
