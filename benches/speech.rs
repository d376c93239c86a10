//! Speech benchmark: AV-HMM training (N 16, M 2, t_c 3) on 120 GRID sentences must take
//! ≤ 30 s, and inversion must run faster than real time. Uses Festival's voice when
//! `festival` is installed, the demo's own voice otherwise; prints seconds and ratios.
//!
//! `cargo bench --bench speech`

#[path = "../tests/speech_corpus.rs"]
#[allow(unused)]
mod speech_corpus;

use lipmap::speech::{MouthClip, SpeechOptions, TrainingClip, compute_log_mel, train_speech_model};
use speech_corpus::{demo_voice_corpus, festival_corpus, grid_sentences, neutral_mouth};
use std::time::Instant;

const TRAIN: usize = 120;
const TEST: usize = 40;

fn main() {
    let fps = 30.0;
    let words = grid_sentences(TRAIN + TEST, 11);
    let (voice, corpus) = match festival_corpus(&words, fps) {
        Some(c) => ("festival", c),
        None => ("demo voice", demo_voice_corpus(&words, fps, 11)),
    };
    let neutral = neutral_mouth();
    let opts = SpeechOptions::new(f64::from(speech_corpus::SAMPLE_RATE), fps);
    let start = Instant::now();
    let log_mels: Vec<_> = corpus[..TRAIN]
        .iter()
        .map(|s| compute_log_mel(&s.samples, &opts.mfcc, s.mouth.len()).expect("analysis"))
        .collect();
    let clips: Vec<TrainingClip> = corpus[..TRAIN]
        .iter()
        .zip(&log_mels)
        .map(|(s, log_mel)| TrainingClip {
            log_mel,
            mouth: MouthClip { frames: &s.mouth, neutral: &neutral },
        })
        .collect();
    let frames: usize = clips.iter().map(|c| c.mouth.frames.len()).sum();
    let mut iterations = 0;
    let model = train_speech_model(&clips, &opts, &mut |i, _| iterations = i).expect("training");
    let train_s = start.elapsed().as_secs_f64();
    println!(
        "speech/train ({voice}, {TRAIN} sentences, {frames} frames, {} Baum-Welch iterations): {train_s:.2} s (target ≤ 30 s, ratio {:.2})",
        iterations,
        train_s / 30.0
    );

    let test = &corpus[TRAIN..];
    let audio_s: f64 =
        test.iter().map(|s| s.samples.len() as f64 / f64::from(speech_corpus::SAMPLE_RATE)).sum();
    let start = Instant::now();
    let inverter = model.inverter().expect("inverter");
    for s in test {
        let log_mel = compute_log_mel(&s.samples, &opts.mfcc, s.mouth.len()).expect("analysis");
        let a = model.audio_features(&log_mel).expect("features");
        std::hint::black_box(model.estimate_visual(&inverter, &a).expect("inversion"));
    }
    let invert_s = start.elapsed().as_secs_f64();
    println!(
        "speech/invert ({TEST} sentences, {audio_s:.1} s of audio, MFCC + inversion): {invert_s:.3} s, real-time factor {:.4} (target < 1)",
        invert_s / audio_s
    );
}
