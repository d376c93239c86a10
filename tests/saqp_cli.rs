//! `lipmap saqp` through the binary on a 30-sentence demo session made without video
//! frames: cross-validation of the built-in synthesizers and of an external one read from
//! motion CSVs, a trained predictor scoring phone files, and the bad inputs a researcher can
//! give it, each a one-line error naming the file or folder.

mod common;
use common::{lipmap, s, text};

use lipmap::io::motion_csv::{VertexMotion, format_motion_csv};
use lipmap::math::Point3;
use lipmap::workflow::saqp::{CorpusOptions, marker_vertices, session_corpus};
use std::path::{Path, PathBuf};
use std::process::Output;

/// The one error line of a failed run (progress lines aside).
fn one_error(out: &Output) -> String {
    assert!(!out.status.success(), "expected a failure, got: {}", text(&out.stdout));
    let lines: Vec<String> = text(&out.stderr)
        .lines()
        .filter(|l| !l.trim().is_empty() && !l.starts_with("cross-validating"))
        .map(String::from)
        .collect();
    assert_eq!(lines.len(), 1, "not one line: {lines:?}");
    lines[0].clone()
}

fn demo(dir: &Path) -> PathBuf {
    let out_dir = dir.join("demo");
    let out =
        lipmap(&["demo", "--no-tui", "--no-frames", "--sentences", "30", "--out", s(&out_dir)]);
    assert!(out.status.success(), "demo: {}", text(&out.stderr));
    let pngs = walk(&out_dir).into_iter().filter(|p| p.extension().is_some_and(|e| e == "png"));
    assert_eq!(pngs.count(), 0, "--no-frames still rendered frames");
    out_dir.join("demo.lipmap.json")
}

fn walk(dir: &Path) -> Vec<PathBuf> {
    let mut out = Vec::new();
    for e in std::fs::read_dir(dir).unwrap() {
        let p = e.unwrap().path();
        if p.is_dir() { out.extend(walk(&p)) } else { out.push(p) }
    }
    out
}

/// A synthesizer that lags the real motion by `lag` frames, as marker CSVs, one per
/// sentence.
fn write_lagged_motion(session: &Path, dir: &Path, lag: usize) {
    std::fs::create_dir_all(dir).unwrap();
    let sc = session_corpus(&[s(session).to_string()], &CorpusOptions::default(), &|_| {}).unwrap();
    let markers: Vec<usize> = marker_vertices(&sc.corpus).unwrap().iter().map(|m| m.0).collect();
    let shapes = &sc.corpus.shapes;
    for sentence in &sc.corpus.sentences {
        let frames = (0..sentence.frames.len())
            .map(|f| {
                let x = shapes.shape(&sentence.frames[f.saturating_sub(lag)]);
                markers.iter().map(|&v| Point3::new(x[3 * v], x[3 * v + 1], x[3 * v + 2])).collect()
            })
            .collect();
        let motion = VertexMotion { vertices: markers.clone(), frames };
        let mut sorted = motion.clone();
        // The CSV reader gives vertices in ascending order; write them so.
        let mut order: Vec<usize> = (0..markers.len()).collect();
        order.sort_by_key(|&k| markers[k]);
        sorted.vertices = order.iter().map(|&k| markers[k]).collect();
        sorted.frames =
            motion.frames.iter().map(|f| order.iter().map(|&k| f[k]).collect()).collect();
        std::fs::write(dir.join(format!("{}.csv", sentence.name)), format_motion_csv(&sorted))
            .unwrap();
    }
}

#[test]
fn cross_validate_train_predict_and_every_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let session = demo(dir.path());

    // The built-in synthesizers, with the paper's Fig. 8.
    let png = dir.path().join("quality.png");
    let out = lipmap(&["saqp", "cv", s(&session), "--plot", s(&png), "--json"]);
    assert!(out.status.success(), "cv: {}", text(&out.stderr));
    let rows = common::synth_rows(&out.stdout);
    let names: Vec<&str> = rows.iter().map(|r| r["synthesizer"].as_str().unwrap()).collect();
    assert_eq!(names, ["keyframe", "trajectory", "concat"]);
    for r in &rows {
        assert_eq!(r["held out"].as_i64(), Some(6), "{r}");
        let rmse = r["RMSE"].as_f64().unwrap();
        assert!(rmse.is_finite() && rmse > 0.0 && rmse < 2.0, "{r}");
    }
    let chart = image::open(&png).unwrap();
    assert_eq!(chart.width(), 900);

    // The markers a researcher's CSV must give.
    let out = lipmap(&["saqp", "markers", s(&session), "--format", "csv"]);
    assert!(out.status.success(), "markers: {}", text(&out.stderr));
    let listing = text(&out.stdout);
    assert!(listing.contains("vertex,mouth"), "{listing}");
    assert!(listing.lines().filter(|l| l.ends_with(",yes")).count() >= 4, "{listing}");

    // An external synthesizer from motion CSVs is scored beside nothing else.
    let ext = dir.path().join("lagged");
    write_lagged_motion(&session, &ext, 3);
    let out = lipmap(&[
        "saqp",
        "cv",
        s(&session),
        "--synth-files",
        s(&ext),
        "--synth",
        "external",
        "--json",
    ]);
    assert!(out.status.success(), "external cv: {}", text(&out.stderr));
    let rows = common::synth_rows(&out.stdout);
    assert_eq!(rows.len(), 1);
    assert_eq!(rows[0]["synthesizer"], "external");
    assert_eq!(rows[0]["held out"].as_i64(), Some(6), "{}", rows[0]);
    assert!(rows[0]["RMSE"].as_f64().is_some_and(f64::is_finite), "{}", rows[0]);

    // A trained predictor scores phone files and names phones the corpus never saw.
    let model = dir.path().join("quality.json");
    let train = |more: &[&str]| {
        let mut args =
            vec!["saqp", "train", s(&session), "--synth", "keyframe", "--out", s(&model)];
        args.extend(more);
        lipmap(&args)
    };
    // A predictor without skill on its held-out sentences is saved only when asked.
    let out = train(&[]);
    let skilled = out.status.success();
    if skilled {
        assert!(text(&out.stdout).contains(": skill)"), "{}", text(&out.stdout));
    } else {
        let e = one_error(&out);
        assert!(e.contains("no skill") && e.contains("--allow-no-skill"), "{e}");
        assert!(!model.exists());
    }
    let out = train(&["--allow-no-skill"]);
    assert!(out.status.success(), "train: {}", text(&out.stderr));
    assert!(text(&out.stdout).contains("keyframe quality predictor on 30 sentences"));
    let known = dir.path().join("known.csv");
    std::fs::write(
        &known,
        "start,end,phone\n0,0.2,sil\n0.2,0.3,B\n0.3,0.45,IH1\n0.45,0.6,N\n0.6,0.8,sil\n",
    )
    .unwrap();
    let foreign = dir.path().join("foreign.csv");
    std::fs::write(
        &foreign,
        "start,end,phone\n0,0.2,sil\n0.2,0.3,B\n0.3,0.45,œ\n0.45,0.6,N\n0.6,0.8,sil\n",
    )
    .unwrap();
    // The known phones in IPA: the same phones to the predictor.
    let ipa = dir.path().join("ipa.csv");
    std::fs::write(
        &ipa,
        "start,end,phone\n0,0.2,sil\n0.2,0.3,b\n0.3,0.45,ɪ\n0.45,0.6,n\n0.6,0.8,sil\n",
    )
    .unwrap();
    let out = lipmap(&[
        "saqp",
        "predict",
        s(&model),
        "--phones",
        s(&known),
        s(&foreign),
        s(&ipa),
        "--json",
    ]);
    assert!(out.status.success(), "predict: {}", text(&out.stderr));
    let tables: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    let rows = tables["predictions"]["rows"].as_array().unwrap().clone();
    assert_eq!(rows.len(), 3);
    for r in &rows {
        let p = r["predicted"].as_f64().unwrap();
        assert!(p.is_finite() && p > 0.0 && p < 6.0, "{r}");
    }
    assert_eq!(rows[0]["unseen phones"], "");
    assert_eq!(rows[1]["unseen phones"], "œ");
    assert_eq!(rows[2]["unseen phones"], "");
    assert_eq!(rows[2]["predicted"], rows[0]["predicted"]);
    // The predictor says whether it has skill.
    let notes = tables["predictions"]["notes"].to_string();
    assert_eq!(notes.contains("has NO skill"), !skilled, "{notes}");

    // Bad inputs: one line naming the place.
    let first = std::fs::read_dir(&ext).unwrap().next().unwrap().unwrap().path();
    let name = first.file_stem().unwrap().to_string_lossy().into_owned();
    let good = std::fs::read_to_string(&first).unwrap();
    let cv_ext = || lipmap(&["saqp", "cv", s(&session), "--synth-files", s(&ext)]);
    let lines: Vec<&str> = good.lines().collect();
    // One frame short.
    let last_frame = lines.last().unwrap().split(',').next().unwrap().to_string();
    let short: Vec<&str> =
        lines.iter().copied().filter(|l| !l.starts_with(&format!("{last_frame},"))).collect();
    std::fs::write(&first, short.join("\n")).unwrap();
    let e = one_error(&cv_ext());
    assert!(e.contains(s(&ext)) && e.contains(&name) && e.contains("frames"), "{e}");
    // A marker missing.
    let marker = lines[1].split(',').nth(1).unwrap().to_string();
    let no_marker: Vec<&str> =
        lines.iter().copied().filter(|l| l.split(',').nth(1) != Some(marker.as_str())).collect();
    std::fs::write(&first, no_marker.join("\n")).unwrap();
    let e = one_error(&cv_ext());
    assert!(e.contains(&marker) && e.contains("lipmap saqp markers"), "{e}");
    // A bad number.
    let mut bad_number: Vec<String> = lines.iter().map(|l| l.to_string()).collect();
    let mut fields: Vec<&str> = lines[1].split(',').collect();
    fields[2] = "1.0e";
    bad_number[1] = fields.join(",");
    std::fs::write(&first, bad_number.join("\n")).unwrap();
    let e = one_error(&cv_ext());
    assert!(e.contains(&format!("{name}.csv:2")), "{e}");
    // A folder with nothing for any sentence.
    let empty = dir.path().join("empty");
    std::fs::create_dir_all(&empty).unwrap();
    let e = one_error(&lipmap(&["saqp", "cv", s(&session), "--synth-files", s(&empty)]));
    assert!(e.contains(s(&empty)) && e.contains("no synthesized motion"), "{e}");
    // Not a predictor.
    let e = one_error(&lipmap(&["saqp", "predict", s(&known), "--phones", s(&known)]));
    assert!(e.contains(s(&known)) && e.contains("not a quality model"), "{e}");
    // A damaged predictor is refused before use (these crashed or hung once).
    let trained: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&model).unwrap()).unwrap();
    type Damage = fn(&mut serde_json::Value);
    // Absurd values that parse: each refused by the field, none scored (a target mean of
    // 1e308 once predicted 1e308 on the 1–5 scale).
    let damages: [(&str, Damage); 12] = [
        ("targets", |m| m["predictor"]["gp"]["targets"] = serde_json::json!([])),
        ("order", |m| m["predictor"]["satf"]["order"] = serde_json::json!(4_294_967_296u64)),
        ("stats.dims", |m| m["predictor"]["stats"]["dims"] = serde_json::json!(0)),
        ("gp.target_mean", |m| m["predictor"]["gp"]["target_mean"] = serde_json::json!(1e308)),
        ("gp.targets", |m| m["predictor"]["gp"]["targets"][0] = serde_json::json!(-7.0)),
        ("omega_m", |m| m["predictor"]["omega_m"] = serde_json::json!(1e308)),
        ("xi", |m| m["predictor"]["xi"] = serde_json::json!(-1.0)),
        ("fps", |m| m["predictor"]["fps"] = serde_json::json!(0.0)),
        ("gp.hyper.noise_variance", |m| {
            m["predictor"]["gp"]["hyper"]["noise_variance"] = serde_json::json!(1e300)
        }),
        ("linear.coefficients", |m| {
            m["predictor"]["linear"]["coefficients"][1] = serde_json::json!(1e100)
        }),
        ("gp.inputs", |m| m["predictor"]["gp"]["inputs"][0][1] = serde_json::json!(7.0)),
        ("skill.ratio", |m| m["predictor"]["skill"]["ratio"] = serde_json::json!(-1.0)),
    ];
    let damaged = dir.path().join("damaged.json");
    for (field, damage) in damages {
        let mut m = trained.clone();
        damage(&mut m);
        std::fs::write(&damaged, serde_json::to_vec(&m).unwrap()).unwrap();
        let e = one_error(&lipmap(&["saqp", "predict", s(&damaged), "--phones", s(&known)]));
        assert!(e.contains(s(&damaged)) && e.contains(field), "{field}: {e}");
    }
}
