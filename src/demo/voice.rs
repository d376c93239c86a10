//! The demo speaker's voice: a source–filter formant synthesiser (after Klatt 1980, "Software
//! for a cascade/parallel formant synthesizer", JASA 67(3)) driven by the same phone timings
//! as the demo's lips, so the speech path (`crate::speech`) has audio whose spectrum carries
//! each phone's identity.
//!
//! The audio is made from the phones alone, never from the mouth trajectory: vowels and
//! sonorants by their first three formants (Peterson & Barney 1952 and Hillenbrand et al. 1995
//! adult male averages, rounded), diphthongs gliding between two vowel targets, fricatives by
//! noise shaped at their place's spectral peak (/s z/ high, /ʃ ʒ/ mid, /f v θ ð/ weak and
//! broad), stops by a closure then a burst at their place's locus, nasals by a low murmur.
//! Formant targets pass through a first-order smoother (15 ms), giving the formant
//! transitions between phones that make consonants audible in their neighbouring vowels.
//!
//! Start with [`speak`].

use crate::alignment::{Alignment, PhoneInventory};
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};
use std::f64::consts::PI;

/// The rate [`speak`] is usually called with (the Festival voices' rate too).
pub const VOICE_SAMPLE_RATE: u32 = 16_000;

/// How a phone is produced.
#[derive(Clone, Copy, Debug, PartialEq)]
enum Manner {
    Silence,
    /// Vowels, glides, liquids: voicing through the formants; `to` is a diphthong's end.
    Sonorant {
        to: Option<[f64; 3]>,
    },
    Nasal,
    /// Frication noise with a spectral peak at `centre` Hz, relative level `level`.
    Fricative {
        centre: f64,
        level: f64,
    },
    /// Closure then a burst peaking at `burst` Hz.
    Stop {
        burst: f64,
    },
    /// Aspiration: noise through the formants of what surrounds it.
    Aspirate,
}

/// One phone's recipe: formant targets (F1–F3, Hz), whether the folds vibrate, the manner.
#[derive(Clone, Copy, Debug, PartialEq)]
struct PhoneSound {
    formants: [f64; 3],
    voiced: bool,
    manner: Manner,
}

const NEUTRAL: [f64; 3] = [500.0, 1500.0, 2500.0];

fn vowel(f: [f64; 3]) -> PhoneSound {
    PhoneSound { formants: f, voiced: true, manner: Manner::Sonorant { to: None } }
}

fn diphthong(from: [f64; 3], to: [f64; 3]) -> PhoneSound {
    PhoneSound { formants: from, voiced: true, manner: Manner::Sonorant { to: Some(to) } }
}

fn sound(phone: &str) -> PhoneSound {
    use Manner::{Aspirate, Fricative, Nasal, Silence, Stop};
    const IY: [f64; 3] = [270.0, 2290.0, 3010.0];
    const AA: [f64; 3] = [730.0, 1090.0, 2440.0];
    const UW: [f64; 3] = [300.0, 870.0, 2240.0];
    let fric = |f: [f64; 3], voiced, centre, level| PhoneSound {
        formants: f,
        voiced,
        manner: Fricative { centre, level },
    };
    let stop =
        |f: [f64; 3], voiced, burst| PhoneSound { formants: f, voiced, manner: Stop { burst } };
    let nasal = |f: [f64; 3]| PhoneSound { formants: f, voiced: true, manner: Nasal };
    match PhoneInventory::default().key_of(phone).as_str() {
        "IY" => vowel(IY),
        "IH" => vowel([390.0, 1990.0, 2550.0]),
        "EH" => vowel([530.0, 1840.0, 2480.0]),
        "AE" => vowel([660.0, 1720.0, 2410.0]),
        "AA" => vowel(AA),
        "AO" => vowel([570.0, 840.0, 2410.0]),
        "UH" => vowel([440.0, 1020.0, 2240.0]),
        "UW" => vowel(UW),
        "AH" | "AX" => vowel([640.0, 1190.0, 2390.0]),
        "ER" => vowel([490.0, 1350.0, 1690.0]),
        "EY" => diphthong([480.0, 1900.0, 2500.0], IY),
        "AY" => diphthong(AA, [300.0, 2100.0, 2800.0]),
        "AW" => diphthong(AA, UW),
        "OW" => diphthong([570.0, 900.0, 2400.0], UW),
        "OY" => diphthong([570.0, 840.0, 2410.0], IY),
        "W" => vowel([300.0, 610.0, 2200.0]),
        "Y" => vowel([260.0, 2070.0, 3020.0]),
        "R" => vowel([310.0, 1060.0, 1380.0]),
        "L" => vowel([360.0, 1300.0, 2700.0]),
        "M" => nasal([250.0, 1100.0, 2200.0]),
        "N" => nasal([250.0, 1700.0, 2600.0]),
        "NG" => nasal([250.0, 2300.0, 2750.0]),
        "B" => stop([200.0, 800.0, 2200.0], true, 900.0),
        "P" => stop([200.0, 800.0, 2200.0], false, 900.0),
        "D" => stop([200.0, 1700.0, 2600.0], true, 4000.0),
        "T" => stop([200.0, 1700.0, 2600.0], false, 4000.0),
        "G" => stop([200.0, 2300.0, 2700.0], true, 2200.0),
        "K" => stop([200.0, 2300.0, 2700.0], false, 2200.0),
        "CH" => fric([300.0, 1900.0, 2600.0], false, 2900.0, 1.0),
        "JH" => fric([300.0, 1900.0, 2600.0], true, 2900.0, 0.7),
        "S" => fric([400.0, 1700.0, 2600.0], false, 5500.0, 1.0),
        "Z" => fric([300.0, 1700.0, 2600.0], true, 5500.0, 0.6),
        "SH" => fric([400.0, 1900.0, 2600.0], false, 2800.0, 1.0),
        "ZH" => fric([300.0, 1900.0, 2600.0], true, 2800.0, 0.6),
        "F" => fric([400.0, 1100.0, 2100.0], false, 6500.0, 0.35),
        "V" => fric([300.0, 1100.0, 2100.0], true, 6500.0, 0.25),
        "TH" => fric([400.0, 1400.0, 2200.0], false, 7000.0, 0.3),
        "DH" => fric([300.0, 1400.0, 2200.0], true, 7000.0, 0.2),
        "HH" => PhoneSound { formants: NEUTRAL, voiced: false, manner: Aspirate },
        _ => PhoneSound { formants: NEUTRAL, voiced: false, manner: Silence },
    }
}

/// Klatt's digital resonator: `y[n] = A x[n] + B y[n−1] + C y[n−2]`, unity gain at DC.
#[derive(Clone, Copy, Debug, Default)]
struct Resonator {
    y1: f64,
    y2: f64,
}

impl Resonator {
    fn step(&mut self, x: f64, freq: f64, bw: f64, dt: f64) -> f64 {
        let c = -(-2.0 * PI * bw * dt).exp();
        let b = 2.0 * (-PI * bw * dt).exp() * (2.0 * PI * freq * dt).cos();
        let a = 1.0 - b - c;
        let y = a * x + b * self.y1 + c * self.y2;
        self.y2 = self.y1;
        self.y1 = y;
        y
    }
}

/// Formant bandwidths (Hz), Klatt's defaults for F1–F3.
const BANDWIDTHS: [f64; 3] = [60.0, 90.0, 150.0];
/// Time constant of the formant-target smoother (s): about the duration of a formant
/// transition out of a stop.
const FORMANT_SMOOTHING_S: f64 = 0.015;
/// Time constant of the source amplitudes (s): fast enough for a stop's closure, slow enough
/// not to click.
const AMPLITUDE_SMOOTHING_S: f64 = 0.004;

/// Target levels at one instant: voicing, aspiration, frication (with its peak), formants.
#[derive(Clone, Copy, Debug)]
struct Targets {
    formants: [f64; 3],
    voicing: f64,
    aspiration: f64,
    frication: f64,
    fric_centre: f64,
}

fn targets_at(s: &PhoneSound, u: f64) -> Targets {
    let base = Targets {
        formants: s.formants,
        voicing: 0.0,
        aspiration: 0.0,
        frication: 0.0,
        fric_centre: 4000.0,
    };
    let voicing = if s.voiced { 1.0 } else { 0.0 };
    match s.manner {
        Manner::Silence => base,
        Manner::Sonorant { to } => {
            let f = match to {
                Some(end) => std::array::from_fn(|k| s.formants[k] + (end[k] - s.formants[k]) * u),
                None => s.formants,
            };
            Targets { formants: f, voicing, ..base }
        }
        Manner::Nasal => Targets { voicing: 0.3, ..base },
        Manner::Fricative { centre, level } => {
            Targets { voicing: 0.4 * voicing, frication: level, fric_centre: centre, ..base }
        }
        Manner::Aspirate => Targets { aspiration: 0.5, ..base },
        // Closure for the first 60 % (voiced stops murmur through it), then the burst and,
        // for voiceless stops, aspiration into the next phone.
        Manner::Stop { burst } if u < 0.6 => {
            Targets { voicing: 0.15 * voicing, fric_centre: burst, ..base }
        }
        Manner::Stop { burst } => Targets {
            voicing: 0.5 * voicing,
            frication: 0.8 * (1.0 - (u - 0.6) / 0.4),
            aspiration: if s.voiced { 0.0 } else { 0.4 },
            fric_centre: burst,
            ..base
        },
    }
}

/// Speech for `alignment` at `sample_rate` Hz: one sample per 1/rate s up to the last phone's
/// end, peak-normalised to 0.7. `seed` fixes the noise and the pitch jitter.
pub fn speak(alignment: &Alignment, sample_rate: u32, seed: u64) -> Vec<f32> {
    let rate = f64::from(sample_rate.max(1));
    let dt = 1.0 / rate;
    let n = (alignment.duration() * rate).ceil() as usize;
    let mut rng = StdRng::seed_from_u64(seed);
    let sounds: Vec<PhoneSound> = alignment.phones.iter().map(|p| sound(&p.label)).collect();
    let duration = alignment.duration().max(1e-3);
    let k_formant = 1.0 - (-dt / FORMANT_SMOOTHING_S).exp();
    let k_amp = 1.0 - (-dt / AMPLITUDE_SMOOTHING_S).exp();
    let mut cur = Targets {
        formants: NEUTRAL,
        voicing: 0.0,
        aspiration: 0.0,
        frication: 0.0,
        fric_centre: 4000.0,
    };
    let mut cascade = [Resonator::default(); 3];
    let mut fric_res = Resonator::default();
    let (mut tilt1, mut tilt2, mut prev_glottal) = (0.0, 0.0, 0.0);
    let mut phase = 0.0;
    let mut period_jitter = 0.0;
    let mut out = Vec::with_capacity(n);
    let mut pi = 0;
    for i in 0..n {
        let t = i as f64 * dt;
        while pi + 1 < alignment.phones.len() && t >= alignment.phones[pi].end {
            pi += 1;
        }
        let target = match (alignment.phones.get(pi), sounds.get(pi)) {
            (Some(p), Some(s)) => {
                targets_at(s, ((t - p.start) / (p.end - p.start).max(1e-6)).clamp(0.0, 1.0))
            }
            _ => cur,
        };
        for k in 0..3 {
            cur.formants[k] += k_formant * (target.formants[k] - cur.formants[k]);
        }
        cur.voicing += k_amp * (target.voicing - cur.voicing);
        cur.aspiration += k_amp * (target.aspiration - cur.aspiration);
        cur.frication += k_amp * (target.frication - cur.frication);
        cur.fric_centre = target.fric_centre;
        // Glottal source: an impulse per period (F0 falling 130 → 95 Hz over the sentence,
        // ±1 % jitter), low-passed twice for the glottal pulse's spectral tilt, then
        // differentiated for lip radiation: a −6 dB/octave voiced spectrum.
        let f0 = (130.0 - 35.0 * t / duration) * (1.0 + period_jitter);
        phase += f0 * dt;
        let impulse = if phase >= 1.0 {
            phase -= 1.0;
            period_jitter = rng.random_range(-0.01..0.01);
            1.0
        } else {
            0.0
        };
        let k_tilt = 1.0 - (-2.0 * PI * 300.0 * dt).exp();
        tilt1 += k_tilt * (impulse - tilt1);
        tilt2 += k_tilt * (tilt1 - tilt2);
        let glottal = tilt2 - prev_glottal;
        prev_glottal = tilt2;
        let noise: f64 = rng.random_range(-1.0..1.0);
        let mut x = 40.0 * cur.voicing * glottal + 0.08 * cur.aspiration * noise;
        for (k, r) in cascade.iter_mut().enumerate() {
            x = r.step(x, cur.formants[k], BANDWIDTHS[k], dt);
        }
        let centre = cur.fric_centre.min(0.45 * rate);
        let fric = fric_res.step(noise, centre, 0.3 * centre, dt) * 0.12 * cur.frication;
        out.push(x + fric);
    }
    let peak = out.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let gain = if peak > 0.0 { 0.7 / peak } else { 0.0 };
    out.into_iter().map(|v| (v * gain) as f32).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::alignment::Phone;
    use rustfft::FftPlanner;
    use rustfft::num_complex::Complex;

    fn one(label: &str) -> Alignment {
        Alignment {
            phones: vec![
                Phone { start: 0.0, end: 0.1, label: "sil".into() },
                Phone { start: 0.1, end: 0.5, label: label.into() },
                Phone { start: 0.5, end: 0.6, label: "sil".into() },
            ],
        }
    }

    /// Magnitude spectrum of 2048 samples from the middle of the phone, in 7.8 Hz bins.
    fn spectrum(x: &[f32]) -> Vec<f64> {
        let n = 2048;
        let s = 4800 - n / 2;
        let mut buf: Vec<Complex<f64>> = (0..n)
            .map(|i| {
                let w = 0.5 - 0.5 * (2.0 * PI * i as f64 / n as f64).cos();
                Complex::new(f64::from(x[s + i]) * w, 0.0)
            })
            .collect();
        FftPlanner::new().plan_fft_forward(n).process(&mut buf);
        buf[..n / 2].iter().map(|c| c.norm()).collect()
    }

    fn band_energy(spec: &[f64], lo: f64, hi: f64) -> f64 {
        let bin = 16_000.0 / 2048.0;
        spec.iter()
            .enumerate()
            .filter(|(i, _)| (lo..hi).contains(&(*i as f64 * bin)))
            .map(|(_, v)| v * v)
            .sum()
    }

    #[test]
    fn vowels_have_their_second_formant_where_it_belongs() {
        // /i/ has F2 near 2290 Hz, /u/ near 870 Hz: the band around each is the stronger one.
        let iy = spectrum(&speak(&one("IY1"), VOICE_SAMPLE_RATE, 1));
        let uw = spectrum(&speak(&one("UW1"), VOICE_SAMPLE_RATE, 1));
        let ratio = |s: &[f64]| band_energy(s, 2000.0, 2600.0) / band_energy(s, 700.0, 1100.0);
        assert!(ratio(&iy) > 4.0 * ratio(&uw), "IY {} UW {}", ratio(&iy), ratio(&uw));
    }

    #[test]
    fn s_is_hissing_high_and_sh_lower() {
        let s = spectrum(&speak(&one("S"), VOICE_SAMPLE_RATE, 2));
        let sh = spectrum(&speak(&one("SH"), VOICE_SAMPLE_RATE, 2));
        let hi = |x: &[f64]| band_energy(x, 4500.0, 7000.0) / band_energy(x, 2000.0, 3500.0);
        assert!(hi(&s) > 3.0 * hi(&sh), "S {} SH {}", hi(&s), hi(&sh));
        // And a fricative is mostly above 2 kHz, a vowel mostly below.
        let aa = spectrum(&speak(&one("AA1"), VOICE_SAMPLE_RATE, 2));
        assert!(band_energy(&s, 2000.0, 8000.0) > band_energy(&s, 0.0, 2000.0));
        assert!(band_energy(&aa, 0.0, 2000.0) > 5.0 * band_energy(&aa, 2000.0, 8000.0));
    }

    #[test]
    fn silence_is_silent_and_length_follows_the_alignment() {
        let x = speak(&one("AA1"), VOICE_SAMPLE_RATE, 3);
        assert_eq!(x.len(), 9600);
        assert!(x.iter().all(|v| v.is_finite() && v.abs() <= 0.7 + 1e-6));
        let lead: f32 = x[..1200].iter().map(|v| v.abs()).fold(0.0, f32::max);
        assert!(lead < 0.01, "{lead}");
        assert!(speak(&Alignment::default(), VOICE_SAMPLE_RATE, 3).is_empty());
    }
}
