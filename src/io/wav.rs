//! WAV audio: read any PCM integer (8, 16, 24, 32 bit) or 32-bit float WAV through `hound`,
//! mixed down to mono, optionally brought to another sample rate; write 16-bit mono PCM.
//!
//! [`WavStream`] reads a file in blocks and resamples as it goes, holding a block and a
//! resampling kernel's width of samples, so an hour of 48 kHz stereo (690 MB of data) costs
//! no more memory than a second of it; [`read_wav`] collects a whole (short) file.
//!
//! Rate conversion is band-limited windowed-sinc resampling ([`crate::speech::Resampler`]).
//! Only downsampling is done: audio recorded at a lower rate than a model's lacks the top of
//! the spectrum the model's MFCCs were computed over, so it is refused with a line saying so
//! rather than silently analysed with an empty upper band.

use super::error::{FormatError, Result};
use crate::speech::Resampler;
use std::io::Read;
use std::path::{Path, PathBuf};

/// Mono audio: samples in [−1, 1] and their rate.
#[derive(Clone, Debug, PartialEq)]
pub struct Audio {
    pub samples: Vec<f32>,
    pub sample_rate: u32,
}

/// What a WAV file holds, found by reading it through ([`check_wav`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WavSummary {
    pub sample_rate: u32,
    pub channels: u16,
    /// Samples per channel.
    pub frames: u64,
    /// [`WavStream::content_hash`] of the whole file.
    pub hash: u64,
}

impl WavSummary {
    /// Length in seconds.
    pub fn seconds(&self) -> f64 {
        self.frames as f64 / f64::from(self.sample_rate)
    }
}

/// Multi-channel frames read per block.
const BLOCK_FRAMES: usize = 8192;

/// The highest sample rate lipmap accepts anywhere a rate is read (a session's clip audio, a
/// speech model's analysis): above any recording format's.
pub const MAX_SAMPLE_RATE_HZ: u32 = 384_000;

/// A WAV file read block by block as mono samples, at its own rate or brought down to
/// another ([`WavStream::open_at_rate`]).
pub struct WavStream<R: Read> {
    path: PathBuf,
    reader: hound::WavReader<R>,
    spec: hound::WavSpec,
    resampler: Option<Resampler>,
    /// Mono samples read so far (at the file's rate).
    read: u64,
    finished: bool,
    hash: u64,
    interleaved: Vec<f32>,
}

/// FNV-1a over the bits of each mono sample: the same audio gives the same hash whatever
/// its file is called or where it lies.
fn fnv1a(mut hash: u64, samples: &[f32]) -> u64 {
    for s in samples {
        for b in s.to_bits().to_le_bytes() {
            hash ^= u64::from(b);
            hash = hash.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }
    hash
}

const FNV_OFFSET: u64 = 0xcbf2_9ce4_8422_2325;

impl WavStream<std::io::BufReader<std::fs::File>> {
    /// Opens `path` to be read at its own rate.
    ///
    /// # Errors
    /// An unreadable file, a malformed header, an unsupported sample format, no channels or
    /// a zero rate: one line naming the file.
    pub fn open(path: &Path) -> Result<Self> {
        let file = super::input::open_input(path, super::input::MAX_INPUT_BYTES)?;
        Self::new(std::io::BufReader::new(file), path)
    }

    /// Opens `path` to be read at `sample_rate` Hz, downsampling when it was recorded faster.
    ///
    /// # Errors
    /// As [`WavStream::open`], and a file recorded at a lower rate than `sample_rate`.
    pub fn open_at_rate(path: &Path, sample_rate: u32) -> Result<Self> {
        Self::open(path)?.at_rate(sample_rate)
    }
}

impl<R: Read> WavStream<R> {
    /// Reads a WAV header from `reader`; `path` only names the source in errors.
    ///
    /// # Errors
    /// As [`WavStream::open`].
    pub fn new(reader: R, path: &Path) -> Result<Self> {
        let reader = hound::WavReader::new(reader).map_err(|e| bad_wav(path, &e))?;
        let spec = reader.spec();
        if spec.channels == 0 || spec.sample_rate == 0 {
            return Err(FormatError::whole(
                path,
                "WAV header has no channels or a zero sample rate",
            ));
        }
        match (spec.sample_format, spec.bits_per_sample) {
            (hound::SampleFormat::Float, 32) | (hound::SampleFormat::Int, 8 | 16 | 24 | 32) => {}
            (format, bits) => {
                return Err(FormatError::at_field(
                    path,
                    "fmt",
                    format!(
                        "unsupported sample format: {bits}-bit {format:?} (use 8/16/24/32-bit PCM or 32-bit float)"
                    ),
                ));
            }
        }
        Ok(Self {
            path: path.to_path_buf(),
            reader,
            spec,
            resampler: None,
            read: 0,
            finished: false,
            hash: FNV_OFFSET,
            interleaved: Vec::new(),
        })
    }

    /// The same stream brought to `sample_rate` Hz.
    ///
    /// # Errors
    /// The file's rate is below `sample_rate`.
    pub fn at_rate(mut self, sample_rate: u32) -> Result<Self> {
        let own = self.spec.sample_rate;
        if own < sample_rate {
            return Err(FormatError::whole(
                &self.path,
                format!(
                    "recorded at {own} Hz, below the {sample_rate} Hz the model was trained on (its upper band is missing); use audio at {sample_rate} Hz or more"
                ),
            ));
        }
        self.resampler = if own == sample_rate {
            None
        } else {
            Some(
                Resampler::new(f64::from(own), f64::from(sample_rate))
                    .map_err(|e| FormatError::whole(&self.path, e.to_string()))?,
            )
        };
        Ok(self)
    }

    /// The file's own sample rate and channel count.
    pub fn spec(&self) -> (u32, u16) {
        (self.spec.sample_rate, self.spec.channels)
    }

    /// Samples per channel the header announces (a truncated file may hold fewer).
    pub fn announced_frames(&self) -> u64 {
        u64::from(self.reader.duration())
    }

    /// Mono samples read so far, at the file's own rate.
    pub fn frames_read(&self) -> u64 {
        self.read
    }

    /// [`fnv1a`] of the mono samples read so far (of the whole file once it is read through).
    pub fn content_hash(&self) -> u64 {
        self.hash
    }

    /// Appends the next block of mono samples (at the stream's rate) to `out`; `false` once
    /// the file is exhausted (its last samples are appended by that call).
    ///
    /// # Errors
    /// A malformed or truncated data chunk, or a sample that is not a finite number (named
    /// by its index).
    pub fn next_block(&mut self, out: &mut Vec<f32>) -> Result<bool> {
        if self.finished {
            return Ok(false);
        }
        let channels = usize::from(self.spec.channels);
        let want = BLOCK_FRAMES * channels;
        self.interleaved.clear();
        let path = &self.path;
        match self.spec.sample_format {
            hound::SampleFormat::Float => {
                for s in self.reader.samples::<f32>().take(want) {
                    self.interleaved.push(s.map_err(|e| bad_wav(path, &e))?);
                }
            }
            hound::SampleFormat::Int => {
                let full_scale = f64::from(1u32 << (self.spec.bits_per_sample - 1));
                for s in self.reader.samples::<i32>().take(want) {
                    let v = s.map_err(|e| bad_wav(path, &e))?;
                    self.interleaved.push((f64::from(v) / full_scale) as f32);
                }
            }
        }
        // Float WAVs can carry NaN or infinities, which every later step would spread.
        if let Some(i) = self.interleaved.iter().position(|v| !v.is_finite()) {
            return Err(FormatError::at_field(
                path,
                format!("sample {}", self.read + (i / channels) as u64),
                "is not a finite number",
            ));
        }
        let mono: Vec<f32> = self
            .interleaved
            .chunks_exact(channels)
            .map(|c| c.iter().sum::<f32>() / channels as f32)
            .collect();
        self.read += mono.len() as u64;
        self.hash = fnv1a(self.hash, &mono);
        let done = self.interleaved.len() < want;
        match &mut self.resampler {
            Some(r) => r.push(&mono, out),
            None => out.extend_from_slice(&mono),
        }
        if done {
            self.finished = true;
            if let Some(r) = self.resampler.take() {
                r.finish(out);
            }
        }
        Ok(!done)
    }
}

fn bad_wav(path: &Path, e: &hound::Error) -> FormatError {
    FormatError::whole(path, format!("not a readable WAV file: {e}"))
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
    let mut stream = WavStream::new(reader, path)?;
    let mut samples = Vec::new();
    while stream.next_block(&mut samples)? {}
    if samples.is_empty() {
        return Err(FormatError::whole(path, "WAV file has no audio samples"));
    }
    Ok(Audio { samples, sample_rate: stream.spec().0 })
}

/// Reads a WAV file through in blocks, checking every sample, without holding it.
///
/// # Errors
/// As [`read_wav`].
pub fn check_wav(path: &Path) -> Result<WavSummary> {
    let mut stream = WavStream::open(path)?;
    let mut block = Vec::new();
    while {
        block.clear();
        stream.next_block(&mut block)?
    } {}
    if stream.frames_read() == 0 {
        return Err(FormatError::whole(path, "WAV file has no audio samples"));
    }
    let (sample_rate, channels) = stream.spec();
    Ok(WavSummary {
        sample_rate,
        channels,
        frames: stream.frames_read(),
        hash: stream.content_hash(),
    })
}

/// Reads a WAV file as mono at `sample_rate` Hz, downsampling when it was recorded faster.
///
/// # Errors
/// As [`read_wav`], and a file recorded at a lower rate than `sample_rate`.
pub fn read_wav_at_rate(path: &Path, sample_rate: u32) -> Result<Vec<f32>> {
    let mut stream = WavStream::open_at_rate(path, sample_rate)?;
    let mut samples = Vec::new();
    while stream.next_block(&mut samples)? {}
    if stream.frames_read() == 0 {
        return Err(FormatError::whole(path, "WAV file has no audio samples"));
    }
    Ok(samples)
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
    fn a_stream_gives_the_whole_file_in_blocks_with_its_hash() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("long.wav");
        let x: Vec<f32> = (0..20_000).map(|i| ((i as f32) * 0.01).sin() * 0.5).collect();
        write_wav(&p, &x, 48_000).unwrap();
        let whole = read_wav(&p).unwrap();
        let mut s = WavStream::open(&p).unwrap();
        let (mut got, mut blocks) = (Vec::new(), 0);
        while s.next_block(&mut got).unwrap() {
            blocks += 1;
        }
        assert_eq!(got, whole.samples);
        assert_eq!(blocks, 20_000 / BLOCK_FRAMES);
        let summary = check_wav(&p).unwrap();
        assert_eq!((summary.sample_rate, summary.channels, summary.frames), (48_000, 1, 20_000));
        assert_eq!(summary.hash, s.content_hash());
        // Resampled as it streams: the same as resampling the whole signal.
        let at16 = read_wav_at_rate(&p, 16_000).unwrap();
        assert_eq!(at16, crate::speech::resample(&whole.samples, 48_000.0, 16_000.0).unwrap());
        // Another file with other samples hashes differently.
        let q = dir.path().join("other.wav");
        write_wav(&q, &x[1..], 48_000).unwrap();
        assert_ne!(check_wav(&q).unwrap().hash, summary.hash);
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
