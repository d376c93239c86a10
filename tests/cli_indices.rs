//! `lipmap indices` and `lipmap eval --heads` run as a user would: the built binary on real
//! iBUG annotations (values checked against hand arithmetic), on a session, and on demo heads.

use lipmap::demo::{DemoOptions, generate};
use lipmap::session::{Clip, FramesRef, ModelRef, Session, View};
use serde_json::Value;
use std::path::{Path, PathBuf};
use std::process::Command;

fn lipmap(args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_lipmap")).args(args).output().unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

fn ok(args: &[&str]) -> String {
    let (success, stdout, stderr) = lipmap(args);
    assert!(success, "lipmap {args:?} failed: {stderr}");
    stdout
}

/// The 68 points of a `.pts` file, parsed here independently of lipmap's reader.
fn read_pts(path: &Path) -> Vec<(f64, f64)> {
    let text = std::fs::read_to_string(path).unwrap();
    let body = text.split('{').nth(1).unwrap().split('}').next().unwrap();
    let nums: Vec<f64> = body.split_whitespace().map(|s| s.parse().unwrap()).collect();
    assert_eq!(nums.len(), 136, "{}", path.display());
    nums.chunks(2).map(|c| (c[0], c[1])).collect()
}

fn dist(a: (f64, f64), b: (f64, f64)) -> f64 {
    ((a.0 - b.0).powi(2) + (a.1 - b.1).powi(2)).sqrt()
}

/// The 12 indices by hand from their definitions (`measure::indices`), in the published order.
fn hand_indices(p: &[(f64, f64)]) -> [f64; 12] {
    let nasion = ((p[39].0 + p[42].0) / 2.0, (p[39].1 + p[42].1) / 2.0);
    let d1 = dist(p[8], nasion);
    let d2 = dist(p[0], p[16]);
    let d3 = dist(p[36], p[45]);
    let d4 = dist(p[39], p[42]);
    let d5 = dist(nasion, p[33]);
    let d6 = dist(p[31], p[35]);
    let d7 = dist(p[51], p[57]);
    let d8 = dist(p[48], p[54]);
    let d9 = dist(p[51], p[62]);
    let d10 = dist(p[66], p[57]);
    let d11 = dist(p[57], p[8]);
    let d12 = dist(p[33], p[51]);
    let d13 = dist(p[33], p[8]);
    [
        d1 / d2,
        d4 / d3,
        d6 / d5,
        d5 / d1,
        d6 / d2,
        d7 / d8,
        d7 / d1,
        d9 / d1,
        d10 / d1,
        d8 / d3,
        d11 / d1,
        d12 / d13,
    ]
    .map(|r| 100.0 * r)
}

/// (index name, value, class) rows of a CSV indices table.
fn csv_rows(csv: &str) -> Vec<(String, f64, String)> {
    let mut lines = csv.lines().filter(|l| !l.starts_with('#'));
    let header: Vec<&str> = lines.next().unwrap().split(',').collect();
    let col = |n: &str| header.iter().position(|h| *h == n).unwrap();
    let (ci, cv, cc) = (col("index"), col("value"), col("class"));
    lines
        .take_while(|l| !l.is_empty())
        .map(|l| {
            let f: Vec<&str> = l.split(',').collect();
            (f[ci].to_string(), f[cv].parse().unwrap(), f[cc].to_string())
        })
        .collect()
}

#[test]
fn indices_of_pts_files_match_hand_arithmetic() {
    let Some(dir) = lipmap::testdata::shared("data/images") else { return };
    for name in ["takeo.pts", "einstein.pts"] {
        let path = dir.join(name);
        let want = hand_indices(&read_pts(&path));
        let rows = csv_rows(&ok(&["indices", path.to_str().unwrap(), "--format", "csv"]));
        assert_eq!(rows.len(), 12, "{name}");
        for ((label, got, class), w) in rows.iter().zip(want) {
            assert!((got - w).abs() < 1e-9 * w.abs().max(1.0), "{name} {label}: {got} vs {w}");
            assert!(["low", "middle", "high"].contains(&class.as_str()), "{name} {label}");
        }
        // Vertical mouth height (7th) classed by the published bounds 13.58 / 16.22.
        let (label, v, class) = &rows[6];
        assert_eq!(label, "vertical mouth height");
        let by_hand = if *v < 13.58 {
            "low"
        } else if *v > 16.22 {
            "high"
        } else {
            "middle"
        };
        assert_eq!(class, by_hand, "{name}");
    }
    // Text output names the file and lists every index.
    let text = ok(&["indices", dir.join("takeo.pts").to_str().unwrap()]);
    assert!(text.contains("takeo.pts, frame 0"), "{text}");
    assert!(text.contains("nose upper lip") && text.contains("D12/D13"), "{text}");
}

#[test]
fn user_bounds_and_computed_bounds_round_trip() {
    let Some(images) = lipmap::testdata::shared("data/images") else { return };
    let Some(carphone) = lipmap::testdata::shared("data/carphone/dlib68_pts") else { return };
    let tmp = tempfile::tempdir().unwrap();
    let takeo = images.join("takeo.pts");
    // A user table putting every vertical mouth height above 1 in "high".
    let user = tmp.path().join("mine.csv");
    std::fs::write(&user, "index,low,high\nvertical mouth height,0.5,1\n").unwrap();
    let rows = csv_rows(&ok(&[
        "indices",
        takeo.to_str().unwrap(),
        "--bounds",
        user.to_str().unwrap(),
        "--format",
        "csv",
    ]));
    assert_eq!(rows[6].2, "high");
    assert_eq!(rows[0].2, "", "an index the table lacks has no class");
    // A bad table is refused with its file and line.
    std::fs::write(&user, "index,low,high\nfacial,3,x\n").unwrap();
    let (success, _, err) =
        lipmap(&["indices", takeo.to_str().unwrap(), "--bounds", user.to_str().unwrap()]);
    assert!(!success && err.contains("mine.csv:2"), "{err}");

    // Corpus bounds from six speakers' frames by the box-plot rule.
    let mut inputs: Vec<PathBuf> = vec![takeo.clone(), images.join("einstein.pts")];
    inputs.extend((0..4).map(|k| carphone.join(format!("frame_{:04}.pts", 20 * k))));
    let out = tmp.path().join("lab.toml");
    let mut args = vec!["indices", "--compute-bounds", out.to_str().unwrap(), "--json"];
    args.extend(inputs.iter().map(|p| p.to_str().unwrap()));
    let doc: Value = serde_json::from_str(&ok(&args)).unwrap();
    let plots = doc["bounds"]["rows"].as_array().unwrap();
    assert_eq!(plots.len(), 12);
    // Q1/Q3 of the six vertical mouth heights worked out here (type-7 quantiles).
    let mut vmh: Vec<f64> = inputs.iter().map(|p| hand_indices(&read_pts(p))[6]).collect();
    vmh.sort_by(f64::total_cmp);
    let q = |f: f64| {
        let h = 5.0 * f;
        let lo = h.floor() as usize;
        vmh[lo] + (h - lo as f64) * (vmh[(lo + 1).min(5)] - vmh[lo])
    };
    let row = &plots[6];
    assert_eq!(row["index"], "vertical mouth height");
    assert!((row["low (Q1)"].as_f64().unwrap() - q(0.25)).abs() < 1e-9, "{row}");
    assert!((row["high (Q3)"].as_f64().unwrap() - q(0.75)).abs() < 1e-9, "{row}");
    // The written table is usable with --bounds.
    let rows = csv_rows(&ok(&[
        "indices",
        takeo.to_str().unwrap(),
        "--bounds",
        out.to_str().unwrap(),
        "--format",
        "csv",
    ]));
    assert!(rows.iter().all(|r| !r.2.is_empty()));
    // Fewer than four speakers cannot give quartiles.
    let (success, _, err) = lipmap(&[
        "indices",
        "--compute-bounds",
        out.to_str().unwrap(),
        takeo.to_str().unwrap(),
        images.join("einstein.pts").to_str().unwrap(),
    ]);
    assert!(!success && err.contains("fewer than 4"), "{err}");
}

#[test]
fn session_prints_speaker_head_and_verdict() {
    let Some(carphone) = lipmap::testdata::shared("data/carphone") else { return };
    let Some(eos) = lipmap::testdata::shared("peer/eos/share") else { return };
    let Some(speech) = lipmap::testdata::shared("data/speech/generated") else { return };
    let tmp = tempfile::tempdir().unwrap();
    let session = tmp.path().join("s.lipmap.json");
    let s = session.to_str().unwrap();
    let p = |p: PathBuf| p.to_str().unwrap().to_string();
    ok(&[
        "new",
        s,
        "--frames",
        &p(carphone.join("frames")),
        "--landmarks",
        &p(carphone.join("dlib68_pts")),
        "--alignment",
        &p(speech.join("praat_bin_blue.TextGrid")),
        "--model",
        &p(eos.join("sfm_shape_3448.bin")),
        "--mapping",
        &p(eos.join("ibug_to_sfm.txt")),
    ]);
    let text = ok(&["indices", s]);
    for part in ["speaker indices", "head indices", "speaker vs head", "verdict"] {
        assert!(text.contains(part), "missing {part}:\n{text}");
    }
    assert!(text.contains("neutral frame") && text.contains("inside silence"), "{text}");
    // The SFM map has no face contour: the two indices needing zygion are left out.
    assert!(
        text.contains("not computed (landmarks not mapped to vertices): facial, nose face width")
    );

    // --frame: the speaker's values are that frame's, worked out by hand.
    let doc: Value = serde_json::from_str(&ok(&["indices", s, "--frame", "10", "--json"])).unwrap();
    let want = hand_indices(&read_pts(&carphone.join("dlib68_pts/frame_0010.pts")));
    let speaker = doc["speaker"]["rows"].as_array().unwrap();
    assert_eq!(speaker.len(), 12);
    for (row, w) in speaker.iter().zip(want) {
        let got = row["value"].as_f64().unwrap();
        assert!((got - w).abs() < 1e-9 * w.max(1.0), "{row} vs {w}");
    }
    let head = doc["head"]["rows"].as_array().unwrap();
    assert!(head[0]["value"].is_null(), "facial needs zygion, unmapped in SFM");
    let vmh = head[6]["value"].as_f64().unwrap();
    assert!(vmh > 5.0 && vmh < 30.0, "{vmh}");
    let checks = doc["verdict"]["rows"].as_array().unwrap();
    assert_eq!(checks.len(), 2);
    let vmh_class = head[6]["class"].as_str().unwrap();
    assert_eq!(checks[0]["head"], vmh_class);
    assert_eq!(doc["comparison"]["rows"].as_array().unwrap().len(), 12);
    // An unknown session is an error naming it.
    let (success, _, err) = lipmap(&["indices", &p(tmp.path().join("nope.lipmap.json"))]);
    assert!(!success && err.contains("nope.lipmap.json"), "{err}");
}

/// A demo head folder and a session of speaker `speaker`'s clips in `dir`.
fn demo_session(dir: &Path) -> (PathBuf, PathBuf) {
    let out = generate(&DemoOptions {
        out_dir: dir.join("demo"),
        speakers: 2,
        sentences: 3,
        width: 240,
        height: 160,
        write_frames: false,
        side_view: false,
        write_model: true,
        max_frames: Some(12),
        ..DemoOptions::default()
    })
    .unwrap();
    let path = dir.join("spk.lipmap.json");
    let mut session = Session::new(&path);
    session.model = Some(ModelRef { path: out.model.clone().unwrap(), blendshapes: None });
    session.landmark_map.file = Some(out.landmark_map.clone());
    for c in &out.speakers[1].clips {
        let mut view = View::new(FramesRef::Images { dir: c.dir.join("front") }, c.fps);
        view.size = Some([c.width, c.height]);
        let mut clip = Clip::new(c.name.clone(), view);
        clip.set_tracked(lipmap::io::landmark_format::read_track(&c.true_csv).unwrap());
        clip.alignment =
            Some(lipmap::io::alignment_format::read_alignment(&c.phones_csv, None).unwrap());
        session.add_clip(clip).unwrap();
    }
    session.save(&path).unwrap();
    (out.out_dir, path)
}

#[test]
fn eval_heads_compares_heads_with_paired_tests() {
    let tmp = tempfile::tempdir().unwrap();
    let (demo_dir, session) = demo_session(tmp.path());
    // Head "other": the demo model with the lower-lip midpoints mapped one row lower, so its
    // fits (and RMSEs) differ from the demo head's.
    let other = tmp.path().join("other");
    std::fs::create_dir(&other).unwrap();
    std::fs::copy(demo_dir.join("model.lmm"), other.join("model.lmm")).unwrap();
    let map = std::fs::read_to_string(demo_dir.join("head_map.toml")).unwrap();
    let head_obj = lipmap::io::obj::read_obj(&demo_dir.join("head.obj")).unwrap();
    let remapped = shift_landmark_down(&map, 58, &head_obj);
    std::fs::write(other.join("head_map.toml"), remapped).unwrap();

    let heads = format!("{},{}", demo_dir.display(), other.display());
    let doc: Value = serde_json::from_str(&ok(&[
        "eval",
        session.to_str().unwrap(),
        "--heads",
        &heads,
        "--json",
    ]))
    .unwrap();
    let rmse = doc["heads"]["rows"].as_array().unwrap();
    assert_eq!(rmse.len(), 3 + 2, "3 sentences, mean, p: {rmse:?}");
    for col in ["demo W", "demo H", "other W", "other H"] {
        assert!(rmse[0][col].is_number(), "{col} in {}", rmse[0]);
    }
    let p = &rmse[4];
    assert!(p["sentence"].as_str().unwrap().starts_with("p vs demo"));
    assert!(p["demo W"].is_null(), "no test of the baseline against itself");
    let pw = p["other H"].as_f64().expect("p of other vs demo over 3 sentences");
    assert!((0.0..=1.0).contains(&pw), "{pw}");
    let matches = doc["matches"]["rows"].as_array().unwrap();
    assert_eq!(matches.len(), 2);
    for m in matches {
        assert!(["yes", "no"].contains(&m["corresponding"].as_str().unwrap()), "{m}");
    }
    // With both kinds of head, the grouped table and its paired test are there.
    let kinds: Vec<&str> = matches.iter().map(|m| m["corresponding"].as_str().unwrap()).collect();
    if kinds.contains(&"yes") && kinds.contains(&"no") {
        let grouped = doc["correspondence"]["rows"].as_array().unwrap();
        assert_eq!(grouped.len(), 5);
        assert!(grouped[4]["non-corresponding H"].is_number(), "{}", grouped[4]);
    }
    // Text output carries the same tables.
    let text = ok(&["eval", session.to_str().unwrap(), "--heads", &heads]);
    assert!(text.contains("RMSE by head") && text.contains("speaker-head match"), "{text}");
    assert!(text.contains("W/H frontal ≤15°"), "the default comparison is named: {text}");
    // `--pose` reaches the heads as it reaches the session's own head, and is named.
    let text = ok(&["eval", session.to_str().unwrap(), "--heads", &heads, "--pose", "image-plane"]);
    assert!(text.contains("RMSE by head · W/H image plane"), "{text}");
    // A folder without a model is refused with a reason.
    let empty = tmp.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    let (success, _, err) =
        lipmap(&["eval", session.to_str().unwrap(), "--heads", empty.to_str().unwrap()]);
    assert!(!success && err.contains("no model"), "{err}");
}

/// The map text with 1-based landmark `lm` moved to the vertex nearest a point 3 mm below
/// its current vertex.
fn shift_landmark_down(map: &str, lm: usize, mesh: &lipmap::model::Mesh) -> String {
    let prefix = format!("{lm} ");
    let line =
        map.lines().find(|l| l.starts_with(&prefix) || l.starts_with(&format!("{lm}="))).unwrap();
    let v: usize =
        line.split('=').nth(1).unwrap().split('#').next().unwrap().trim().parse().unwrap();
    let p = mesh.vertices[v];
    let target = lipmap::math::Point3::new(p.x, p.y - 3.0, p.z);
    let nearest = (0..mesh.vertices.len())
        .filter(|&k| k != v)
        .min_by(|&a, &b| {
            (mesh.vertices[a] - target).norm().total_cmp(&(mesh.vertices[b] - target).norm())
        })
        .unwrap();
    map.replace(line, &format!("{lm} = {nearest}"))
}
