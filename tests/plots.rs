//! Every chart lipmap draws, made by the binary and read back from its PNG: the trajectory
//! plots of `export` (the demo, and the real carphone clip with praat's IPA alignment) and
//! SAQP's Fig. 8 (`saqp cv --plot`). Each must carry its title (clip and comparison), both axis
//! labels with their units and, for trajectories, the phone labels as the aligner wrote them,
//! IPA included. Labels are found pixel for pixel with the font that drew them
//! (`plot::font::find_text`), so a label cut, crossed by a line or drawn as `?` fails.

mod common;
use common::{lipmap, s};

use image::RgbImage;
use lipmap::plot::font::find_text;
use lipmap::plot::trajectory::{INK, LABEL_PX, PHONE_PX, TITLE_PX};
use std::path::{Path, PathBuf};
use std::process::Output;

fn ok(out: &Output, what: &str) {
    assert!(out.status.success(), "{what}: {}", String::from_utf8_lossy(&out.stderr));
}

fn png(path: &Path) -> RgbImage {
    image::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display())).to_rgb8()
}

/// Finds each text (horizontal, or turned up when `up`) in `img`, naming the file and the
/// text that is missing.
fn assert_drawn(img: &RgbImage, file: &Path, texts: &[(&str, f32, bool)]) {
    for &(text, px, up) in texts {
        assert!(
            find_text(img, text, px, INK, up).is_some(),
            "{}: `{text}` is not drawn (or not legibly)",
            file.display()
        );
    }
}

/// The labels every trajectory chart of clip `clip` carries, min–max scaled (the default).
fn trajectory_labels(clip: &str, with_p: bool) -> Vec<(String, f32, bool)> {
    let mut t = vec![
        (
            format!("{clip}: mouth measures, video landmarks (2D) vs fitted 3D head"),
            TITLE_PX,
            false,
        ),
        ("time (s)".to_string(), LABEL_PX, false),
        ("video".to_string(), LABEL_PX, false),
        ("3D head".to_string(), LABEL_PX, false),
        ("W mouth width".to_string(), LABEL_PX, true),
        ("H mouth height".to_string(), LABEL_PX, true),
        ("min–max scaled, 0–1".to_string(), LABEL_PX, true),
    ];
    if with_p {
        t.push(("P protrusion".to_string(), LABEL_PX, true));
    }
    t
}

fn borrowed(t: &[(String, f32, bool)]) -> Vec<(&str, f32, bool)> {
    t.iter().map(|(s, px, up)| (s.as_str(), *px, *up)).collect()
}

#[test]
fn demo_export_plots_name_clip_comparison_axes_and_phones() {
    let dir = tempfile::tempdir().unwrap();
    let session = common::demo_session(dir.path());
    let out = dir.path().join("out");
    ok(&lipmap(&["export", s(&session), "--out", s(&out), "--plots"]), "export");
    let plots: Vec<PathBuf> =
        std::fs::read_dir(out.join("plots")).unwrap().map(|e| e.unwrap().path()).collect();
    assert!(!plots.is_empty());
    for file in &plots {
        let img = png(file);
        let clip = file.file_stem().unwrap().to_str().unwrap();
        assert_drawn(&img, file, &borrowed(&trajectory_labels(clip, true)));
        // The demo's phones, as its aligner wrote them (ARPAbet with stress digits).
        let phones = std::fs::read_to_string(
            session.parent().unwrap().join("speaker_00").join(clip).join("phones.csv"),
        )
        .unwrap();
        let labels: Vec<&str> = phones
            .lines()
            .skip(1)
            .filter_map(|l| l.rsplit(',').next())
            .filter(|l| *l != "sil")
            .collect();
        assert!(labels.iter().any(|l| l.ends_with(['0', '1', '2'])), "{labels:?}");
        let found = labels.iter().filter(|l| find_text(&img, l, PHONE_PX, INK, false).is_some());
        // Neighbours too short for their label may be left out; most are drawn.
        assert!(found.count() * 10 >= labels.len() * 8, "{}: {labels:?}", file.display());
    }
}

#[test]
fn carphone_export_with_an_ipa_alignment_draws_the_ipa_phones() {
    // mary.TextGrid is 1.87 s: 50 frames at 25 fps cover it.
    let Some(c) = common::carphone(50) else { return };
    let Some(mary) = lipmap::testdata::shared("data/speech/praatio_examples/mary.TextGrid") else {
        return;
    };
    let session = c.root.join("s.lipmap.json");
    ok(
        &lipmap(&[
            "new",
            s(&session),
            "--frames",
            s(&c.frames),
            "--fps",
            "25",
            "--landmarks",
            s(&c.landmarks),
            "--alignment",
            s(&mary),
            "--model",
            s(&c.eos.join("sfm_shape_3448.bin")),
            "--blendshapes",
            s(&c.eos.join("expression_blendshapes_3448.bin")),
            "--mapping",
            s(&c.eos.join("ibug_to_sfm.txt")),
            "--clip",
            "carphone",
        ]),
        "new",
    );
    let out = c.root.join("out");
    ok(&lipmap(&["export", s(&session), "--out", s(&out), "--plots"]), "export");
    let file = out.join("plots").join("carphone.png");
    let img = png(&file);
    assert_drawn(&img, &file, &borrowed(&trajectory_labels("carphone", false)));
    let phones: Vec<(&str, f32, bool)> = ["m", "ə", "r", "i", "o", "l", "d", "θ", "b", "œ"]
        .iter()
        .map(|p| (*p, PHONE_PX, false))
        .collect();
    assert_drawn(&img, &file, &phones);
    // Upper-case forms are not what the aligner wrote.
    assert!(find_text(&img, "I", PHONE_PX, INK, false).is_none());
}

#[test]
fn saqp_figure_8_labels_its_axes_and_each_synthesizer() {
    let dir = tempfile::tempdir().unwrap();
    let demo = dir.path().join("demo");
    ok(
        &lipmap(&["demo", "--no-tui", "--no-frames", "--sentences", "30", "--out", s(&demo)]),
        "demo",
    );
    let file = dir.path().join("fig8.png");
    let session = demo.join("demo.lipmap.json");
    let out = lipmap(&["saqp", "cv", s(&session), "--plot", s(&file), "--json"]);
    ok(&out, "saqp cv");
    let rows = common::synth_rows(&out.stdout);
    let img = png(&file);
    let mut texts: Vec<(String, f32, bool)> = vec![
        (
            "Quality of held-out sentences (cross-validation): ground truth vs predicted".into(),
            TITLE_PX,
            false,
        ),
        ("held-out sentence, ranked by ground-truth score (rank)".into(), LABEL_PX, false),
        ("Likert score".into(), LABEL_PX, true),
        ("1 worst – 5 best".into(), LABEL_PX, true),
        ("ground truth".into(), LABEL_PX, false),
        ("predicted ± σ".into(), LABEL_PX, false),
    ];
    for r in &rows {
        let name = r["synthesizer"].as_str().unwrap();
        let pearson = r["r"].as_f64().unwrap_or_else(|| panic!("no `r` in {r}"));
        texts.push((format!("{name} synthesizer: Pearson r {pearson:.2}"), LABEL_PX, false));
    }
    assert_eq!(texts.len(), 6 + 3);
    assert_drawn(&img, &file, &borrowed(&texts));
}
