//! SAQP at the demo's size: generate 200 demo sentences (no rendering), fit every clip, and
//! run the whole cross-validation (region PCA, 56 sub-corpora × 3 synthesizers, the λ/order
//! and ω_m searches, GP fits, held-out prediction); the target is ≤ 5 s for the
//! cross-validation. Prints times and the ratio to the target.
//! Run: `cargo bench --bench saqp`.

use lipmap::demo::corpus::{CorpusOptions, generate_corpus};
use lipmap::fit::FitSettings;
use lipmap::saqp::{CvOptions, cross_validate};
use std::collections::HashMap;
use std::time::Instant;

const TARGET_S: f64 = 5.0;

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
}
