//! The audio vector of each video frame, normalised per recording so that a voice, a
//! microphone and a room the model never heard give features it knows.
//!
//! From a recording's log mel energies (T × J, [`super::mfcc::LogMelAnalyser`]):
//! 1. cepstra c1 … c_n ([`super::mfcc::cepstra`]);
//! 2. cepstral mean and variance normalisation (CMVN) over the recording's speech: each
//!    coefficient minus its mean, over its standard deviation, both weighted by the speech
//!    activity `a_t` ([`super::activity`]), so long pauses do not move the statistics. The
//!    mean removes a constant channel (microphone, room), the variance a voice's or a
//!    recording's spread (the paper, with one speaker and one studio, removes neither);
//! 3. each frame's normalised cepstra times `a_t`: non-speech fades to the zero vector, the
//!    same on every recording whatever its noise;
//! 4. two more values: the loudness relative to the recording's loud speech times `a_t`, and
//!    `a_t` itself, each × [`LEVEL_SCALE`]. The jaw opens with the loudness of a vowel; c0,
//!    which carries it, is absolute (recording level) and left out of the cepstra, so it comes
//!    back relative.
//!
//! [`audio_features`] then stacks the co-articulation context (`super::context`).

use super::activity::{ActivityOptions, speech_activity};
use super::context::stack_context;
use super::error::SpeechError;
use super::mfcc::{MfccOptions, cepstra};
use crate::math::DMatrix;

/// Scale of the loudness and activity columns. Both lie in [0, 1] with a spread of about
/// 0.4; × 3 puts them near the normalised cepstra's unit spread, so the baseline's ridge,
/// relative to the mean feature variance, treats them alike.
pub const LEVEL_SCALE: f64 = 3.0;

/// Values per frame: the cepstra, loudness and activity.
pub fn frame_dim(mfcc: &MfccOptions) -> usize {
    mfcc.n_ceps + 2
}

/// Weight below which a recording has no speech to normalise by (less than a frame's worth).
const MIN_SPEECH_WEIGHT: f64 = 1.0;

/// The per-frame audio vectors (T × (n_ceps + 2)) of a recording's log mel energies, as the
/// module doc describes.
///
/// # Errors
/// No frames, a width that is not the options' filter count, non-finite energies, options
/// out of range.
pub fn frame_features(
    log_mel: &DMatrix,
    mfcc: &MfccOptions,
    activity: &ActivityOptions,
) -> Result<DMatrix, SpeechError> {
    mfcc.validate()?;
    if log_mel.ncols() != mfcc.n_filters {
        return Err(SpeechError::DimensionMismatch {
            what: "mel filters per frame",
            expected: mfcc.n_filters,
            got: log_mel.ncols(),
        });
    }
    let (a, loudness) = speech_activity(log_mel, activity)?;
    let c = cepstra(log_mel, mfcc.n_ceps);
    let weight: f64 = a.iter().sum();
    let t_len = log_mel.nrows();
    let mut out = DMatrix::zeros(t_len, frame_dim(mfcc));
    for (k, col) in c.column_iter().enumerate() {
        // Without speech every frame is faded to zero, whatever the statistics.
        let (mean, sd) = if weight < MIN_SPEECH_WEIGHT {
            (0.0, 1.0)
        } else {
            let mean = col.iter().zip(&a).map(|(x, w)| x * w).sum::<f64>() / weight;
            let var = col.iter().zip(&a).map(|(x, w)| w * (x - mean).powi(2)).sum::<f64>() / weight;
            (mean, var.sqrt().max(1e-9))
        };
        for t in 0..t_len {
            out[(t, k)] = a[t] * (col[t] - mean) / sd;
        }
    }
    let n = mfcc.n_ceps;
    for t in 0..t_len {
        out[(t, n)] = LEVEL_SCALE * a[t] * loudness[t];
        out[(t, n + 1)] = LEVEL_SCALE * a[t];
    }
    Ok(out)
}

/// [`frame_features`] with `context` frames stacked on each side: T × (n_ceps + 2)(2t_c + 1).
///
/// # Errors
/// As [`frame_features`].
pub fn audio_features(
    log_mel: &DMatrix,
    mfcc: &MfccOptions,
    activity: &ActivityOptions,
    context: usize,
) -> Result<DMatrix, SpeechError> {
    Ok(stack_context(&frame_features(log_mel, mfcc, activity)?, context))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::speech::mfcc::compute_log_mel;

    /// White noise bursts (a fixed LCG stream) with a slow loudness swell, separated by
    /// pauses of low-level noise at `pause_level`.
    fn bursts(n: usize, pause_level: f32, seed: u64) -> Vec<f32> {
        let mut state = seed;
        (0..n as u32)
            .map(|i| {
                state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
                let white = (state >> 40) as f32 / (1u64 << 24) as f32 - 0.5;
                let on = (i / 4000) % 3 != 0;
                white * if on { 1.2 + (i as f32 * 0.0007).sin() } else { pause_level }
            })
            .collect()
    }

    fn features_of(x: &[f32]) -> DMatrix {
        let opts = MfccOptions::new(16_000.0, 25.0);
        frame_features(&compute_log_mel(x, &opts, 50).unwrap(), &opts, &ActivityOptions::default())
            .unwrap()
    }

    #[test]
    fn cmvn_removes_a_channel_filter_and_a_level() {
        // A fixed filter y[n] = x[n] + 0.8·x[n−1] and a gain of 0.1 add (nearly) the same
        // log gain to every frame of each band: a constant cepstral offset, which the
        // normalisation removes, and a level, which the loudness is relative to.
        let x = bursts(32_000, 1e-3, 12_345);
        let y: Vec<f32> =
            (0..x.len()).map(|n| 0.1 * (x[n] + if n > 0 { 0.8 * x[n - 1] } else { 0.0 })).collect();
        let opts = MfccOptions::new(16_000.0, 25.0);
        let raw = |v: &[f32]| cepstra(&compute_log_mel(v, &opts, 50).unwrap(), opts.n_ceps);
        let (fx, fy) = (features_of(&x), features_of(&y));
        // Frames 7–18 lie inside the first burst (samples 4000–11999).
        let inside = |m: &DMatrix, cols: usize| m.view((7, 0), (12, cols)).into_owned();
        let d_raw = (inside(&raw(&x), 11) - inside(&raw(&y), 11)).abs().max();
        let d = (inside(&fx, 13) - inside(&fy, 13)).abs().max();
        assert!(d < 0.2 * d_raw, "normalised {d}, raw {d_raw}");
        // Pauses are zero; speech is not.
        assert!(fx.row(2).iter().all(|v| *v == 0.0), "{}", fx.row(2));
        assert!(fx.row(15).iter().any(|v| v.abs() > 0.1));
    }

    #[test]
    fn pauses_read_the_same_whatever_their_noise() {
        // The same bursts with pauses at −60 dB or at digital zero: the pause frames are the
        // same fixed vector (zero), the speech frames barely move.
        let quiet = bursts(32_000, 1e-3, 7);
        let digital = bursts(32_000, 0.0, 7);
        let (fq, fd) = (features_of(&quiet), features_of(&digital));
        for t in [1, 2, 3, 21, 22, 39, 40] {
            assert!(fq.row(t).iter().chain(fd.row(t).iter()).all(|v| *v == 0.0), "frame {t}");
        }
        assert!((&fq - &fd).rows(8, 10).abs().max() < 0.1);
    }

    #[test]
    fn a_recording_without_speech_is_all_zero() {
        let f = features_of(&vec![0.0; 20_000]);
        assert!(f.iter().all(|v| *v == 0.0));
    }
}
