//! `lipmap profile` on a demo session: the proposed setup is stored, P comes out for every
//! frame, and a bad flag is refused without touching the session file.

use std::process::Command;

#[test]
fn profile_stores_its_setup_and_measures_every_frame() {
    let bin = env!("CARGO_BIN_EXE_lipmap");
    let dir = tempfile::tempdir().unwrap();
    let demo = dir.path().join("demo");
    let st = Command::new(bin)
        .args(["demo", "--no-tui", "--sentences", "1", "--out"])
        .arg(&demo)
        .output()
        .unwrap();
    assert!(st.status.success(), "{}", String::from_utf8_lossy(&st.stderr));
    let session = demo.join("demo.lipmap.json");

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
    let (_, rows) = doc.as_object().unwrap().iter().next().unwrap();
    let rows = rows.as_array().unwrap();
    assert!(rows.len() > 20);
    let measured = rows.iter().filter(|r| r["P"].is_number()).count();
    assert!(measured * 10 >= rows.len() * 9, "{measured} of {} frames measured", rows.len());
    assert!(std::fs::read_to_string(&session).unwrap().contains("profile_setup"));
}
