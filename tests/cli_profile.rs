//! `lipmap profile` on a demo session: the proposed setup is stored, P comes out for every
//! frame, a bad flag is refused without touching the session file, and single frames'
//! upper-lip points are corrected and uncorrected, each printed row saying its source.

mod common;

use std::process::Command;

#[test]
fn profile_stores_its_setup_and_measures_every_frame() {
    let bin = env!("CARGO_BIN_EXE_lipmap");
    let dir = tempfile::tempdir().unwrap();
    let session = common::demo_session(dir.path());

    let bad = Command::new(bin)
        .arg("profile")
        .arg(&session)
        .args(["--crop", "1,2,0,4"])
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2));
    let err = String::from_utf8_lossy(&bad.stderr);
    assert!(err.contains("--crop needs a positive width and height"), "{err}");
    assert!(!std::fs::read_to_string(&session).unwrap().contains("profile_setup"));

    let ok = Command::new(bin).arg("profile").arg(&session).arg("--json").output().unwrap();
    assert!(ok.status.success(), "{}", String::from_utf8_lossy(&ok.stderr));
    let doc: serde_json::Value = serde_json::from_slice(&ok.stdout).unwrap();
    let profile = &doc["profile"][0];
    let rows = profile["rows"].as_array().unwrap();
    assert!(rows.len() > 20);
    let measured = rows.iter().filter(|r| r["P"].is_number()).count();
    assert!(measured * 10 >= rows.len() * 9, "{measured} of {} frames measured", rows.len());
    assert!(std::fs::read_to_string(&session).unwrap().contains("profile_setup"));
    assert!(rows.iter().all(|r| r["source"] == "automatic" || r["source"] == "failed"));
    let clip = profile["item"].as_str().unwrap().to_string();

    // A malformed correction is refused before anything is saved.
    let before = std::fs::read_to_string(&session).unwrap();
    let bad = Command::new(bin)
        .arg("profile")
        .arg(&session)
        .args(["--correct", "5:abc"])
        .output()
        .unwrap();
    assert_eq!(bad.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&bad.stderr).contains("FRAME:X,Y"));
    assert_eq!(std::fs::read_to_string(&session).unwrap(), before);
    // So is a point outside the side frame.
    let outside = Command::new(bin)
        .arg("profile")
        .arg(&session)
        .args(["--clip", &clip, "--correct", "5:-50,99999"])
        .output()
        .unwrap();
    assert_ne!(outside.status.code(), Some(0));
    let err = String::from_utf8_lossy(&outside.stderr);
    assert!(err.contains("outside the") && err.contains("side frame"), "{err}");
    assert_eq!(std::fs::read_to_string(&session).unwrap(), before);

    // Correct frames 5 and 7: their rows carry the given point, P moves with it.
    let run = |extra: &[&str]| -> Vec<serde_json::Value> {
        let o = Command::new(bin)
            .arg("profile")
            .arg(&session)
            .args(["--clip", &clip, "--json"])
            .args(extra)
            .output()
            .unwrap();
        assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
        let doc: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        doc["profile"][0]["rows"].as_array().unwrap().clone()
    };
    let auto5 = &rows[5];
    let (x5, y5) = (auto5["x"].as_f64().unwrap() + 6.0, auto5["y"].as_f64().unwrap());
    let corrected = run(&["--correct", &format!("5:{x5},{y5}"), "--correct", "7:401.25,300"]);
    assert_eq!(corrected[5]["source"], "corrected");
    assert_eq!(corrected[7]["source"], "corrected");
    assert_eq!(corrected[6]["source"], rows[6]["source"]);
    assert_eq!(corrected[5]["x"].as_f64().unwrap(), x5);
    assert_eq!(corrected[7]["x"].as_f64().unwrap(), 401.25);
    assert_eq!(corrected[6]["P"], rows[6]["P"]);
    // Six px further forward at the same row: P grows by 6 px over the nose length.
    let dp = corrected[5]["P"].as_f64().unwrap() - auto5["P"].as_f64().unwrap();
    assert!(dp > 0.05 && dp < 0.3, "P moved by {dp}");
    let text = std::fs::read_to_string(&session).unwrap();
    assert!(text.contains("profile_corrections"), "{text}");

    // The corrections persist: a plain run still shows them; then frame 5 is uncorrected.
    assert_eq!(run(&[])[7]["source"], "corrected");
    let undone = run(&["--uncorrect", "5"]);
    assert_eq!(undone[5]["source"], auto5["source"]);
    assert_eq!(undone[5]["P"], auto5["P"]);
    assert_eq!(undone[7]["source"], "corrected");

    // A frame past the side view's end is refused.
    let far = Command::new(bin)
        .arg("profile")
        .arg(&session)
        .args(["--correct", "100000:1,1"])
        .output()
        .unwrap();
    assert_eq!(far.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&far.stderr).contains("does not exist"));

    // The head's P from side renders: one P per sentence, like the mesh's; a wild pitch is
    // refused.
    let eval = |extra: &[&str]| {
        Command::new(bin).arg("eval").arg(&session).args(["--json"]).args(extra).output().unwrap()
    };
    for how in [&["--head-p", "mesh"][..], &["--head-p", "render", "--render-pitch", "-5"]] {
        let o = eval(how);
        assert!(o.status.success(), "{how:?}: {}", String::from_utf8_lossy(&o.stderr));
        let doc: serde_json::Value = serde_json::from_slice(&o.stdout).unwrap();
        let sentences = doc["sentences"]["rows"].as_array().unwrap();
        let p = sentences[0]["RMSE P"].as_f64().unwrap();
        assert!(p > 0.0 && p < 0.3, "{how:?}: RMSE P {p}");
    }
    let wild = eval(&["--head-p", "render", "--render-pitch", "100"]);
    assert_eq!(wild.status.code(), Some(2));
    assert!(String::from_utf8_lossy(&wild.stderr).contains("--render-pitch"));
}
