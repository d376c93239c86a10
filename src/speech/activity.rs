//! Speech or not, frame by frame, from the recording itself: each frame's energy and
//! spectrum against the recording's own noise floor, and its loudness against the
//! recording's loud speech.
//!
//! The paper trains and tests on one clean studio recording and says nothing of silence. A
//! model trained on one voice and driven by another recording sees, between the words, a
//! background noise it never heard (the demo voice's pauses are digital zero, a real room is
//! not), and its cepstra say nothing reliable there: the mouth moved in the leading silence
//! of every unseen voice we tried. So silence is recognised before the model sees it
//! ([`super::features`] fades the cepstra of non-speech frames to one fixed vector and gives
//! the model this activity as a feature): relative measures, so that they mean the same on
//! any recording.
//!
//! Per frame t with mel log energies `log E_tj`:
//! - the noise floor of band j is the `floor_quantile` of `log E_tj` over the recording (the
//!   quiet frames), but at most `max_range_db` below that band's `peak_quantile` (a
//!   recording with digital silence would otherwise put the floor at −200 dB and call a
//!   resonator's −90 dB tail speech); the whole frame's floor likewise from `L_t = log Σ_j E_tj`;
//! - the frame's signal-to-floor ratio is the larger of `L_t` over its floor and the mean
//!   over bands of `log E_tj` over the band's floor (counted where positive): loud voicing
//!   shows in the first, a quiet /s/ or /f/ concentrated in a few high bands in the second;
//! - activity `a_t` ramps linearly from 0 at `onset_db` above the floor to 1 at `full_db`;
//! - loudness `l_t = clamp(1 + (L_t − P)/loudness_range, 0, 1)`, P the `peak_quantile` of
//!   `L_t`: 1 at the recording's loud speech, 0 at `loudness_range_db` below it, the same
//!   scale for any recording level.
//!
//! Quantiles of the whole recording: a frame's activity depends on frames long after it, so
//! the per-frame log energies are kept (J values per frame, 18 MB for an hour at 24 fps),
//! never the samples.

use super::error::{SpeechError, bad};
use crate::math::DMatrix;
use serde::{Deserialize, Serialize};

/// Thresholds of the speech/non-speech decision; stored in a model.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ActivityOptions {
    /// Quantile of a band's log energies taken as its noise floor.
    pub floor_quantile: f64,
    /// Quantile taken as the recording's loud speech.
    pub peak_quantile: f64,
    /// The floor is at most this far below the loud speech, dB.
    pub max_range_db: f64,
    /// Activity is 0 up to this many dB above the floor …
    pub onset_db: f64,
    /// … and 1 from this many on.
    pub full_db: f64,
    /// Loudness runs from 0 at this many dB below the loud speech to 1 at it.
    pub loudness_range_db: f64,
}

impl Default for ActivityOptions {
    /// Floor at the 10th percentile (a recording with any pause has over 10 % of its frames
    /// in it; one without has its closures and weakest consonants there, which are
    /// near-silent anyway), loud speech at the 98th, at most 50 dB apart (a quiet room
    /// recorded close; the demo voice's digital pauses are brought up to it); activity from
    /// 6 dB (twice the floor's power) to 15 dB; loudness over 40 dB.
    fn default() -> Self {
        Self {
            floor_quantile: 0.1,
            peak_quantile: 0.98,
            max_range_db: 50.0,
            onset_db: 6.0,
            full_db: 15.0,
            loudness_range_db: 40.0,
        }
    }
}

impl ActivityOptions {
    /// Checks the options (they also come from model files).
    ///
    /// # Errors
    /// A quantile outside [0, 1] or not below the peak's; a dB value not finite, not
    /// positive or above 200; an onset not below the full level.
    pub fn validate(&self) -> Result<(), SpeechError> {
        let q = |v: f64| v.is_finite() && (0.0..=1.0).contains(&v);
        if !(q(self.floor_quantile) && q(self.peak_quantile))
            || self.floor_quantile >= self.peak_quantile
        {
            return Err(bad(
                "activity quantiles",
                format!("floor {} and peak {}", self.floor_quantile, self.peak_quantile),
            ));
        }
        for (name, v) in [
            ("activity range", self.max_range_db),
            ("activity onset", self.onset_db),
            ("activity full level", self.full_db),
            ("loudness range", self.loudness_range_db),
        ] {
            if !(v.is_finite() && v > 0.0 && v <= 200.0) {
                return Err(bad(name, format!("{v} dB")));
            }
        }
        if self.onset_db >= self.full_db {
            return Err(bad(
                "activity levels",
                format!("onset {} dB not below {} dB", self.onset_db, self.full_db),
            ));
        }
        Ok(())
    }
}

/// Natural-log units per dB of power.
const NEPER_PER_DB: f64 = std::f64::consts::LN_10 / 10.0;

/// The `q` quantile of `values` (nearest rank); `values` must not be empty.
fn quantile(values: &[f64], q: f64) -> f64 {
    let mut sorted = values.to_vec();
    sorted.sort_by(f64::total_cmp);
    sorted[((sorted.len() - 1) as f64 * q).round() as usize]
}

/// `log Σ_j E_tj` of each row of `log_mel`.
pub fn frame_log_energy(log_mel: &DMatrix) -> Vec<f64> {
    log_mel
        .row_iter()
        .map(|row| {
            let m = row.max();
            m + row.iter().map(|x| (x - m).exp()).sum::<f64>().ln()
        })
        .collect()
}

/// (floor, peak) of `values`: the floor quantile, raised to at most `max_range_db` below
/// the peak quantile.
fn floor_and_peak(values: &[f64], opts: &ActivityOptions) -> (f64, f64) {
    let peak = quantile(values, opts.peak_quantile);
    let floor = quantile(values, opts.floor_quantile).max(peak - opts.max_range_db * NEPER_PER_DB);
    (floor, peak)
}

/// Speech activity `a_t` ∈ [0, 1] and loudness `l_t` ∈ [0, 1] of every frame of `log_mel`
/// (T × J, natural-log mel energies, T ≥ 1), as the module doc defines them.
///
/// # Errors
/// Options out of range; no frames; a non-finite energy.
pub fn speech_activity(
    log_mel: &DMatrix,
    opts: &ActivityOptions,
) -> Result<(Vec<f64>, Vec<f64>), SpeechError> {
    opts.validate()?;
    if log_mel.nrows() == 0 || log_mel.ncols() == 0 {
        return Err(SpeechError::Empty("frames to detect speech in"));
    }
    if log_mel.iter().any(|v| !v.is_finite()) {
        return Err(bad("log mel energies", "not finite"));
    }
    let total = frame_log_energy(log_mel);
    let (floor, peak) = floor_and_peak(&total, opts);
    let bands: Vec<f64> = log_mel
        .column_iter()
        .map(|c| floor_and_peak(&c.iter().copied().collect::<Vec<_>>(), opts).0)
        .collect();
    let (onset, full) = (opts.onset_db * NEPER_PER_DB, opts.full_db * NEPER_PER_DB);
    let activity = log_mel
        .row_iter()
        .zip(&total)
        .map(|(row, l)| {
            let spectral = row.iter().zip(&bands).map(|(e, f)| (e - f).max(0.0)).sum::<f64>()
                / bands.len() as f64;
            let snr = (l - floor).max(spectral);
            ((snr - onset) / (full - onset)).clamp(0.0, 1.0)
        })
        .collect();
    let range = opts.loudness_range_db * NEPER_PER_DB;
    let loudness = total.iter().map(|l| (1.0 + (l - peak) / range).clamp(0.0, 1.0)).collect();
    Ok((activity, loudness))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Frames of a flat spectrum at `db` (J = 4 bands).
    fn frames(levels_db: &[f64]) -> DMatrix {
        DMatrix::from_fn(levels_db.len(), 4, |t, _| levels_db[t] * NEPER_PER_DB)
    }

    #[test]
    fn pauses_at_the_noise_floor_are_silence_and_speech_above_it_is_not() {
        // 30 % of frames at a −60 dB room noise, speech between −20 and 0 dB.
        let mut levels = vec![-60.0; 30];
        levels.extend((0..70).map(|i| -20.0 + 20.0 * (i as f64 / 69.0)));
        let (a, l) = speech_activity(&frames(&levels), &ActivityOptions::default()).unwrap();
        assert!(a[..30].iter().all(|&x| x == 0.0), "{a:?}");
        assert!(a[30..].iter().all(|&x| x == 1.0), "{a:?}");
        // Loudness: 1 at the loud end, (1 − 20/40) at −20 dB, 0 in the pauses.
        assert!((l[99] - 1.0).abs() < 1e-9 && (l[30] - 0.5).abs() < 0.02 && l[0] == 0.0);
    }

    #[test]
    fn the_same_speech_at_another_level_or_over_digital_silence_reads_the_same() {
        let mut levels = vec![-60.0; 30];
        levels.extend((0..70).map(|i| -30.0 + 30.0 * ((i as f64) * 0.3).sin().abs()));
        let opts = ActivityOptions::default();
        let (a, l) = speech_activity(&frames(&levels), &opts).unwrap();
        // 25 dB quieter: the same activity and loudness.
        let quiet: Vec<f64> = levels.iter().map(|v| v - 25.0).collect();
        let (aq, lq) = speech_activity(&frames(&quiet), &opts).unwrap();
        assert!(a.iter().zip(&aq).all(|(x, y)| (x - y).abs() < 1e-9));
        assert!(l.iter().zip(&lq).all(|(x, y)| (x - y).abs() < 1e-9));
        // Pauses of digital zero (−200 dB) instead of a −60 dB room: the floor is held 50 dB
        // below the speech, so a decaying tail 55 dB down is still silence.
        let mut digital = levels.clone();
        digital[..30].iter_mut().for_each(|v| *v = -200.0);
        digital[29] = -55.0;
        let (ad, _) = speech_activity(&frames(&digital), &opts).unwrap();
        assert!(ad[..30].iter().all(|&x| x == 0.0), "{ad:?}");
        assert!(ad[30..].iter().zip(&a[30..]).all(|(x, y)| (x - y).abs() < 1e-9));
    }

    #[test]
    fn a_fricative_over_a_loud_hum_counts_as_speech() {
        // A −20 dB hum in the two lowest of 8 bands, −60 dB elsewhere; loud speech in frames
        // 30–39. Frame 5, a fricative at −20 dB in the top four bands, raises the total only
        // 4.8 dB over the hum, but its own bands by 35 dB.
        let db = |v: f64| v * NEPER_PER_DB;
        let mut m = DMatrix::from_fn(40, 8, |_, j| if j < 2 { db(-20.0) } else { db(-60.0) });
        for t in 30..40 {
            m.row_mut(t).fill(db(-5.0));
        }
        for j in 4..8 {
            m[(5, j)] = db(-20.0);
        }
        let (a, _) = speech_activity(&m, &ActivityOptions::default()).unwrap();
        assert_eq!(a[5], 1.0);
        assert_eq!(a[4], 0.0);
    }

    #[test]
    fn bad_options_and_input_are_errors() {
        let ok = ActivityOptions::default();
        assert!(ok.validate().is_ok());
        for wrong in [
            ActivityOptions { floor_quantile: 0.99, ..ok.clone() },
            ActivityOptions { onset_db: 20.0, ..ok.clone() },
            ActivityOptions { max_range_db: f64::INFINITY, ..ok.clone() },
        ] {
            assert!(wrong.validate().is_err(), "{wrong:?}");
        }
        assert!(speech_activity(&DMatrix::zeros(0, 4), &ok).is_err());
        assert!(speech_activity(&DMatrix::from_element(3, 2, f64::NAN), &ok).is_err());
    }
}
