//! A researcher's first hour, through the binary: README's headless `fit` on eos's own files
//! (its landmark CSV and both forms of its map), `validate` naming every file lipmap writes,
//! `lipmap help TERM`, and the words and numbering of `eval`, `fit` and `transfer`. Real data
//! from ../shared (skipped with a notice when absent); the rest on a one-sentence demo.

mod common;
use common::{lipmap, s};

use std::path::Path;
use std::process::Output;

/// eos's SFM model, its expression blendshapes and `map`, as `fit` and `new` take them.
fn sfm_args(share: &Path, map: &Path) -> Vec<String> {
    let model = share.join("sfm_shape_3448.bin");
    let blendshapes = share.join("expression_blendshapes_3448.bin");
    [("--model", model.as_path()), ("--blendshapes", &blendshapes), ("--mapping", map)]
        .into_iter()
        .flat_map(|(flag, path)| [flag.to_string(), s(path).to_string()])
        .collect()
}

fn stdout(o: &Output) -> String {
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    String::from_utf8_lossy(&o.stdout).into_owned()
}

#[test]
fn readme_headless_fit_reads_eos_landmarks_and_maps_and_validate_names_its_outputs() {
    let Some(eos) = lipmap::testdata::shared("peer/eos") else {
        eprintln!("skipped: ../shared/peer/eos is absent");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let share = eos.join("share");
    let landmarks = eos.join("reference/landmarks.csv");
    for (map, out) in [
        (share.join("ibug_to_sfm.txt"), dir.path().join("fit_toml")),
        (eos.join("model/landmarks_and_contours.json"), dir.path().join("fit_json")),
    ] {
        let model = sfm_args(&share, &map);
        let mut args = vec!["fit"];
        args.extend(model.iter().map(String::as_str));
        let landmarks = ["--landmarks", s(&landmarks), "--image-size", "1280x720"];
        args.extend(landmarks.into_iter().chain(["--clip", "--out", s(&out)]));
        let text = stdout(&lipmap(&args));
        assert!(text.contains("60 frames") && text.contains("reprojection RMS"), "{text}");
    }
    let fit = dir.path().join("fit_toml");
    let v = lipmap(&[
        "validate",
        s(&landmarks),
        s(&share.join("ibug_to_sfm.txt")),
        s(&eos.join("model/landmarks_and_contours.json")),
        s(&fit.join("fit.csv")),
        s(&fit.join("shapes.npy")),
    ]);
    let said = stdout(&v);
    let lines: Vec<&str> = said.lines().collect();
    assert_eq!(lines.len(), 5, "{said}");
    assert!(lines[0].ends_with("ok (landmarks, 60 frames)"), "{said}");
    assert!(lines[1].ends_with("ok (landmark map, 50 landmarks mapped)"), "{said}");
    assert!(lines[2].ends_with("ok (landmark map, 50 landmarks mapped)"), "{said}");
    assert!(lines[3].ends_with("ok (fit results (fit.csv), 60 frames, 0 failed)"), "{said}");
    assert!(lines[4].contains("ok (array 60 × 10344: 60 shapes of 3448 vertices"), "{said}");
}

#[test]
fn validate_names_what_export_and_transfer_write() {
    let dir = tempfile::tempdir().unwrap();
    let session = common::demo_session(dir.path());
    let demo = session.parent().unwrap();
    let out = dir.path().join("out");
    stdout(&lipmap(&["export", s(&session), "--out", s(&out)]));
    let moved = dir.path().join("moved");
    stdout(&lipmap(&[
        "transfer",
        s(&session),
        "--head",
        s(&demo.join("head.obj")),
        "--mapping",
        s(&demo.join("head_map.toml")),
        "--out",
        s(&moved),
    ]));
    let clip = std::fs::read_dir(&moved).unwrap().next().unwrap().unwrap().path();
    let plot = std::fs::read_dir(out.join("plots")).unwrap().next().unwrap().unwrap().path();
    let files = [
        out.join("tables/sentences.csv"),
        out.join("tables/worst_fits.csv"),
        plot,
        clip.join("shapes.npy"),
        clip.join("frames.csv"),
        demo.join("head_map.toml"),
    ];
    let mut args = vec!["validate"];
    args.extend(files.iter().map(|f| s(f)));
    let said = stdout(&lipmap(&args));
    let lines: Vec<&str> = said.lines().collect();
    assert_eq!(lines.len(), files.len(), "{said}");
    assert!(lines[0].contains("ok (table, 2 rows × "), "{said}");
    assert!(lines[0].contains("(sentence, "), "{said}");
    assert!(lines[1].contains("ok (table, ") && lines[1].contains("rank, clip, frame"), "{said}");
    assert!(lines[2].contains("ok (image, "), "{said}");
    assert!(lines[3].contains("shapes of") && lines[3].contains("vertices"), "{said}");
    assert!(lines[4].contains("ok (frame list (frames.csv"), "{said}");
    assert!(lines[5].contains("ok (landmark map, 68 landmarks mapped)"), "{said}");
}

#[test]
fn help_explains_a_term_by_any_of_its_names_and_still_shows_commands() {
    let e = stdout(&lipmap(&["help", "omega_m"]));
    assert!(e.starts_with("mouth weight ω_m  ("), "{e}");
    assert!(e.contains("quality error Q"), "{e}");
    let e = stdout(&lipmap(&["help", "bridged"]));
    assert!(e.starts_with("frames filled from neighbours"), "{e}");
    let e = stdout(&lipmap(&["help", "reprojection", "RMS"]));
    assert!(e.starts_with("reprojection RMS  (px"), "{e}");
    let list = stdout(&lipmap(&["help", "terms"]));
    assert!(list.contains("largest training error ξ") && list.contains("placement residual"));
    let fit = stdout(&lipmap(&["help", "saqp", "cv"]));
    assert!(fit.contains("Usage: lipmap saqp cv"), "{fit}");
    let bad = lipmap(&["help", "no-such-thing"]);
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("lipmap help terms"));
}

#[test]
fn eval_tables_state_set_scaling_and_comparison_and_points_are_one_based() {
    let dir = tempfile::tempdir().unwrap();
    let session = common::demo_session(dir.path());
    let text = stdout(&lipmap(&["eval", s(&session)]));
    // The demo fits with all 68 points.
    let conditions = "fit on F5 (68 points) · min–max scaled per sentence · W/H frontal ≤15°";
    for title in ["RMSE per sentence (video vs head)", "RMSE per phoneme", "RMSE per viseme class"]
    {
        assert!(text.contains(&format!("{title} — {conditions}")), "{title}: {text}");
    }
    assert!(
        text.contains("worst frames by reprojection RMS (px) — fit on F5 (68 points)"),
        "{text}"
    );
    // Another set (a session setting), scaling and comparison are named as such. Flags name
    // points 1–68.
    let fit = lipmap(&["fit", s(&session), "--set", "F1"]);
    let err = String::from_utf8_lossy(&fit.stderr).into_owned();
    stdout(&fit);
    let other =
        stdout(&lipmap(&["eval", s(&session), "--normalise", "none", "--pose", "image-plane"]));
    assert!(other.contains("fit on F1 (20 points) · ratios unscaled · W/H image plane"), "{other}");
    for line in err.lines().filter(|l| l.contains(" jumped ")) {
        let n: usize = line
            .split(" jumped ")
            .next()
            .and_then(|l| l.rsplit(' ').next())
            .and_then(|n| n.parse().ok())
            .unwrap_or_else(|| panic!("{line}"));
        assert!((1..=68).contains(&n), "{line}");
    }
}

#[test]
fn carphone_session_from_dlib_tracks_speaks_in_points_1_to_68_and_names_what_eval_compared() {
    let (Some(carphone), Some(eos)) =
        (lipmap::testdata::shared("data/carphone"), lipmap::testdata::shared("peer/eos/share"))
    else {
        eprintln!("skipped: ../shared/data/carphone or ../shared/peer/eos is absent");
        return;
    };
    let dir = tempfile::tempdir().unwrap();
    let session = dir.path().join("cp.lipmap.json");
    let (frames, tracks) = (carphone.join("frames"), carphone.join("dlib68_pts"));
    let model = sfm_args(&eos, &eos.join("ibug_to_sfm.txt"));
    let mut args = vec!["new", s(&session), "--frames", s(&frames), "--fps", "29.97"];
    args.extend(["--landmarks", s(&tracks)]);
    args.extend(model.iter().map(String::as_str));
    let made = stdout(&lipmap(&args));
    assert!(made.contains("120 frames of landmarks, 50 landmarks mapped"), "{made}");
    let fit = lipmap(&["fit", s(&session)]);
    let said = stdout(&fit) + &String::from_utf8_lossy(&fit.stderr);
    assert!(said.contains("median reprojection RMS"), "{said}");
    // dlib's slip on the lower lip midpoint in frame 118 is iBUG point 57 (index 56).
    assert!(said.contains("frame 118: point 57 jumped"), "{said}");
    let eval = lipmap(&["eval", s(&session)]);
    let text = stdout(&eval);
    let conditions = "fit on F4 (51 points) · min–max scaled per sentence · W/H frontal ≤15°";
    assert!(text.contains(&format!("RMSE per sentence (video vs head) — {conditions}")), "{text}");
    let warned = String::from_utf8_lossy(&eval.stderr);
    // Frame 119 sits at the limit (yaw 14.95°, F4 fit), so a change in the solver's last
    // step can move it across.
    assert!(warned.contains("81 of 120 fitted frames turned past the pose limit"), "{warned}");
}
