//! Mel-frequency cepstral coefficients at the video frame rate (Terissi et al. 2011, §3 and
//! §6.1: the first eleven non-DC mel-cepstral coefficients, one vector per video frame).
//!
//! Per frame: pre-emphasis `y[n] = x[n] − a·x[n−1]` (whole signal), a Hamming window centred
//! on the frame's time `f / fps`, the power spectrum by FFT, triangular filters equally spaced
//! on the mel scale `mel(f) = 2595·log10(1 + f/700)`, the log of each filter's energy, and the
//! DCT-II `c_i = √(2/J) Σ_j log E_j · cos(π i (j + ½) / J)` for i = 1 … n_ceps (c0, the
//! frame's loudness, is left out). Cepstral mean normalisation then subtracts each
//! coefficient's mean over the clip, removing a constant channel (microphone, room) response.
//! The conventions are HTK's (Young et al., *The HTK Book*, §5.4).

use super::error::{SpeechError, bad};
use crate::math::DMatrix;
use rustfft::FftPlanner;
use rustfft::num_complex::Complex;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// How the audio features are computed; stored in a trained model so audio is analysed the
/// same way at inversion.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct MfccOptions {
    /// Sample rate of the signal, Hz.
    pub sample_rate: f64,
    /// Video frame rate, frames per second: one MFCC vector per frame.
    pub frame_rate: f64,
    /// Analysis window length, seconds.
    pub window_s: f64,
    /// Pre-emphasis coefficient `a`.
    pub pre_emphasis: f64,
    /// Number of mel filters J.
    pub n_filters: usize,
    /// Cepstral coefficients kept, c1 … c_n.
    pub n_ceps: usize,
    /// Filterbank edges, Hz.
    pub low_hz: f64,
    pub high_hz: f64,
    /// Subtract the clip's mean of each coefficient.
    pub mean_normalise: bool,
}

impl MfccOptions {
    /// The defaults for audio at `sample_rate` and video at `frame_rate`: 11 coefficients
    /// (the paper's), 26 filters over 0 Hz … Nyquist, pre-emphasis 0.97 (HTK's), a 25 ms
    /// window (the usual speech analysis frame, short enough that a stop burst is not smeared
    /// over a vowel), cepstral mean normalisation on.
    pub fn new(sample_rate: f64, frame_rate: f64) -> Self {
        Self {
            sample_rate,
            frame_rate,
            window_s: 0.025,
            pre_emphasis: 0.97,
            n_filters: 26,
            n_ceps: 11,
            low_hz: 0.0,
            high_hz: sample_rate / 2.0,
            mean_normalise: true,
        }
    }

    /// Checks the options, bounded by what speech analysis can mean (they also come from
    /// model files): rates within what a recording or a video has, a window of at most a
    /// second, at most 256 filters. Without the bounds a number read from a file would size
    /// the frame and filterbank tables.
    pub(crate) fn validate(&self) -> Result<(), SpeechError> {
        let within = |v: f64, hi: f64| v.is_finite() && v > 0.0 && v <= hi;
        if !within(self.sample_rate, 384_000.0) {
            return Err(bad("sample rate", format!("{} Hz", self.sample_rate)));
        }
        if !within(self.frame_rate, 1000.0) {
            return Err(bad("frame rate", format!("{} fps", self.frame_rate)));
        }
        if !within(self.window_s, 1.0) || self.window_s * self.sample_rate < 4.0 {
            return Err(bad("window", format!("{} s", self.window_s)));
        }
        if !(2..=256).contains(&self.n_filters) || self.n_ceps == 0 || self.n_ceps >= self.n_filters
        {
            return Err(bad(
                "filterbank",
                format!("{} coefficients from {} filters", self.n_ceps, self.n_filters),
            ));
        }
        if !(0.0 <= self.low_hz
            && self.low_hz < self.high_hz
            && self.high_hz <= self.sample_rate / 2.0)
        {
            return Err(bad("band", format!("{} … {} Hz", self.low_hz, self.high_hz)));
        }
        Ok(())
    }
}

/// Video frames covered by `n_samples` of audio: frame f at time f / fps, while it is inside
/// the signal.
pub fn frame_count(n_samples: usize, opts: &MfccOptions) -> usize {
    let duration = n_samples as f64 / opts.sample_rate;
    ((duration * opts.frame_rate) - 1e-9).ceil().max(0.0) as usize
}

/// Mel scale (HTK).
pub fn hz_to_mel(hz: f64) -> f64 {
    2595.0 * (1.0 + hz / 700.0).log10()
}

/// Inverse of [`hz_to_mel`].
pub fn mel_to_hz(mel: f64) -> f64 {
    700.0 * (10f64.powf(mel / 2595.0) - 1.0)
}

/// The triangular mel filterbank as a J × (n_fft/2 + 1) matrix of weights on FFT bins: filter
/// j rises from centre j − 1 to 1 at centre j and falls to 0 at centre j + 1, the J + 2
/// edges equally spaced in mel between `low_hz` and `high_hz`.
pub fn mel_filterbank(
    n_filters: usize,
    n_fft: usize,
    sample_rate: f64,
    low_hz: f64,
    high_hz: f64,
) -> DMatrix {
    let n_bins = n_fft / 2 + 1;
    let (lo, hi) = (hz_to_mel(low_hz), hz_to_mel(high_hz));
    let edges: Vec<f64> = (0..n_filters + 2)
        .map(|i| mel_to_hz(lo + (hi - lo) * i as f64 / (n_filters + 1) as f64))
        .collect();
    let mut fb = DMatrix::zeros(n_filters, n_bins);
    for j in 0..n_filters {
        let (l, c, r) = (edges[j], edges[j + 1], edges[j + 2]);
        for b in 0..n_bins {
            let f = b as f64 * sample_rate / n_fft as f64;
            let w = if f > l && f <= c {
                (f - l) / (c - l)
            } else if f > c && f < r {
                (r - f) / (r - c)
            } else {
                0.0
            };
            fb[(j, b)] = w;
        }
    }
    fb
}

/// DCT-II of log filterbank energies, coefficients 1 ..= n_ceps (c0 left out).
pub fn cepstrum(log_energies: &[f64], n_ceps: usize) -> Vec<f64> {
    let j_len = log_energies.len() as f64;
    let norm = (2.0 / j_len).sqrt();
    (1..=n_ceps)
        .map(|i| {
            norm * log_energies
                .iter()
                .enumerate()
                .map(|(j, e)| e * (PI * i as f64 * (j as f64 + 0.5) / j_len).cos())
                .sum::<f64>()
        })
        .collect()
}

/// Hamming window of length n.
fn hamming(n: usize) -> Vec<f64> {
    let d = (n.max(2) - 1) as f64;
    (0..n).map(|i| 0.54 - 0.46 * (2.0 * PI * i as f64 / d).cos()).collect()
}

/// Floor on filter energies before the log: silence (digital zero) gives a finite, constant
/// cepstrum instead of −∞. Relative to a full-scale signal's energy this is −200 dB.
const ENERGY_FLOOR: f64 = 1e-20;

/// MFCCs of `samples` for `n_frames` video frames: an `n_frames × n_ceps` matrix, row f for
/// the window centred at `f / frame_rate`. Samples outside the signal count as zero.
///
/// # Errors
/// Invalid options, no samples, no frames, or a non-finite sample.
pub fn compute_mfcc(
    samples: &[f32],
    opts: &MfccOptions,
    n_frames: usize,
) -> Result<DMatrix, SpeechError> {
    opts.validate()?;
    if samples.is_empty() {
        return Err(SpeechError::Empty("audio samples"));
    }
    if n_frames == 0 {
        return Err(SpeechError::Empty("video frames"));
    }
    if let Some(i) = samples.iter().position(|s| !s.is_finite()) {
        return Err(bad("sample", format!("sample {i} is not finite")));
    }
    let emphasised: Vec<f64> = (0..samples.len())
        .map(|n| {
            let prev = if n == 0 { 0.0 } else { f64::from(samples[n - 1]) };
            f64::from(samples[n]) - opts.pre_emphasis * prev
        })
        .collect();
    let win_len = (opts.window_s * opts.sample_rate).round() as usize;
    let n_fft = win_len.next_power_of_two();
    let window = hamming(win_len);
    let fb = mel_filterbank(opts.n_filters, n_fft, opts.sample_rate, opts.low_hz, opts.high_hz);
    let fft = FftPlanner::<f64>::new().plan_fft_forward(n_fft);
    let mut buf = vec![Complex::new(0.0, 0.0); n_fft];
    let mut out = DMatrix::zeros(n_frames, opts.n_ceps);
    let mut power = vec![0.0; n_fft / 2 + 1];
    for f in 0..n_frames {
        let centre = (f as f64 / opts.frame_rate * opts.sample_rate).round() as isize;
        let start = centre - (win_len / 2) as isize;
        for (i, b) in buf.iter_mut().enumerate() {
            let n = start + i as isize;
            let x = if i < win_len && n >= 0 && (n as usize) < emphasised.len() {
                emphasised[n as usize] * window[i]
            } else {
                0.0
            };
            *b = Complex::new(x, 0.0);
        }
        fft.process(&mut buf);
        for (p, b) in power.iter_mut().zip(&buf) {
            *p = b.norm_sqr();
        }
        let log_e: Vec<f64> = (0..opts.n_filters)
            .map(|j| {
                let e: f64 = fb.row(j).iter().zip(&power).map(|(w, p)| w * p).sum();
                e.max(ENERGY_FLOOR).ln()
            })
            .collect();
        for (i, c) in cepstrum(&log_e, opts.n_ceps).into_iter().enumerate() {
            out[(f, i)] = c;
        }
    }
    if opts.mean_normalise {
        for mut col in out.column_iter_mut() {
            let mean = col.mean();
            col.add_scalar_mut(-mean);
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mel_scale_round_trips_and_matches_htk_at_1000_hz() {
        // 2595·log10(1 + 1000/700) = 999.99 mel: the scale is built to make 1 kHz ≈ 1000 mel.
        assert!((hz_to_mel(1000.0) - 999.985).abs() < 0.01);
        assert!((mel_to_hz(hz_to_mel(3210.0)) - 3210.0).abs() < 1e-9);
    }

    #[test]
    fn a_tone_lands_in_the_filter_centred_on_it() {
        // 16 kHz, 4 filters over 0 … 8000 Hz: centres at mel 2840.0·{1,2,3,4}/5 …
        let opts = MfccOptions {
            n_filters: 4,
            n_ceps: 3,
            mean_normalise: false,
            pre_emphasis: 0.0,
            ..MfccOptions::new(16_000.0, 25.0)
        };
        let hi = hz_to_mel(8000.0);
        let centre2 = mel_to_hz(hi * 2.0 / 5.0); // filter index 1
        let n_fft = 512;
        let fb = mel_filterbank(4, n_fft, 16_000.0, 0.0, 8000.0);
        // Put the tone exactly on an FFT bin near that centre.
        let bin = (centre2 * n_fft as f64 / 16_000.0).round();
        let hz = bin * 16_000.0 / n_fft as f64;
        let best = (0..4)
            .max_by(|&a, &b| fb[(a, bin as usize)].total_cmp(&fb[(b, bin as usize)]))
            .unwrap();
        assert_eq!(best, 1, "tone at {hz} Hz");
        // Rows are triangles peaking at most at 1.
        assert!(fb.iter().all(|w| (0.0..=1.0).contains(w)));
        // Through the whole pipeline: c_i ∝ Σ_j log E_j cos(π i (j+½)/4) is dominated by the
        // loud filter 1 against the three quiet ones, so the cepstrum follows cos(π i 1.5/4)
        // in sign: c1 > 0, c2 < 0, c3 < 0.
        let x: Vec<f32> =
            (0..16_000).map(|n| (2.0 * PI * hz * n as f64 / 16_000.0).sin() as f32).collect();
        let c = compute_mfcc(&x, &opts, 10).unwrap();
        let row = c.row(5);
        assert!(row[0] > 0.0 && row[1] < 0.0 && row[2] < 0.0, "{row}");
    }

    #[test]
    fn the_dct_matches_a_hand_computation() {
        // J = 2: c1 = √(2/2)·(e0·cos(π/4) + e1·cos(3π/4)) = (e0 − e1)/√2.
        let c = cepstrum(&[3.0, 1.0], 1);
        assert!((c[0] - 2.0 / 2f64.sqrt()).abs() < 1e-12);
        // A flat log spectrum has no cepstrum beyond c0.
        assert!(cepstrum(&[2.0; 8], 5).iter().all(|c| c.abs() < 1e-12));
    }

    #[test]
    fn mean_normalisation_removes_a_channel_filter() {
        // A fixed filter y[n] = x[n] + 0.8·x[n−1] adds (nearly) the same log gain to every
        // frame of each band: a constant cepstral offset, which the clip mean removes.
        // White noise (a fixed LCG stream) with a slow loudness swell: energy in every band.
        let mut state = 12_345u64;
        let x: Vec<f32> = (0..16_000u32)
            .map(|n| {
                state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
                let white = (state >> 40) as f32 / (1u64 << 24) as f32 - 0.5;
                white * (1.2 + (n as f32 * 0.0007).sin())
            })
            .collect();
        let y: Vec<f32> =
            (0..x.len()).map(|n| x[n] + if n > 0 { 0.8 * x[n - 1] } else { 0.0 }).collect();
        let raw = MfccOptions { mean_normalise: false, ..MfccOptions::new(16_000.0, 25.0) };
        let cmn = MfccOptions::new(16_000.0, 25.0);
        let d = |o: &MfccOptions| {
            (compute_mfcc(&x, o, 25).unwrap() - compute_mfcc(&y, o, 25).unwrap()).abs().max()
        };
        let (d_raw, d_cmn) = (d(&raw), d(&cmn));
        assert!(d_cmn < 0.2 * d_raw, "with CMN {d_cmn}, without {d_raw}");
        let m = compute_mfcc(&x, &cmn, 25).unwrap();
        assert!(m.row_mean().abs().max() < 1e-9);
    }

    #[test]
    fn bad_input_is_an_error() {
        let opts = MfccOptions::new(16_000.0, 25.0);
        assert_eq!(compute_mfcc(&[], &opts, 3), Err(SpeechError::Empty("audio samples")));
        assert!(compute_mfcc(&[0.0, f32::NAN], &opts, 1).is_err());
        assert!(compute_mfcc(&[0.0; 100], &MfccOptions { n_ceps: 30, ..opts }, 1).is_err());
    }

    #[test]
    fn options_beyond_speech_analysis_are_refused() {
        let opts = MfccOptions::new(16_000.0, 25.0);
        assert_eq!(opts.validate(), Ok(()));
        for wrong in [
            MfccOptions { sample_rate: 1e9, ..opts },
            MfccOptions { frame_rate: 1e7, ..opts },
            MfccOptions { window_s: 50.0, ..opts },
            MfccOptions { n_filters: 100_000, ..opts },
        ] {
            assert!(wrong.validate().is_err(), "{wrong:?}");
        }
    }
}
