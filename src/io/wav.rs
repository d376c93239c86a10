//! WAV audio: read any PCM integer (8, 16, 24, 32 bit) or 32-bit float WAV through `hound`,
//! mixed down to mono, optionally brought to another sample rate; write 16-bit mono PCM.
//!
//! Rate conversion is band-limited windowed-sinc resampling ([`crate::speech::resample`]).
//! Only downsampling is done: audio recorded at a lower rate than a model's lacks the top of
//! the spectrum the model's MFCCs were computed over, so it is refused with a line saying so
//! rather than silently analysed with an empty upper band.

use super::error::{FormatError, Result};
use std::io::Read;
use std::path::Path;

/// Mono audio: samples in [−1, 1] and their rate.
#[derive(Clone, Debug, PartialEq)]
pub struct Audio {
    pub samples: Vec<f32>,
    pub sample_rate: u32,
}

/// Reads a WAV file, mixing all channels to mono (their mean).
///
/// # Errors
/// An unreadable file, a malformed or truncated header or data chunk, an unsupported sample
/// format, or no samples: one line naming the file.
pub fn read_wav(path: &Path) -> Result<Audio> {
    let file = super::input::open_input(path, super::input::MAX_INPUT_BYTES)?;
    parse_wav(std::io::BufReader::new(file), path)
}

/// As [`read_wav`] from any reader; `path` only names the source in errors.
///
/// # Errors
/// As [`read_wav`].
pub fn parse_wav(reader: impl Read, path: &Path) -> Result<Audio> {
    let bad = |e: hound::Error| FormatError::whole(path, format!("not a readable WAV file: {e}"));
    let mut wav = hound::WavReader::new(reader).map_err(bad)?;
    let spec = wav.spec();
    let channels = usize::from(spec.channels);
    if channels == 0 || spec.sample_rate == 0 {
        return Err(FormatError::whole(path, "WAV header has no channels or a zero sample rate"));
    }
    let interleaved: Vec<f32> = match (spec.sample_format, spec.bits_per_sample) {
        (hound::SampleFormat::Float, 32) => {
            wav.samples::<f32>().collect::<std::result::Result<_, _>>().map_err(bad)?
        }
        (hound::SampleFormat::Int, bits @ (8 | 16 | 24 | 32)) => {
            let full_scale = f64::from(1u32 << (bits - 1));
            wav.samples::<i32>()
                .map(|s| s.map(|v| (f64::from(v) / full_scale) as f32))
                .collect::<std::result::Result<_, _>>()
                .map_err(bad)?
        }
        (format, bits) => {
            return Err(FormatError::at_field(
                path,
                "fmt",
                format!(
                    "unsupported sample format: {bits}-bit {format:?} (use 8/16/24/32-bit PCM or 32-bit float)"
                ),
            ));
        }
    };
    if interleaved.len() < channels {
        return Err(FormatError::whole(path, "WAV file has no audio samples"));
    }
    // Float WAVs can carry NaN or infinities, which every later step would spread.
    if let Some(i) = interleaved.iter().position(|v| !v.is_finite()) {
        return Err(FormatError::at_field(
            path,
            format!("sample {}", i / channels),
            "is not a finite number",
        ));
    }
    let samples = interleaved
        .chunks_exact(channels)
        .map(|c| c.iter().sum::<f32>() / channels as f32)
        .collect();
    Ok(Audio { samples, sample_rate: spec.sample_rate })
}

/// Reads a WAV file as mono at `sample_rate` Hz, downsampling when it was recorded faster.
///
/// # Errors
/// As [`read_wav`], and a file recorded at a lower rate than `sample_rate`.
pub fn read_wav_at_rate(path: &Path, sample_rate: u32) -> Result<Vec<f32>> {
    let audio = read_wav(path)?;
    if audio.sample_rate == sample_rate {
        return Ok(audio.samples);
    }
    if audio.sample_rate < sample_rate {
        return Err(FormatError::whole(
            path,
            format!(
                "recorded at {} Hz, below the {} Hz the model was trained on (its upper band is missing); use audio at {} Hz or more",
                audio.sample_rate, sample_rate, sample_rate
            ),
        ));
    }
    crate::speech::resample(&audio.samples, f64::from(audio.sample_rate), f64::from(sample_rate))
        .map_err(|e| FormatError::whole(path, e.to_string()))
}

/// Writes mono samples (clipped to [−1, 1]) as 16-bit PCM.
///
/// # Errors
/// An I/O failure, naming the file.
pub fn write_wav(path: &Path, samples: &[f32], sample_rate: u32) -> Result<()> {
    let spec = hound::WavSpec {
        channels: 1,
        sample_rate,
        bits_per_sample: 16,
        sample_format: hound::SampleFormat::Int,
    };
    let fail = |e: hound::Error| FormatError::whole(path, format!("writing WAV: {e}"));
    let mut file = super::atomic::AtomicFile::create(path).map_err(|e| FormatError::io(path, e))?;
    let mut w = hound::WavWriter::new(&mut file, spec).map_err(fail)?;
    for s in samples {
        w.write_sample((s.clamp(-1.0, 1.0) * 32767.0).round() as i16).map_err(fail)?;
    }
    w.finalize().map_err(fail)?;
    file.commit().map_err(|e| FormatError::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::io::Cursor;

    fn encode(spec: hound::WavSpec, frames: &[Vec<i32>]) -> Vec<u8> {
        let mut buf = Cursor::new(Vec::new());
        let mut w = hound::WavWriter::new(&mut buf, spec).unwrap();
        for f in frames {
            for &s in f {
                w.write_sample(s).unwrap();
            }
        }
        w.finalize().unwrap();
        buf.into_inner()
    }

    fn spec(channels: u16, bits: u16) -> hound::WavSpec {
        hound::WavSpec {
            channels,
            sample_rate: 8000,
            bits_per_sample: bits,
            sample_format: hound::SampleFormat::Int,
        }
    }

    #[test]
    fn integer_widths_scale_to_unit_range_and_channels_mix_to_mono() {
        for bits in [8u16, 16, 24, 32] {
            let half = 1i32 << (bits - 2);
            let bytes = encode(spec(2, bits), &[vec![half, -half], vec![half, half]]);
            let a = parse_wav(Cursor::new(bytes), Path::new("x.wav")).unwrap();
            assert_eq!(a.samples.len(), 2);
            assert!(a.samples[0].abs() < 1e-6, "{bits} bit: {:?}", a.samples);
            assert!((a.samples[1] - 0.5).abs() < 1e-6, "{bits} bit: {:?}", a.samples);
        }
    }

    #[test]
    fn float_wavs_read_and_written_wavs_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.wav");
        let x: Vec<f32> = (0..100).map(|i| (i as f32 * 0.1).sin() * 0.8).collect();
        write_wav(&p, &x, 16_000).unwrap();
        let a = read_wav(&p).unwrap();
        assert_eq!(a.sample_rate, 16_000);
        assert!(a.samples.iter().zip(&x).all(|(a, b)| (a - b).abs() < 1e-4));
        let fspec = hound::WavSpec {
            channels: 1,
            sample_rate: 44_100,
            bits_per_sample: 32,
            sample_format: hound::SampleFormat::Float,
        };
        let mut buf = Cursor::new(Vec::new());
        let mut w = hound::WavWriter::new(&mut buf, fspec).unwrap();
        w.write_sample(0.25f32).unwrap();
        w.finalize().unwrap();
        assert_eq!(parse_wav(Cursor::new(buf.into_inner()), &p).unwrap().samples, vec![0.25]);

        let mut buf = Cursor::new(Vec::new());
        let mut w = hound::WavWriter::new(&mut buf, fspec).unwrap();
        for v in [0.25f32, 0.5, f32::NAN] {
            w.write_sample(v).unwrap();
        }
        w.finalize().unwrap();
        let e = parse_wav(Cursor::new(buf.into_inner()), &p).unwrap_err().to_string();
        assert!(e.contains("a.wav") && e.contains("sample 2") && !e.contains('\n'), "{e}");
    }

    #[test]
    fn lower_rates_are_refused_and_higher_ones_resampled() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("low.wav");
        write_wav(&p, &[0.0; 800], 8000).unwrap();
        let e = read_wav_at_rate(&p, 16_000).unwrap_err().to_string();
        assert!(
            e.starts_with(&p.display().to_string()) && e.contains("8000 Hz") && !e.contains('\n'),
            "{e}"
        );
        let q = dir.path().join("high.wav");
        write_wav(&q, &[0.1; 3200], 32_000).unwrap();
        assert_eq!(read_wav_at_rate(&q, 16_000).unwrap().len(), 1600);
    }

    #[test]
    fn empty_and_truncated_files_give_one_line_errors_never_panics() {
        let good = encode(spec(1, 16), &(0..64).map(|i| vec![i * 100]).collect::<Vec<_>>());
        let p = Path::new("speech/clip.wav");
        // Every truncation of a valid file: an error naming the file, or (cut inside the
        // data) the samples that are whole.
        for len in 0..good.len() {
            match parse_wav(Cursor::new(&good[..len]), p) {
                Ok(a) => assert!(len > 44 && !a.samples.is_empty(), "{len} bytes gave {a:?}"),
                Err(e) => {
                    let s = e.to_string();
                    assert!(s.starts_with("speech/clip.wav") && !s.contains('\n'), "{len}: {s}");
                }
            }
        }
        // Header bytes overwritten with pseudo-random values (a fixed LCG stream).
        let mut state = 0x2545_f491_u64;
        for _ in 0..2000 {
            let mut bad = good.clone();
            for _ in 0..3 {
                state = state
                    .wrapping_mul(6_364_136_223_846_793_005)
                    .wrapping_add(1_442_695_040_888_963_407);
                let i = (state >> 33) as usize % 44;
                bad[i] = (state >> 17) as u8;
            }
            let _ = parse_wav(Cursor::new(&bad), p);
        }
        let empty = encode(spec(1, 16), &[]);
        assert!(
            parse_wav(Cursor::new(empty), p).unwrap_err().to_string().contains("no audio samples")
        );
    }
}
