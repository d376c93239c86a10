//! The demo speaker as lipmap's end-to-end test: generate it, correct the injected tracker
//! errors as a user would, fit, and check the fitted head's W, H, P against the known truth;
//! check the flags catch the injected errors and the phoneme table covers every phone.

use lipmap::demo::{DemoOptions, generate};
use lipmap::fit::FrameFit;
use lipmap::io::landmark_format::read_track;
use lipmap::landmarks::PointSource;
use lipmap::landmarks::flags::{FlagThresholds, flag_frames};
use lipmap::measure::Measure;
use lipmap::measure::MeshMeasureOptions;
use lipmap::session::Session;
use lipmap::workflow::demo::write_demo_sessions;
use lipmap::workflow::{self, Normalisation, Resources};
use std::collections::BTreeSet;

fn truth_column(path: &std::path::Path, name: &str) -> Vec<f64> {
    let mut r = csv::Reader::from_path(path).unwrap();
    let idx = r.headers().unwrap().iter().position(|h| h == name).unwrap();
    r.records().map(|rec| rec.unwrap()[idx].parse().unwrap()).collect()
}

#[test]
fn demo_fit_recovers_truth_flags_errors_and_covers_phones() {
    let dir = tempfile::tempdir().unwrap();
    let opts = DemoOptions { out_dir: dir.path().join("demo"), ..DemoOptions::default() };
    let out = generate(&opts).unwrap();
    let sessions = write_demo_sessions(&out).unwrap();
    let mut session = Session::load(&sessions[0]).unwrap();
    let speaker = &out.speakers[0];

    // The flags must include every frame with an injected gross error (asserted last).
    let mut unflagged = Vec::new();
    for (c, clip) in speaker.clips.iter().enumerate() {
        let track = session.effective_track(c).unwrap();
        let flagged: BTreeSet<usize> =
            flag_frames::<FrameFit>(&track, None, &[], &FlagThresholds::default())
                .into_iter()
                .map(|f| f.frame)
                .collect();
        for e in &clip.injected_errors {
            if !flagged.contains(&e.frame) {
                unflagged.push(format!("{} frame {}", clip.name, e.frame));
            }
        }
    }

    // Correct the injected errors from the true landmarks, as a user would by hand.
    for (c, clip) in speaker.clips.iter().enumerate() {
        let truth = read_track(&clip.true_csv).unwrap();
        for e in &clip.injected_errors {
            let frame = truth.get(e.frame).unwrap();
            for p in std::iter::once(e.point).chain(e.other) {
                let mut pt = frame.points[p];
                pt.source = PointSource::Corrected;
                session.set_correction(c, e.frame, p, pt).unwrap();
            }
        }
    }

    let res = Resources::load(&session).unwrap();
    let settings = session.fit_settings.clone();
    let mut utterances = Vec::new();
    for (c, clip) in speaker.clips.iter().enumerate() {
        let fits = workflow::fit_clip_cached(&mut session, &res, c, &settings, None).unwrap();
        assert_eq!(fits.failed(), 0, "{}: failed fits", clip.name);
        let (u, warnings) = workflow::utterance_of_clip(
            &session,
            &res,
            c,
            &fits.fits,
            &MeshMeasureOptions::default(),
            Default::default(),
        )
        .unwrap();
        assert!(warnings.is_empty(), "{warnings:?}");
        // With a side view the head's P is its whole upper lip's foremost point, as the
        // profile shows it: truth `p_lip` (see docs/protrusion.md).
        for (m, col) in [(Measure::W, "w"), (Measure::H, "h"), (Measure::P, "p_lip")] {
            let truth = truth_column(&clip.truth_csv, col);
            let head = u.head.series(m);
            assert_eq!(head.len(), truth.len(), "{}: frame count", clip.name);
            let se: Vec<f64> = head
                .iter()
                .zip(&truth)
                .map(|(h, t)| (h.expect("every frame measured") - t).powi(2))
                .collect();
            let rmse = (se.iter().sum::<f64>() / se.len() as f64).sqrt();
            eprintln!("{} {m}: RMSE vs truth {rmse:.4}", clip.name);
            assert!(rmse <= 0.03, "{} {m}: RMSE {rmse:.4} > 0.03", clip.name);
        }
        utterances.push(u);
    }

    // The per-phoneme table has a row for every phone present.
    let report = workflow::evaluate(&utterances, &[], Normalisation::None, 5);
    let rows: BTreeSet<String> =
        report.phonemes.formatted_rows().into_iter().map(|r| r[0].clone()).collect();
    for u in &utterances {
        for p in &u.alignment.phones {
            let label = lipmap::alignment::PhoneInventory::default().key_of(&p.label);
            assert!(rows.contains(&label), "phone {label} missing from the table: {rows:?}");
        }
    }
    assert!(unflagged.is_empty(), "injected errors not flagged: {unflagged:?}");
}
