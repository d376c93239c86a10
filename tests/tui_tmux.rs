//! End to end through a real terminal: tmux runs `lipmap tui` on a demo session; the test
//! moves a landmark, saves, quits, and checks the session file and the restored terminal.

mod common;

use std::process::Command;
use std::time::{Duration, Instant};

fn tmux(args: &[&str]) -> String {
    let out = Command::new("tmux").args(args).output().expect("tmux runs");
    String::from_utf8_lossy(&out.stdout).into_owned()
}

fn wait_for(what: &str, timeout: Duration, mut done: impl FnMut() -> bool) {
    let t0 = Instant::now();
    while !done() {
        assert!(t0.elapsed() < timeout, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(100));
    }
}

struct KillSession(String);

impl Drop for KillSession {
    fn drop(&mut self) {
        let _ = Command::new("tmux").args(["kill-session", "-t", &self.0]).output();
    }
}

#[test]
fn tui_moves_a_landmark_saves_and_restores_the_terminal() {
    if Command::new("tmux").arg("-V").output().is_err() {
        eprintln!("skipping: tmux is not installed (Debian package `tmux`)");
        return;
    }
    let bin = env!("CARGO_BIN_EXE_lipmap");
    let dir = tempfile::tempdir().unwrap();
    let session = common::demo_session(dir.path());
    let before: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&session).unwrap()).unwrap();

    let name = format!("lipmap-e2e-{}", std::process::id());
    let _kill = KillSession(name.clone());
    let shell = "env -i PATH=/usr/bin:/bin TERM=xterm-256color HOME=/tmp PS1=e2e-ready: bash --norc --noprofile";
    tmux(&["new-session", "-d", "-s", &name, "-x", "120", "-y", "40", shell]);
    let stty_file = dir.path().join("stty.txt");
    let send = |keys: &[&str]| {
        let mut args = vec!["send-keys", "-t", name.as_str()];
        args.extend_from_slice(keys);
        tmux(&args);
    };
    let cmd = format!("{bin} tui {}", session.display());
    send(&[&cmd, "Enter"]);
    let screen = || tmux(&["capture-pane", "-p", "-t", &name]);
    // The frames view names the selected point, e.g. "jaw 1" or "inner lip top".
    wait_for("the TUI to draw", Duration::from_secs(30), || {
        let s = screen();
        s.contains("frame") && s.contains('▀')
    });
    std::thread::sleep(Duration::from_millis(300));
    send(&["l"]);
    send(&["l"]);
    send(&["l"]);
    send(&["s"]);
    std::thread::sleep(Duration::from_millis(500));
    send(&["q"]);
    // Back at the shell: the terminal must be in cooked mode with echo again.
    wait_for("the TUI to exit", Duration::from_secs(15), || {
        let s = screen();
        !s.contains('▀') && s.contains("e2e-ready:")
    });
    send(&[&format!("stty -a > {}", stty_file.display()), "Enter"]);
    wait_for("stty to run", Duration::from_secs(10), || stty_file.exists());
    std::thread::sleep(Duration::from_millis(200));
    let stty = std::fs::read_to_string(&stty_file).unwrap();
    assert!(stty.contains(" icanon") && stty.contains(" echo"), "terminal left raw: {stty}");
    assert!(!screen().contains('▀'), "the alternate screen was not left:\n{}", screen());

    let after: serde_json::Value =
        serde_json::from_slice(&std::fs::read(&session).unwrap()).unwrap();
    let clip_before = &before["clips"][0];
    let clip_after = &after["clips"][0];
    assert_eq!(clip_before["tracked"], clip_after["tracked"], "the tracker's landmarks changed");
    let corrections = serde_json::to_string(&clip_after["corrections"]).unwrap();
    assert!(corrections.contains("\"corrected\""), "no corrected point saved: {corrections}");
}
