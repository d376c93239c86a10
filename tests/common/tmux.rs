//! A terminal for the TUI tests: a detached tmux session running a clean shell, keys sent
//! with `send-keys`, the screen read with `capture-pane`; killed when dropped.

use std::process::Command;
use std::time::{Duration, Instant};

/// Runs tmux with `args`, returning its standard output.
pub fn tmux(args: &[&str]) -> String {
    let out = Command::new("tmux").args(args).output().expect("tmux runs");
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// Whether tmux is installed (prints the skip notice when not).
pub fn available() -> bool {
    let ok = Command::new("tmux").arg("-V").output().is_ok();
    if !ok {
        eprintln!("skipping: tmux is not installed (Debian package `tmux`)");
    }
    ok
}

/// Polls `done` every 50 ms until it holds, failing the test after `timeout`.
pub fn wait_for(what: &str, timeout: Duration, mut done: impl FnMut() -> bool) {
    let t0 = Instant::now();
    while !done() {
        assert!(t0.elapsed() < timeout, "timed out waiting for {what}");
        std::thread::sleep(Duration::from_millis(50));
    }
}

/// A 120×40 tmux session named `name` running a bare bash whose prompt is `e2e-ready:`.
pub struct Term(pub String);

impl Term {
    pub fn new(name: &str) -> Self {
        let shell = "env -i PATH=/usr/bin:/bin TERM=xterm-256color HOME=/tmp PS1=e2e-ready: bash --norc --noprofile";
        tmux(&["new-session", "-d", "-s", name, "-x", "120", "-y", "40", shell]);
        Self(name.to_string())
    }

    /// Sends each of `keys` (tmux key names or literal text) in one command.
    pub fn send(&self, keys: &[&str]) {
        let mut args = vec!["send-keys", "-t", self.0.as_str()];
        args.extend_from_slice(keys);
        tmux(&args);
    }

    pub fn screen(&self) -> String {
        tmux(&["capture-pane", "-p", "-t", &self.0])
    }

    /// Waits until the TUI's frames view is drawn (half-block image and frame counter).
    pub fn wait_for_tui(&self) {
        wait_for("the TUI to draw", Duration::from_secs(30), || {
            let s = self.screen();
            s.contains("frame") && s.contains('▀')
        });
    }

    /// Waits for the shell prompt with the TUI gone, then checks with `stty -a` (written to
    /// `stty_file`) that the terminal is cooked with echo and that the main screen is back.
    pub fn assert_restored(&self, stty_file: &std::path::Path) {
        wait_for("the TUI to exit", Duration::from_secs(15), || {
            let s = self.screen();
            !s.contains('▀') && s.contains("e2e-ready:")
        });
        self.send(&[&format!("stty -a > {}", stty_file.display()), "Enter"]);
        wait_for("stty to run", Duration::from_secs(10), || {
            std::fs::read_to_string(stty_file).is_ok_and(|s| s.contains("echo"))
        });
        let stty = std::fs::read_to_string(stty_file).unwrap();
        assert!(stty.contains(" icanon") && stty.contains(" echo"), "terminal left raw: {stty}");
        assert!(!self.screen().contains('▀'), "the alternate screen was not left");
    }
}

impl Drop for Term {
    fn drop(&mut self) {
        let _ = Command::new("tmux").args(["kill-session", "-t", &self.0]).output();
    }
}
