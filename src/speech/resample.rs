//! Band-limited resampling of a mono signal to another sample rate: windowed-sinc
//! interpolation (Smith, "Digital Audio Resampling", the bandlimited interpolation method),
//! low-pass at the lower of the two Nyquist frequencies so downsampling does not alias.
//!
//! [`Resampler`] takes the signal in blocks and keeps only the input samples the next output
//! still needs (a kernel's width), so an hour of audio resamples in bounded memory. Between
//! integer rates (every WAV's), output i lies at input time `i·M/L` (`L/M` the ratio in
//! lowest terms), whose fractional part takes only L values: the kernel is tabulated once per
//! phase (polyphase form), so each output costs one dot product rather than a sine and a
//! cosine per tap.

use super::error::{SpeechError, bad};
use std::f64::consts::PI;

/// Zero crossings of the sinc kept on each side of an output sample. 16 keeps the pass-band
/// ripple and stop-band leakage of the Hann-windowed kernel well under the MFCC's resolution
/// (a 25 ms window, 26 mel bands) at a cost of 32 taps per output sample per unit ratio.
const HALF_TAPS: f64 = 16.0;
/// Largest polyphase table (phases × taps); rarer rate pairs evaluate the kernel per tap.
const MAX_TABLE: usize = 1 << 22;

/// The kernel tabulated by phase: `taps[p]` are the weights of inputs `n0 + first[p] + k`
/// for an output at input time `n0 + p/L`.
#[derive(Clone, Debug)]
struct Polyphase {
    l: u64,
    m: u64,
    first: Vec<i64>,
    taps: Vec<Vec<f64>>,
}

/// A streaming resampler from one rate to another.
#[derive(Clone, Debug)]
pub struct Resampler {
    ratio: f64,
    cutoff: f64,
    half_width: f64,
    table: Option<Polyphase>,
    /// Input samples from absolute index `kept_from` on.
    kept: Vec<f32>,
    kept_from: usize,
    received: usize,
    next_out: usize,
}

fn sinc(x: f64) -> f64 {
    if x.abs() < 1e-12 { 1.0 } else { (PI * x).sin() / (PI * x) }
}

fn gcd(a: u64, b: u64) -> u64 {
    if b == 0 { a } else { gcd(b, a % b) }
}

impl Resampler {
    /// A resampler from `from_hz` to `to_hz`.
    ///
    /// # Errors
    /// A rate that is not positive and finite.
    pub fn new(from_hz: f64, to_hz: f64) -> Result<Self, SpeechError> {
        for (name, r) in [("source rate", from_hz), ("target rate", to_hz)] {
            if !(r.is_finite() && r > 0.0) {
                return Err(bad(name, format!("{r} Hz")));
            }
        }
        let ratio = to_hz / from_hz;
        // Cut-off as a fraction of the source rate's Nyquist frequency.
        let cutoff = ratio.min(1.0);
        let half_width = HALF_TAPS / cutoff;
        let mut r = Self {
            ratio,
            cutoff,
            half_width,
            table: None,
            kept: Vec::new(),
            kept_from: 0,
            received: 0,
            next_out: 0,
        };
        let integral = |v: f64| v.fract() == 0.0 && v <= f64::from(u32::MAX);
        if integral(from_hz) && integral(to_hz) {
            let (a, b) = (from_hz as u64, to_hz as u64);
            let g = gcd(a, b);
            let (l, m) = (b / g, a / g);
            let width = 2 * half_width.ceil() as usize + 2;
            if (l as usize).saturating_mul(width) <= MAX_TABLE {
                r.table = Some(r.polyphase(l, m));
            }
        }
        Ok(r)
    }

    fn kernel(&self, x: f64) -> f64 {
        if x.abs() > self.half_width {
            return 0.0;
        }
        let window = 0.5 + 0.5 * (PI * x / self.half_width).cos();
        self.cutoff * sinc(self.cutoff * x) * window
    }

    fn polyphase(&self, l: u64, m: u64) -> Polyphase {
        let (mut first, mut taps) =
            (Vec::with_capacity(l as usize), Vec::with_capacity(l as usize));
        for p in 0..l {
            let frac = p as f64 / l as f64;
            let lo = (frac - self.half_width).ceil() as i64;
            let hi = (frac + self.half_width).floor() as i64;
            first.push(lo);
            taps.push((lo..=hi).map(|k| self.kernel(frac - k as f64)).collect());
        }
        Polyphase { l, m, first, taps }
    }

    /// Input time of output `i`.
    fn time_of(&self, i: usize) -> f64 {
        i as f64 / self.ratio
    }

    /// The last input sample output `i` reads.
    fn last_input(&self, i: usize) -> i64 {
        match &self.table {
            Some(t) => {
                let pos = i as u64 * t.m;
                let (n0, p) = ((pos / t.l) as i64, (pos % t.l) as usize);
                n0 + t.first[p] + t.taps[p].len() as i64 - 1
            }
            None => (self.time_of(i) + self.half_width).floor() as i64,
        }
    }

    /// The first input sample output `i` reads.
    fn first_input(&self, i: usize) -> i64 {
        match &self.table {
            Some(t) => {
                let pos = i as u64 * t.m;
                (pos / t.l) as i64 + t.first[(pos % t.l) as usize]
            }
            None => (self.time_of(i) - self.half_width).ceil() as i64,
        }
    }

    /// Output `i` from the kept inputs; inputs outside the signal count as zero.
    fn output(&self, i: usize) -> f32 {
        let sample = |n: i64| -> f64 {
            if n < self.kept_from as i64 {
                return 0.0;
            }
            self.kept.get((n - self.kept_from as i64) as usize).map_or(0.0, |&v| f64::from(v))
        };
        let acc: f64 = match &self.table {
            Some(t) => {
                let pos = i as u64 * t.m;
                let (n0, p) = ((pos / t.l) as i64, (pos % t.l) as usize);
                let start = n0 + t.first[p];
                t.taps[p].iter().enumerate().map(|(k, w)| w * sample(start + k as i64)).sum()
            }
            None => {
                let t = self.time_of(i);
                (self.first_input(i)..=self.last_input(i))
                    .map(|n| self.kernel(t - n as f64) * sample(n))
                    .sum()
            }
        };
        acc as f32
    }

    /// Adds the next `input` samples and appends every output they complete to `out`.
    pub fn push(&mut self, input: &[f32], out: &mut Vec<f32>) {
        self.kept.extend_from_slice(input);
        self.received += input.len();
        while self.last_input(self.next_out) < self.received as i64 {
            out.push(self.output(self.next_out));
            self.next_out += 1;
        }
        let needed = self.first_input(self.next_out).max(0) as usize;
        if needed > self.kept_from {
            let cut = (needed - self.kept_from).min(self.kept.len());
            self.kept.drain(..cut);
            self.kept_from += cut;
        }
    }

    /// Appends the remaining outputs (the signal zero past its end): in all,
    /// `round(inputs × ratio)` of them (at least one for a non-empty input).
    pub fn finish(mut self, out: &mut Vec<f32>) {
        let total = if self.received == 0 {
            0
        } else {
            ((self.received as f64) * self.ratio).round().max(1.0) as usize
        };
        // Outputs made while pushing lie before `received − half_width`, so never past it.
        while self.next_out < total {
            out.push(self.output(self.next_out));
            self.next_out += 1;
        }
    }
}

/// `samples` at `from_hz` resampled to `to_hz` (one block through a [`Resampler`]). Equal
/// rates return the input unchanged.
///
/// # Errors
/// A non-positive or non-finite rate.
pub fn resample(samples: &[f32], from_hz: f64, to_hz: f64) -> Result<Vec<f32>, SpeechError> {
    let mut r = Resampler::new(from_hz, to_hz)?;
    if (from_hz - to_hz).abs() < 1e-9 || samples.is_empty() {
        return Ok(samples.to_vec());
    }
    let mut out = Vec::with_capacity((samples.len() as f64 * to_hz / from_hz) as usize + 1);
    r.push(samples, &mut out);
    r.finish(&mut out);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn tone(hz: f64, rate: f64, n: usize) -> Vec<f32> {
        (0..n).map(|i| (2.0 * PI * hz * i as f64 / rate).sin() as f32).collect()
    }

    #[test]
    fn a_tone_survives_resampling_and_one_above_the_new_nyquist_is_removed() {
        let x = tone(440.0, 22_050.0, 22_050);
        let y = resample(&x, 22_050.0, 16_000.0).unwrap();
        assert_eq!(y.len(), 16_000);
        let want = tone(440.0, 16_000.0, 16_000);
        let err = y[200..15_800]
            .iter()
            .zip(&want[200..15_800])
            .map(|(a, b)| (a - b).abs())
            .fold(0.0f32, f32::max);
        assert!(err < 0.01, "max error {err}");
        // 10 kHz is above 8 kHz, the new Nyquist frequency: it must not alias into the band.
        let z = resample(&tone(10_000.0, 22_050.0, 22_050), 22_050.0, 16_000.0).unwrap();
        let rms = (z[200..15_800].iter().map(|v| v * v).sum::<f32>() / 15_600.0).sqrt();
        assert!(rms < 0.01, "aliased rms {rms}");
    }

    #[test]
    fn blocks_of_any_size_give_the_same_samples_and_the_table_the_direct_kernel() {
        let x: Vec<f32> = (0..9_001).map(|i| ((i * 7919) % 1000) as f32 / 1000.0 - 0.5).collect();
        for (from, to) in [(44_100.0, 16_000.0), (48_000.0, 16_000.0), (22_050.5, 16_000.0)] {
            let whole = resample(&x, from, to).unwrap();
            for block in [1usize, 333, 4096] {
                let mut r = Resampler::new(from, to).unwrap();
                let mut out = Vec::new();
                for c in x.chunks(block) {
                    r.push(c, &mut out);
                    // Only a kernel's width of input is kept.
                    assert!(r.kept.len() <= block + 2 * r.half_width as usize + 4);
                }
                r.finish(&mut out);
                assert_eq!(out, whole, "{from} → {to}, blocks of {block}");
            }
            // The polyphase table and the kernel evaluated per tap agree.
            let mut direct = Resampler::new(from, to).unwrap();
            direct.table = None;
            let mut out = Vec::new();
            direct.push(&x, &mut out);
            direct.finish(&mut out);
            let d = out.iter().zip(&whole).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
            assert!(out.len() == whole.len() && d < 1e-5, "{from} → {to}: {d}");
        }
    }

    #[test]
    fn bad_rates_are_refused() {
        assert!(resample(&[0.0], 0.0, 16_000.0).is_err());
        assert!(resample(&[0.0], 16_000.0, f64::NAN).is_err());
    }
}
