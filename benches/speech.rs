//! Speech benchmark through the release binary, as a user runs it: `lipmap speech train`
//! with default settings on 130 demo sentences must take ≤ 30 s of CPU time (user + system,
//! every thread: wall time on a shared machine measures the other users), held-out estimate
//! included; `lipmap speech animate` must run faster than real time (CPU seconds per second
//! of audio, on the 130 sentences' voices joined into one WAV).
//!
//! `cargo bench --bench speech`

#[path = "support/child.rs"]
mod child;

use child::run_lipmap;
use std::path::Path;

const SENTENCES: usize = 130;
const TRAIN_BOUND_CPU_S: f64 = 30.0;

fn s(p: &Path) -> &str {
    p.to_str().expect("UTF-8 temporary path")
}

fn main() {
    let tmp = tempfile::tempdir().expect("temporary folder");
    let corpus = tmp.path().join("corpus");
    let n = SENTENCES.to_string();
    let made =
        run_lipmap(&["demo", "--no-tui", "--no-frames", "--sentences", &n, "--out", s(&corpus)]);
    assert_eq!(made.code, 0, "demo of {SENTENCES} sentences");
    let session = corpus.join("demo.lipmap.json");

    let model = tmp.path().join("speech.json");
    let train = run_lipmap(&["speech", "train", s(&session), "--out", s(&model)]);
    assert_eq!(train.code, 0, "speech train");
    let loaded = lipmap::workflow::speech::load_speech_model(&model).expect("trained model");
    let clips = lipmap::session::Session::load(&session).expect("demo session").clips;
    let frames: usize = clips.iter().map(|c| c.tracked_summary().frames).sum();
    let hmm = &loaded.speech.hmm;
    println!(
        "speech/train (default settings, {SENTENCES} demo sentences, {frames} frames, {} × {}, held-out estimate included): {:.1} s CPU (target ≤ {TRAIN_BOUND_CPU_S:.0} s, ratio {:.2}); {:.1} s wall, peak {:.0} MB",
        hmm.n_states(),
        hmm.n_mixtures(),
        train.cpu_s,
        train.cpu_s / TRAIN_BOUND_CPU_S,
        train.wall_s,
        train.peak_mb
    );

    // The voices joined into one recording, pauses and all.
    let mut voice = Vec::new();
    for c in &clips {
        let file = &c.audio.as_ref().expect("demo clips carry audio").file;
        voice.extend(lipmap::io::wav::read_wav(file).expect("demo voice").samples);
    }
    let rate = lipmap::demo::voice::VOICE_SAMPLE_RATE;
    let wav = tmp.path().join("voices.wav");
    lipmap::io::wav::write_wav(&wav, &voice, rate).expect("joined voices");
    let audio_s = voice.len() as f64 / f64::from(rate);
    let anim = tmp.path().join("anim");
    let animate =
        run_lipmap(&["speech", "animate", s(&model), "--audio", s(&wav), "--out", s(&anim)]);
    assert_eq!(animate.code, 0, "speech animate");
    println!(
        "speech/animate ({audio_s:.0} s of audio): {:.1} s CPU, real-time factor {:.3} (target < 1); {:.1} s wall, peak {:.0} MB",
        animate.cpu_s,
        animate.cpu_s / audio_s,
        animate.wall_s,
        animate.peak_mb
    );
}
