//! Mel-frequency cepstral coefficients at the video frame rate (Terissi et al. 2011, §3 and
//! §6.1: the first eleven non-DC mel-cepstral coefficients, one vector per video frame),
//! computed as the audio streams in.
//!
//! Per frame: pre-emphasis `y[n] = x[n] − a·x[n−1]`, a Hamming window centred on the frame's
//! time `f / fps`, the power spectrum by FFT, triangular filters equally spaced on the mel
//! scale `mel(f) = 2595·log10(1 + f/700)`, and the log of each filter's energy
//! ([`LogMelAnalyser`], one row per frame); then the DCT-II
//! `c_i = √(2/J) Σ_j log E_j · cos(π i (j + ½) / J)` for i = 1 … n_ceps ([`cepstra`]; c0, the
//! frame's loudness, is left out of the cepstra and measured relative to the recording in
//! [`super::activity`]). The conventions are HTK's (Young et al., *The HTK Book*, §5.4).
//!
//! The analyser keeps only the samples of the windows still to come, so a recording of any
//! length is analysed in bounded memory; what it keeps per frame (J log energies) is what
//! the per-recording normalisation of [`super::features`] needs.

use super::error::{SpeechError, bad};
use crate::math::DMatrix;
use rustfft::num_complex::Complex;
use rustfft::{Fft, FftPlanner};
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;
use std::sync::Arc;

/// How the audio is analysed; stored in a trained model so audio is analysed the same way at
/// inversion.
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
}

impl MfccOptions {
    /// The defaults for audio at `sample_rate` and video at `frame_rate`: 11 coefficients
    /// (the paper's), 26 filters over 0 Hz … Nyquist, pre-emphasis 0.97 (HTK's), a 25 ms
    /// window (the usual speech analysis frame, short enough that a stop burst is not smeared
    /// over a vowel).
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
        }
    }

    /// Checks the options, bounded by what speech analysis can mean (they also come from
    /// model files): rates within what a recording or a video has, a window of at most a
    /// second, at most 256 filters, a pre-emphasis in [0, 1). Without the bounds a number
    /// read from a file would size the frame and filterbank tables.
    ///
    /// # Errors
    /// The first option out of its range, named.
    pub fn validate(&self) -> Result<(), SpeechError> {
        let within = |v: f64, hi: f64| v.is_finite() && v > 0.0 && v <= hi;
        if !within(self.sample_rate, f64::from(crate::io::wav::MAX_SAMPLE_RATE_HZ)) {
            return Err(bad("sample rate", format!("{} Hz", self.sample_rate)));
        }
        if !within(self.frame_rate, 1000.0) {
            return Err(bad("frame rate", format!("{} fps", self.frame_rate)));
        }
        if !within(self.window_s, 1.0) || self.window_s * self.sample_rate < 4.0 {
            return Err(bad("window", format!("{} s", self.window_s)));
        }
        if !(self.pre_emphasis.is_finite() && (0.0..1.0).contains(&self.pre_emphasis)) {
            return Err(bad("pre-emphasis", self.pre_emphasis.to_string()));
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

/// The cepstra (T × n_ceps) of every row of `log_mel` (T × J), by [`cepstrum`].
pub fn cepstra(log_mel: &DMatrix, n_ceps: usize) -> DMatrix {
    let j_len = log_mel.ncols();
    // One J × n_ceps DCT matrix: every frame's cepstrum is then a row of one product.
    let dct = DMatrix::from_fn(j_len, n_ceps, |j, i| {
        let mut unit = vec![0.0; j_len];
        unit[j] = 1.0;
        cepstrum(&unit, n_ceps)[i]
    });
    log_mel * dct
}

/// Hamming window of length n.
fn hamming(n: usize) -> Vec<f64> {
    let d = (n.max(2) - 1) as f64;
    (0..n).map(|i| 0.54 - 0.46 * (2.0 * PI * i as f64 / d).cos()).collect()
}

/// Floor on filter energies before the log: silence (digital zero) gives a finite, constant
/// log spectrum instead of −∞. Relative to a full-scale signal's energy this is −200 dB.
pub const ENERGY_FLOOR: f64 = 1e-20;

/// Log mel energies of the frames of a signal that arrives in blocks ([`LogMelAnalyser::push`]):
/// frame f is analysed as soon as the samples of its window have arrived, and samples no
/// window needs any more are dropped. Samples outside the signal count as zero.
pub struct LogMelAnalyser {
    opts: MfccOptions,
    /// Frames to make; `None`: those the signal covers ([`frame_count`]), known at the end.
    n_frames: Option<usize>,
    win_len: usize,
    window: Vec<f64>,
    /// Per filter: its first FFT bin and its weights from there.
    filters: Vec<(usize, Vec<f64>)>,
    fft: Arc<dyn Fft<f64>>,
    spectrum: Vec<Complex<f64>>,
    /// Pre-emphasised samples from absolute index `kept_from` on.
    kept: Vec<f64>,
    kept_from: usize,
    received: usize,
    last_raw: f64,
    next_frame: usize,
    /// Row-major: J values per analysed frame.
    rows: Vec<f64>,
}

impl LogMelAnalyser {
    /// An analyser for `opts`, making `n_frames` frames (or, with `None`, as many as the
    /// signal covers).
    ///
    /// # Errors
    /// Options out of range ([`MfccOptions::validate`]).
    pub fn new(opts: &MfccOptions, n_frames: Option<usize>) -> Result<Self, SpeechError> {
        opts.validate()?;
        let win_len = (opts.window_s * opts.sample_rate).round() as usize;
        let n_fft = win_len.next_power_of_two();
        let fb = mel_filterbank(opts.n_filters, n_fft, opts.sample_rate, opts.low_hz, opts.high_hz);
        let filters = fb
            .row_iter()
            .map(|row| {
                let first = row.iter().position(|w| *w > 0.0).unwrap_or(0);
                let last = row.iter().rposition(|w| *w > 0.0).map_or(first, |l| l + 1);
                (first, row.iter().skip(first).take(last - first).copied().collect())
            })
            .collect();
        Ok(Self {
            opts: opts.clone(),
            n_frames,
            win_len,
            window: hamming(win_len),
            filters,
            fft: FftPlanner::<f64>::new().plan_fft_forward(n_fft),
            spectrum: vec![Complex::new(0.0, 0.0); n_fft],
            kept: Vec::new(),
            kept_from: 0,
            received: 0,
            last_raw: 0.0,
            next_frame: 0,
            rows: Vec::new(),
        })
    }

    /// First sample of frame f's window (may be before the signal's start).
    fn window_start(&self, f: usize) -> isize {
        let centre = (f as f64 / self.opts.frame_rate * self.opts.sample_rate).round() as isize;
        centre - (self.win_len / 2) as isize
    }

    /// Adds the next `samples` of the signal and analyses every frame they complete.
    ///
    /// # Errors
    /// A sample that is not finite (named by its index in the whole signal).
    pub fn push(&mut self, samples: &[f32]) -> Result<(), SpeechError> {
        if let Some(i) = samples.iter().position(|s| !s.is_finite()) {
            return Err(bad("sample", format!("sample {} is not finite", self.received + i)));
        }
        for &s in samples {
            let x = f64::from(s);
            self.kept.push(x - self.opts.pre_emphasis * self.last_raw);
            self.last_raw = x;
        }
        self.received += samples.len();
        while self.wants(self.next_frame)
            && self.window_start(self.next_frame) + self.win_len as isize <= self.received as isize
        {
            self.analyse_next();
        }
        self.drop_used();
        Ok(())
    }

    /// Whether frame `f` is one to make, as far as is known yet.
    fn wants(&self, f: usize) -> bool {
        self.n_frames.is_none_or(|n| f < n)
    }

    fn analyse_next(&mut self) {
        let start = self.window_start(self.next_frame);
        for (i, b) in self.spectrum.iter_mut().enumerate() {
            let n = start + i as isize;
            let x = if i < self.win_len && n >= self.kept_from as isize {
                self.kept.get(n as usize - self.kept_from).map_or(0.0, |v| v * self.window[i])
            } else {
                0.0
            };
            *b = Complex::new(x, 0.0);
        }
        self.fft.process(&mut self.spectrum);
        for (first, weights) in &self.filters {
            let e: f64 =
                weights.iter().zip(&self.spectrum[*first..]).map(|(w, b)| w * b.norm_sqr()).sum();
            self.rows.push(e.max(ENERGY_FLOOR).ln());
        }
        self.next_frame += 1;
    }

    /// Forgets the samples before the next frame's window.
    fn drop_used(&mut self) {
        let needed = self.window_start(self.next_frame).max(0) as usize;
        if needed > self.kept_from {
            let cut = (needed - self.kept_from).min(self.kept.len());
            self.kept.drain(..cut);
            self.kept_from += cut;
        }
    }

    /// Samples received so far.
    pub fn samples_received(&self) -> usize {
        self.received
    }

    /// Analyses the remaining frames (their windows padded with zeros past the signal's end)
    /// and returns the log mel energies, one row of J per frame.
    pub fn finish(mut self) -> DMatrix {
        let total = self.n_frames.unwrap_or_else(|| frame_count(self.received, &self.opts));
        while self.next_frame < total {
            self.analyse_next();
        }
        DMatrix::from_row_slice(
            total,
            self.opts.n_filters,
            &self.rows[..total * self.opts.n_filters],
        )
    }
}

/// Log mel energies (T × J) of a whole signal for `n_frames` video frames.
///
/// # Errors
/// Invalid options, no samples, no frames, or a non-finite sample.
pub fn compute_log_mel(
    samples: &[f32],
    opts: &MfccOptions,
    n_frames: usize,
) -> Result<DMatrix, SpeechError> {
    if samples.is_empty() {
        return Err(SpeechError::Empty("audio samples"));
    }
    if n_frames == 0 {
        return Err(SpeechError::Empty("video frames"));
    }
    let mut a = LogMelAnalyser::new(opts, Some(n_frames))?;
    a.push(samples)?;
    Ok(a.finish())
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
        let c = cepstra(&compute_log_mel(&x, &opts, 10).unwrap(), 3);
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
        // The matrix form is the same transform, row by row.
        let rows = DMatrix::from_row_slice(2, 3, &[1.0, -2.0, 0.5, 3.0, 3.0, -1.0]);
        let m = cepstra(&rows, 2);
        for r in 0..2 {
            let one = cepstrum(&rows.row(r).iter().copied().collect::<Vec<_>>(), 2);
            assert!((m[(r, 0)] - one[0]).abs() < 1e-12 && (m[(r, 1)] - one[1]).abs() < 1e-12);
        }
    }

    /// White noise with a slow loudness swell (a fixed LCG stream).
    fn noise(n: usize) -> Vec<f32> {
        let mut state = 12_345u64;
        (0..n as u32)
            .map(|i| {
                state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
                let white = (state >> 40) as f32 / (1u64 << 24) as f32 - 0.5;
                white * (1.2 + (i as f32 * 0.0007).sin())
            })
            .collect()
    }

    #[test]
    fn streaming_in_any_blocks_equals_analysing_the_whole_signal() {
        let opts = MfccOptions::new(16_000.0, 24.0);
        let x = noise(23_456);
        let whole = compute_log_mel(&x, &opts, 40).unwrap();
        for block in [1usize, 7, 400, 1_000, 30_000] {
            let mut a = LogMelAnalyser::new(&opts, None).unwrap();
            for chunk in x.chunks(block) {
                a.push(chunk).unwrap();
                // What is kept stays within one window and one block.
                assert!(a.kept.len() <= a.win_len + block + 1, "{block}: {}", a.kept.len());
            }
            let got = a.finish();
            // 23,456 samples at 16 kHz = 1.466 s: frames 0 … 35 have their time inside.
            assert_eq!(got.nrows(), frame_count(x.len(), &opts));
            assert_eq!(got.nrows(), 36);
            assert!((got - whole.rows(0, 36)).abs().max() == 0.0, "block {block}");
        }
    }

    #[test]
    fn bad_input_is_an_error() {
        let opts = MfccOptions::new(16_000.0, 25.0);
        assert_eq!(compute_log_mel(&[], &opts, 3), Err(SpeechError::Empty("audio samples")));
        let e = compute_log_mel(&[0.0, f32::NAN], &opts, 1).unwrap_err().to_string();
        assert!(e.contains("sample 1"), "{e}");
        assert!(compute_log_mel(&[0.0; 100], &MfccOptions { n_ceps: 30, ..opts }, 1).is_err());
    }

    #[test]
    fn options_beyond_speech_analysis_are_refused() {
        let opts = MfccOptions::new(16_000.0, 25.0);
        assert_eq!(opts.validate(), Ok(()));
        for wrong in [
            MfccOptions { sample_rate: 1e9, ..opts.clone() },
            MfccOptions { frame_rate: 1e7, ..opts.clone() },
            MfccOptions { window_s: 50.0, ..opts.clone() },
            MfccOptions { n_filters: 100_000, ..opts.clone() },
            MfccOptions { pre_emphasis: f64::NAN, ..opts.clone() },
            MfccOptions { high_hz: 9000.0, ..opts.clone() },
        ] {
            assert!(wrong.validate().is_err(), "{wrong:?}");
        }
    }
}
