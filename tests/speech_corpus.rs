//! GRID sentences as audio-visual training data for the speech tests and benchmark: audio
//! from Festival (a voice lipmap did not make) or from the demo's own formant voice, the
//! visual side from the demo's coarticulation model driven by the same phone timings.
//!
//! Festival runs one `festival -b` script per sentence, writing a WAV and its phone end times
//! (xlabel, read by `lipmap::io::htk_lab`); results are cached under the cargo target's
//! temporary folder, so only the first run pays for synthesis. Without `festival` on the PATH
//! the Festival corpus is `None` and callers print a skip notice.
#![allow(dead_code)]

use lipmap::alignment::{Alignment, Phone};
use lipmap::demo::visemes::ArticulationFields;
use lipmap::demo::{coart, demo_head, lexicon, voice};
use lipmap::math::Point3;
use rand::SeedableRng;
use rand::rngs::StdRng;
use rayon::prelude::*;
use std::path::{Path, PathBuf};
use std::process::Command;

/// One sentence: mono audio at 16 kHz, its phones, and the mouth vertices per video frame.
pub struct Sentence {
    pub text: String,
    pub samples: Vec<f32>,
    pub alignment: Alignment,
    pub mouth: Vec<Vec<Point3>>,
}

/// The rate of both voices (Festival's kal voice is 16 kHz).
pub const SAMPLE_RATE: u32 = 16_000;

/// The mouth's vertices: the demo head's mapped outer and inner lip landmarks (iBUG 48–67)
/// and the chin (7–9), which carries the jaw.
fn mouth_vertices() -> (Vec<Point3>, ArticulationFields) {
    let (head, fields) = demo_head();
    let idx: Vec<usize> = (48..68)
        .chain(7..10)
        .map(|l| head.landmarks.vertex(l).expect("demo head maps every landmark"))
        .collect();
    let rest = idx.iter().map(|&v| head.mesh.vertices[v]).collect();
    let sub = ArticulationFields {
        fields: fields.fields.iter().map(|f| idx.iter().map(|&v| f[v]).collect()).collect(),
    };
    (rest, sub)
}

/// The neutral mouth (the demo head at rest).
pub fn neutral_mouth() -> Vec<Point3> {
    mouth_vertices().0
}

/// The demo's mouth motion for `alignment` at `fps`: frames f / fps up to its end.
pub fn mouth_motion(alignment: &Alignment, fps: f64) -> Vec<Vec<Point3>> {
    let (rest, fields) = mouth_vertices();
    let n = (alignment.duration() * fps - 1e-9).ceil().max(1.0) as usize;
    coart::mouth_trajectory(alignment, fps, n).iter().map(|a| fields.apply(&rest, a)).collect()
}

/// Festival's (radio phoneset) labels that the demo's viseme table spells differently.
fn arpabet(label: &str) -> String {
    match label {
        "ax" => "AH".into(),
        "axr" => "ER".into(),
        "dx" => "D".into(),
        "el" => "L".into(),
        "em" => "M".into(),
        "en" | "nx" => "N".into(),
        "hv" => "HH".into(),
        other => other.to_ascii_uppercase(),
    }
}

/// `n` GRID sentences (seeded), as word lists.
pub fn grid_sentences(n: usize, seed: u64) -> Vec<Vec<&'static str>> {
    let mut rng = StdRng::seed_from_u64(seed);
    (0..n).map(|_| lexicon::random_sentence(&mut rng)).collect()
}

/// Whether `festival` can be run.
pub fn festival_available() -> bool {
    Command::new("festival").arg("--version").output().is_ok_and(|o| o.status.success())
}

fn cache_dir() -> PathBuf {
    PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("festival_grid")
}

/// Speaks `text` with Festival's kal voice: the WAV and the xlabel phone end times.
fn festival_say(text: &str, dir: &Path) -> Result<(PathBuf, PathBuf), String> {
    let stem = text.replace(' ', "_");
    let (wav, segs) = (dir.join(format!("{stem}.wav")), dir.join(format!("{stem}.segs")));
    if wav.exists() && segs.exists() {
        return Ok((wav, segs));
    }
    let script = dir.join(format!("{stem}.scm"));
    let body = format!(
        "(voice_kal_diphone)\n(set! utt (Utterance Text \"{text}\"))\n(utt.synth utt)\n\
         (utt.save.wave utt \"{w}.part\" 'riff)\n(utt.save.segs utt \"{s}.part\")\n",
        w = wav.display(),
        s = segs.display()
    );
    std::fs::write(&script, body).map_err(|e| e.to_string())?;
    let out =
        Command::new("festival").arg("-b").arg(&script).output().map_err(|e| e.to_string())?;
    if !out.status.success() {
        return Err(format!(
            "festival failed on {text:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        ));
    }
    // Renamed only when complete, so an interrupted run never leaves a half-written cache.
    for p in [&wav, &segs] {
        std::fs::rename(
            p.with_extension(format!("{}.part", p.extension().unwrap().to_str().unwrap())),
            p,
        )
        .map_err(|e| format!("{}: {e}", p.display()))?;
    }
    Ok((wav, segs))
}

/// The Festival WAV of each sentence with its phones (Festival's own labels), `None` when
/// it is not installed.
pub fn festival_wavs(words: &[Vec<&str>]) -> Option<Vec<(String, PathBuf, Alignment)>> {
    if !festival_available() {
        return None;
    }
    let dir = cache_dir();
    std::fs::create_dir_all(&dir).expect("creating the Festival cache");
    Some(
        words
            .iter()
            .map(|w| {
                let text = w.join(" ");
                let (wav, segs) = festival_say(&text, &dir).unwrap_or_else(|e| panic!("{e}"));
                let seg_text = std::fs::read_to_string(&segs)
                    .unwrap_or_else(|e| panic!("{}: {e}", segs.display()));
                let alignment = lipmap::io::htk_lab::parse_xlabel(&seg_text, &segs)
                    .unwrap_or_else(|e| panic!("{e}"));
                (text, wav, alignment)
            })
            .collect(),
    )
}

/// Sentences spoken by Festival, `None` (with a printed notice) when it is not installed.
pub fn festival_corpus(words: &[Vec<&str>], fps: f64) -> Option<Vec<Sentence>> {
    if !festival_available() {
        eprintln!(
            "skipping: `festival` is not installed (apt-get install festival festvox-kallpc16k)"
        );
        return None;
    }
    let dir = cache_dir();
    std::fs::create_dir_all(&dir).expect("creating the Festival cache");
    let sentences = words
        .par_iter()
        .map(|w| {
            let text = w.join(" ");
            let (wav, segs) = festival_say(&text, &dir).unwrap_or_else(|e| panic!("{e}"));
            let audio = lipmap::io::wav::read_wav(&wav).unwrap_or_else(|e| panic!("{e}"));
            assert_eq!(audio.sample_rate, SAMPLE_RATE, "{}", wav.display());
            let seg_text = std::fs::read_to_string(&segs)
                .unwrap_or_else(|e| panic!("{}: {e}", segs.display()));
            let raw = lipmap::io::htk_lab::parse_xlabel(&seg_text, &segs)
                .unwrap_or_else(|e| panic!("{e}"));
            let alignment = Alignment {
                phones: raw
                    .phones
                    .iter()
                    .map(|p| Phone { label: arpabet(&p.label), ..p.clone() })
                    .collect(),
            };
            let mouth = mouth_motion(&alignment, fps);
            Sentence { text, samples: audio.samples, alignment, mouth }
        })
        .collect();
    Some(sentences)
}

/// Sentences spoken by the demo's own voice, timed by the demo's duration model.
pub fn demo_voice_corpus(words: &[Vec<&str>], fps: f64, seed: u64) -> Vec<Sentence> {
    let mut rng = StdRng::seed_from_u64(seed);
    let timed: Vec<(String, Alignment)> = words
        .iter()
        .map(|w| {
            let mut a = lexicon::time_sentence(w, &mut rng).expect("GRID words are in the lexicon");
            // Lead-in and trail of silence, as a recording has.
            for p in &mut a.phones {
                p.start += 0.2;
                p.end += 0.2;
            }
            a.phones.insert(0, Phone { start: 0.0, end: 0.2, label: "sil".into() });
            let end = a.duration();
            a.phones.push(Phone { start: end, end: end + 0.2, label: "sil".into() });
            (w.join(" "), a)
        })
        .collect();
    timed
        .into_par_iter()
        .enumerate()
        .map(|(i, (text, alignment))| {
            let samples = voice::speak(&alignment, SAMPLE_RATE, seed + i as u64);
            let mouth = mouth_motion(&alignment, fps);
            Sentence { text, samples, alignment, mouth }
        })
        .collect()
}

#[test]
fn festival_sentences_carry_audio_and_matching_mouth_frames() {
    let Some(c) = festival_corpus(&[vec!["bin", "blue", "at", "f", "two", "now"]], 30.0) else {
        return;
    };
    let s = &c[0];
    let secs = s.samples.len() as f64 / f64::from(SAMPLE_RATE);
    assert!(
        (secs - s.alignment.duration()).abs() < 0.05,
        "{secs} s of audio, phones to {}",
        s.alignment.duration()
    );
    assert_eq!(s.mouth.len(), (s.alignment.duration() * 30.0 - 1e-9).ceil() as usize);
    let labels: Vec<&str> = s.alignment.phones.iter().map(|p| p.label.as_str()).collect();
    assert_eq!(&labels[..4], &["PAU", "B", "IH", "N"]);
}
