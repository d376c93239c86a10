//! Band-limited resampling of a mono signal to another sample rate: windowed-sinc
//! interpolation (Smith, "Digital Audio Resampling", the bandlimited interpolation method),
//! low-pass at the lower of the two Nyquist frequencies so downsampling does not alias.

use super::error::{SpeechError, bad};
use std::f64::consts::PI;

/// Zero crossings of the sinc kept on each side of an output sample. 16 keeps the pass-band
/// ripple and stop-band leakage of the Hann-windowed kernel well under the MFCC's resolution
/// (a 40 ms window, 26 mel bands) at a cost of 32 taps per output sample per unit ratio.
const HALF_TAPS: f64 = 16.0;

/// `samples` at `from_hz` resampled to `to_hz`. Equal rates return the input unchanged.
///
/// # Errors
/// A non-positive or non-finite rate.
pub fn resample(samples: &[f32], from_hz: f64, to_hz: f64) -> Result<Vec<f32>, SpeechError> {
    for (name, r) in [("source rate", from_hz), ("target rate", to_hz)] {
        if !(r.is_finite() && r > 0.0) {
            return Err(bad(name, format!("{r} Hz")));
        }
    }
    if (from_hz - to_hz).abs() < 1e-9 || samples.is_empty() {
        return Ok(samples.to_vec());
    }
    let ratio = to_hz / from_hz;
    // Cut-off as a fraction of the source rate's Nyquist frequency.
    let cutoff = ratio.min(1.0);
    let half_width = HALF_TAPS / cutoff;
    let n_out = ((samples.len() as f64) * ratio).round().max(1.0) as usize;
    let n_in = samples.len() as isize;
    let out = (0..n_out)
        .map(|i| {
            let t = i as f64 / ratio;
            let lo = (t - half_width).ceil() as isize;
            let hi = (t + half_width).floor() as isize;
            let mut acc = 0.0;
            for n in lo.max(0)..=hi.min(n_in - 1) {
                let x = t - n as f64;
                let window = 0.5 + 0.5 * (PI * x / half_width).cos();
                acc += f64::from(samples[n as usize]) * cutoff * sinc(cutoff * x) * window;
            }
            acc as f32
        })
        .collect();
    Ok(out)
}

fn sinc(x: f64) -> f64 {
    if x.abs() < 1e-12 { 1.0 } else { (PI * x).sin() / (PI * x) }
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
    fn bad_rates_are_refused() {
        assert!(resample(&[0.0], 0.0, 16_000.0).is_err());
        assert!(resample(&[0.0], 16_000.0, f64::NAN).is_err());
    }
}
