//! Precision and recall of the flags on the demo's injected tracker errors (swapped lip
//! points and displaced lip points, `demo::simulate_tracker`), over several sentences.

use lipmap::demo::{DemoOptions, generate};
use lipmap::io::landmark_format::read_track;
use lipmap::landmarks::flags::FlagThresholds;
use lipmap::workflow::fit_clip_cached;
use lipmap::workflow::flags::clip_flags;
use std::collections::BTreeSet;

#[test]
fn flags_find_the_injected_errors_with_few_false_flags() {
    let dir = tempfile::tempdir().unwrap();
    let opts = DemoOptions {
        out_dir: dir.path().join("demo"),
        sentences: 6,
        write_frames: false,
        side_view: false,
        write_model: false,
        ..DemoOptions::default()
    };
    let out = generate(&opts).unwrap();
    let (mut flagged, mut errors, mut hits) = (0usize, 0usize, 0usize);
    let mut missed = Vec::new();
    let mut frames = 0;
    for clip in &out.speakers[0].clips {
        let track = read_track(&clip.tracked_csv).unwrap();
        frames += track.len();
        let all = clip_flags(&track, &[], &[], &FlagThresholds::default());
        if std::env::var("FLAGS_DEBUG").is_ok() {
            eprintln!("{} errors {:?}", clip.name, clip.injected_errors);
            for f in &all {
                eprintln!("  {} {:?}", f.frame, f.reasons);
            }
        }
        let got: BTreeSet<usize> = all.into_iter().map(|f| f.frame).collect();
        let truth: BTreeSet<usize> = clip.injected_errors.iter().map(|e| e.frame).collect();
        flagged += got.len();
        errors += truth.len();
        hits += got.intersection(&truth).count();
        missed.extend(truth.difference(&got).map(|f| format!("{} frame {f}", clip.name)));
    }
    let precision = hits as f64 / flagged.max(1) as f64;
    let recall = hits as f64 / errors.max(1) as f64;
    println!(
        "demo: {errors} injected errors in {frames} frames; {flagged} flagged; \
         precision {precision:.3}, recall {recall:.3}; missed {missed:?}"
    );
    assert!(errors >= 6, "too few injected errors to judge: {errors}");
    // Measured before the step back from a glitch stopped being flagged: 12 errors in 372
    // frames, recall 0.917 (one displaced point missed), precision 0.500 (each glitch's
    // return step flagged too). The limits keep that floor.
    assert!(recall >= 0.9, "recall {recall:.3} < 0.9; missed {missed:?}");
    assert!(precision >= 0.5, "precision {precision:.3} < 0.5");
}

/// The flags that discredit a frame (`FlagReason::discredits_frame`, which `lipmap saqp`
/// bridges in its ground truth), from the tracks and their fits as `lipmap saqp` sees
/// them, on the demo with and without injected errors: the errors are found, and a clean
/// track loses no frame.
#[test]
fn discrediting_flags_find_the_errors_and_spare_clean_tracks() {
    let dir = tempfile::tempdir().unwrap();
    let count = |rate: f64, name: &str| {
        let opts = DemoOptions {
            out_dir: dir.path().join(name),
            sentences: 6,
            write_frames: false,
            side_view: false,
            gross_error_rate: rate,
            ..DemoOptions::default()
        };
        let out = generate(&opts).unwrap();
        let path = &lipmap::workflow::demo::write_demo_sessions(&out).unwrap()[0];
        let mut session = lipmap::session::Session::load(path).unwrap();
        let res = lipmap::workflow::Resources::load(&session).unwrap();
        let settings = session.fit_settings.clone();
        let (mut discredited, mut errors, mut hits, mut frames) = (0, 0, 0, 0);
        for (k, clip) in out.speakers[0].clips.iter().enumerate() {
            let fits = fit_clip_cached(&mut session, &res, k, &settings, None).unwrap().fits;
            let track = session.effective_track(k).unwrap();
            frames += track.len();
            let got: BTreeSet<usize> = clip_flags(&track, &fits, &[], &FlagThresholds::default())
                .into_iter()
                .filter(|f| f.reasons.iter().any(|r| r.discredits_frame()))
                .map(|f| f.frame)
                .collect();
            let truth: BTreeSet<usize> = clip.injected_errors.iter().map(|e| e.frame).collect();
            discredited += got.len();
            errors += truth.len();
            hits += got.intersection(&truth).count();
        }
        (discredited, errors, hits, frames)
    };
    let (discredited, errors, hits, frames) = count(0.03, "errors");
    println!(
        "with errors: {errors} injected in {frames} frames, {discredited} discredited, {hits} of them errors"
    );
    let (clean_discredited, _, _, clean_frames) = count(0.0, "clean");
    println!("clean: {clean_discredited} of {clean_frames} frames discredited");
    assert!(errors >= 6, "too few injected errors to judge: {errors}");
    assert!(hits as f64 >= 0.75 * errors as f64, "{hits} of {errors} errors discredited");
    assert!(
        hits as f64 >= 0.75 * discredited as f64,
        "{hits} of {discredited} discredited are errors"
    );
    assert_eq!(clean_discredited, 0, "a clean track had frames discredited");
}
