//! End to end through a real terminal: tmux runs `lipmap tui` on a demo session; the test
//! moves a landmark, saves, quits, and checks the session file and the restored terminal.

mod common;

use common::tmux::{Term, available};
use std::time::Duration;

#[test]
fn tui_moves_a_landmark_saves_and_restores_the_terminal() {
    if !available() {
        return;
    }
    let bin = env!("CARGO_BIN_EXE_lipmap");
    let dir = tempfile::tempdir().unwrap();
    let session = common::demo_session(dir.path());
    let before: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&session).unwrap()).unwrap();

    let term = Term::new(&format!("lipmap-e2e-{}", std::process::id()));
    term.send(&[&format!("{bin} tui {}", session.display()), "Enter"]);
    // The frames view names the selected point, e.g. "jaw 1" or "inner lip top".
    term.wait_for_tui();
    std::thread::sleep(Duration::from_millis(300));
    term.send(&["l"]);
    term.send(&["l"]);
    term.send(&["l"]);
    term.send(&["s"]);
    std::thread::sleep(Duration::from_millis(500));
    term.send(&["q"]);
    // Back at the shell: the terminal must be in cooked mode with echo again.
    term.assert_restored(&dir.path().join("stty.txt"));

    let after: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&session).unwrap()).unwrap();
    let clip_before = &before["clips"][0];
    let clip_after = &after["clips"][0];
    assert_eq!(clip_before["tracked"], clip_after["tracked"], "the tracker's landmarks changed");
    let corrections = serde_json::to_string(&clip_after["corrections"]).unwrap();
    assert!(corrections.contains("\"corrected\""), "no corrected point saved: {corrections}");
}
