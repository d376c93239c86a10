//! SAQP at the demo's size: generate 200 demo sentences (no rendering), fit every clip, and
//! run the whole cross-validation (region PCA, 56 sub-corpora × 3 synthesizers, the λ/order
//! and ω_m searches, GP and line fits, held-out prediction); the target is ≤ 10 s for
//! `lipmap saqp cv` on 200 sentences. Then the path `lipmap saqp cv SESSION` runs: a 200-sentence demo
//! session (no frames rendered) gathered, flagged, fitted on the first run and read from
//! the fit cache after, and cross-validated. Prints times and the ratios to the target.
//! Run: `cargo bench --bench saqp`.

use lipmap::demo::DemoOptions;
use lipmap::demo::corpus::{CorpusOptions, generate_corpus};
use lipmap::fit::FitSettings;
use lipmap::saqp::{CvOptions, cross_validate};
use lipmap::workflow::saqp::{SaqpSettings, cross_validate_sessions};
use std::collections::HashMap;
use std::time::Instant;

const TARGET_S: f64 = 10.0;

fn main() {
    let t = Instant::now();
    let demo = generate_corpus(&CorpusOptions { sentences: 200, ..CorpusOptions::default() })
        .expect("demo corpus");
    let frames: usize = demo.sentences.iter().map(|s| s.truth.len()).sum();
    println!("generate 200 sentences ({frames} frames): {:.2} s", t.elapsed().as_secs_f64());
    let t = Instant::now();
    let settings = FitSettings::default();
    let fits = demo.fit_sentences(&settings);
    println!("fit every clip: {:.2} s", t.elapsed().as_secs_f64());
    let corpus = demo.to_saqp(&fits);
    let mut best = f64::INFINITY;
    for _ in 0..3 {
        let t = Instant::now();
        let report = cross_validate(&corpus, &HashMap::new(), &CvOptions::default())
            .expect("cross-validation");
        let s = t.elapsed().as_secs_f64();
        best = best.min(s);
        std::hint::black_box(report);
    }
    println!(
        "saqp cross-validation, 200 sentences: {best:.2} s (best of 3) = {:.2} × the {TARGET_S} s target",
        best / TARGET_S
    );
    session_path();
}

/// `lipmap saqp cv` on a demo session, as the command runs it.
fn session_path() {
    let dir = tempfile::tempdir().expect("temporary folder");
    let options = DemoOptions {
        sentences: 200,
        out_dir: dir.path().to_path_buf(),
        write_frames: false,
        side_view: false,
        ..DemoOptions::default()
    };
    let generated = lipmap::demo::generate(&options).expect("demo");
    let sessions = lipmap::workflow::demo::write_demo_sessions(&generated).expect("session");
    let session = vec![sessions[0].display().to_string()];
    let settings = SaqpSettings {
        corpus: lipmap::workflow::saqp::CorpusOptions::default(),
        cv: CvOptions::default(),
        synth_files: None,
    };
    let mut times = Vec::new();
    for _ in 0..3 {
        let t = Instant::now();
        let cv = cross_validate_sessions(&session, &settings, &|_| {}).expect("saqp cv");
        times.push(t.elapsed().as_secs_f64());
        std::hint::black_box(cv);
    }
    let cached = times[1..].iter().copied().fold(f64::INFINITY, f64::min);
    println!(
        "lipmap saqp cv SESSION, 200 sentences: {:.2} s with fitting, {cached:.2} s from the fit cache (best of 2) = {:.2} × the {TARGET_S} s target",
        times[0],
        cached / TARGET_S
    );
}
