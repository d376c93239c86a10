//! Crash safety of the TUI through a real terminal (tmux): bursts of edits then `kill -9`
//! at random moments lose at most the last edit, and `export` and `eval` run after the crash
//! see them; TERM, INT and HUP save the edits, release the lock and restore the terminal; a
//! terminal that closes stops the editor without losing the edits or leaving the lock.

mod common;

use common::tmux::{Term, available, tmux, wait_for};
use lipmap::session::Session;
use rand::{Rng, SeedableRng};
use std::path::{Path, PathBuf};
use std::time::Duration;

/// A copy of the demo session beside it (so its relative paths hold) with nothing reviewed.
fn fresh_copy(demo: &Path, name: &str) -> PathBuf {
    let path = demo.with_file_name(format!("{name}.lipmap.json"));
    let mut s = Session::load(demo).unwrap();
    for c in &mut s.clips {
        c.corrections.reviewed.clear();
    }
    s.save(&path).unwrap();
    path
}

/// Reviewed frames of the first clip as a restarted editor would see them: the session
/// file with the journal replayed.
fn reviewed_after_restart(path: &Path) -> usize {
    let mut s = Session::load(path).unwrap();
    lipmap::session::journal::replay(&mut s, path).unwrap();
    s.clips[0].corrections.reviewed.len()
}

/// Starts `lipmap tui FILE` in the terminal's shell as `exec`, so the pane's process is
/// lipmap; returns its pid once the TUI is drawn.
fn start_tui(term: &Term, session: &Path, pid_file: &Path) -> u32 {
    let bin = env!("CARGO_BIN_EXE_lipmap");
    let _ = std::fs::remove_file(pid_file);
    let cmd =
        format!("bash -c 'echo $$ > {}; exec {bin} tui {}'", pid_file.display(), session.display());
    term.send(&[&cmd, "Enter"]);
    term.wait_for_tui();
    let pid = std::fs::read_to_string(pid_file).unwrap();
    pid.trim().parse().unwrap()
}

fn signal(pid: u32, sig: &str) {
    let st = std::process::Command::new("kill").args([sig, &pid.to_string()]).status().unwrap();
    assert!(st.success(), "kill {sig} {pid}");
}

fn gone(pid: u32) -> bool {
    !Path::new(&format!("/proc/{pid}")).exists()
}

#[test]
fn kill_9_at_random_moments_loses_at_most_the_last_edit() {
    if !available() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let demo = common::demo_session(dir.path());
    let frames = Session::load(&demo).unwrap().clips[0].tracked_summary().frames;
    let mut rng = rand::rngs::StdRng::seed_from_u64(0x5afe);
    let trials = 8;
    for trial in 0..trials {
        let session = fresh_copy(&demo, &format!("trial{trial}"));
        let term = Term::new(&format!("lipmap-kill-{}-{trial}", std::process::id()));
        let pid = start_tui(&term, &session, &dir.path().join("pid"));
        // Each edit marks a frame reviewed and moves on: the count of reviewed frames on
        // disk is the count of edits that survived.
        let mut sent = 0;
        for _ in 0..rng.random_range(1..=3) {
            let k = rng.random_range(3..=7).min(frames.saturating_sub(sent + 1));
            let keys: Vec<&str> = std::iter::repeat_n(["r", "n"], k).flatten().collect();
            term.send(&keys);
            sent += k;
            std::thread::sleep(Duration::from_millis(rng.random_range(20..250)));
        }
        // The last burst was sent 20–250 ms ago; kill now, somewhere in its processing,
        // its journaling or an autosave.
        signal(pid, "-KILL");
        wait_for("lipmap to die", Duration::from_secs(30), || gone(pid));
        let kept = reviewed_after_restart(&session);
        assert!(kept <= sent, "trial {trial}: {kept} edits on disk, {sent} made");
        assert!(sent - kept <= 1, "trial {trial}: {} of {sent} edits lost", sent - kept);
        drop(term);
    }
    // A restarted editor replays the journal and saves it into the session file.
    let session = demo.with_file_name(format!("trial{}.lipmap.json", trials - 1));
    let expected = reviewed_after_restart(&session);
    let term = Term::new(&format!("lipmap-kill-{}-reopen", std::process::id()));
    let pid = start_tui(&term, &session, &dir.path().join("pid"));
    wait_for("the restore notice", Duration::from_secs(30), || {
        term.screen().contains("restored the edits")
    });
    term.send(&["q"]);
    wait_for("lipmap to quit", Duration::from_secs(30), || gone(pid));
    let saved = Session::load(&session).unwrap();
    assert_eq!(saved.clips[0].corrections.reviewed.len(), expected, "the journal was not saved");
    assert!(!lipmap::session::journal::journal_path(&session).exists(), "journal left behind");
}

/// Runs the lipmap binary with `args`, failing the test when it does not exit 0; returns its
/// stderr.
fn lipmap(args: &[&std::ffi::OsStr]) -> String {
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_lipmap")).args(args).output().unwrap();
    let stderr = String::from_utf8_lossy(&out.stderr).into_owned();
    assert!(out.status.success(), "lipmap {args:?} failed: {stderr}");
    stderr
}

/// Frames with a hand-corrected point in the lipmap CSVs `export` wrote into `out`.
fn corrected_frames_exported(out: &Path) -> std::collections::BTreeSet<usize> {
    let mut frames = std::collections::BTreeSet::new();
    for entry in std::fs::read_dir(out.join("landmarks")).unwrap() {
        let text = std::fs::read_to_string(entry.unwrap().path()).unwrap();
        let mut lines = text.lines();
        let header: Vec<&str> = lines.next().unwrap().split(',').collect();
        let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
        let (frame, source) = (col("frame"), col("source"));
        for line in lines {
            let cells: Vec<&str> = line.split(',').collect();
            if cells[source] == "corrected" {
                frames.insert(cells[frame].parse().unwrap());
            }
        }
    }
    frames
}

/// A copy of the demo session with no edits at all, opened in the TUI, given a burst of
/// `n` edits on `n` frames (the selected point moved, then the next frame) and killed with
/// SIGKILL right after, before any autosave.
fn crashed_after_a_burst(dir: &Path, demo: &Path, name: &str, n: usize) -> PathBuf {
    let path = demo.with_file_name(format!("{name}.lipmap.json"));
    let mut s = Session::load(demo).unwrap();
    for c in &mut s.clips {
        c.corrections = Default::default();
    }
    s.save(&path).unwrap();
    let term = Term::new(&format!("lipmap-burst-{}-{name}", std::process::id()));
    let pid = start_tui(&term, &path, &dir.join("pid"));
    let keys: Vec<&str> = std::iter::repeat_n(["L", "n"], n).flatten().collect();
    term.send(&keys);
    // Time to take the keys in, far less than the autosave's pause.
    std::thread::sleep(Duration::from_millis(300));
    signal(pid, "-KILL");
    wait_for("lipmap to die", Duration::from_secs(30), || gone(pid));
    assert!(lipmap::session::journal::journal_path(&path).exists(), "no journal left");
    assert!(Session::load(&path).unwrap().clips[0].corrections.points.is_empty(), "autosaved");
    path
}

#[test]
fn export_and_eval_after_kill_9_see_the_edits_of_every_frame_but_the_last() {
    if !available() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let demo = common::demo_session(dir.path());
    let n = 6;

    // `export` straight after the crash: the landmarks it writes carry the edits.
    let session = crashed_after_a_burst(dir.path(), &demo, "burst-export", n);
    let out = dir.path().join("out");
    lipmap(&["export".as_ref(), session.as_os_str(), "--out".as_ref(), out.as_os_str()]);
    let corrected = corrected_frames_exported(&out);
    assert!(corrected.len() + 1 >= n && corrected.len() <= n, "edited frames {corrected:?}");
    assert!(corrected.iter().all(|&f| f < n), "{corrected:?}");

    // `eval` straight after the crash: says it restored them, and fits and measures them
    // (the fits it caches are of the edited landmarks).
    let session = crashed_after_a_burst(dir.path(), &demo, "burst-eval", n);
    let stderr = lipmap(&["eval".as_ref(), session.as_os_str()]);
    let restored = stderr
        .split("restored the edits of an editor that stopped without saving (")
        .nth(1)
        .and_then(|rest| rest.split(' ').next())
        .and_then(|count| count.parse::<usize>().ok());
    assert!(restored.is_some_and(|k| k + 1 >= n && k <= n), "{stderr}");
    let saved = Session::load(&session).unwrap();
    let edited: std::collections::BTreeSet<usize> =
        saved.clips[0].corrections.points.keys().copied().collect();
    assert!(edited.len() + 1 >= n && edited.len() <= n, "edited frames {edited:?}");
    assert!(
        saved.stale_frames(0).unwrap().is_empty(),
        "eval fitted other landmarks than the edited"
    );
    assert!(!lipmap::session::journal::journal_path(&session).exists(), "journal left behind");
}

#[test]
fn term_int_and_hup_save_unlock_and_restore_the_terminal() {
    if !available() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let demo = common::demo_session(dir.path());
    for sig in ["-TERM", "-INT", "-HUP"] {
        let session = fresh_copy(&demo, &format!("sig{}", &sig[1..]));
        let term = Term::new(&format!("lipmap-sig-{}-{}", std::process::id(), &sig[1..]));
        let pid_file = dir.path().join("pid");
        let bin = env!("CARGO_BIN_EXE_lipmap");
        // Not `exec`: the shell must come back to check the terminal.
        term.send(&[
            &format!(
                "bash -c 'echo $$ > {}; exec {bin} tui {}'",
                pid_file.display(),
                session.display()
            ),
            "Enter",
        ]);
        term.wait_for_tui();
        let pid: u32 = std::fs::read_to_string(&pid_file).unwrap().trim().parse().unwrap();
        term.send(&["r", "n", "r"]);
        // Sooner than the autosave's pause: only the signal's save puts these on disk.
        std::thread::sleep(Duration::from_millis(150));
        signal(pid, sig);
        wait_for("lipmap to stop", Duration::from_secs(30), || gone(pid));
        term.assert_restored(&dir.path().join(format!("stty{sig}.txt")));
        let saved = Session::load(&session).unwrap();
        assert_eq!(saved.clips[0].corrections.reviewed.len(), 2, "{sig}: edits not saved");
        assert!(
            !lipmap::session::store::lock_path(&session).exists(),
            "{sig}: the lock file was left"
        );
        assert!(!lipmap::session::journal::journal_path(&session).exists(), "{sig}: journal left");
        assert!(term.screen().contains("stopped by SIG"), "{sig}: {}", term.screen());
        let _ = tmux(&["kill-session", "-t", &term.0]);
    }
}

#[test]
fn a_closed_terminal_stops_the_editor_with_its_edits_and_lock_released() {
    if !available() {
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let demo = common::demo_session(dir.path());
    let session = fresh_copy(&demo, "hangup");
    // The terminal itself goes away, as when an SSH connection drops: the pane's pty closes
    // and the editor gets a HUP it may be unable to read through the dead terminal.
    let term = Term::new(&format!("lipmap-hangup-{}", std::process::id()));
    let pid = start_tui(&term, &session, &dir.path().join("pid"));
    term.send(&["r", "n", "r"]);
    wait_for("the edits to reach the journal", Duration::from_secs(30), || {
        reviewed_after_restart(&session) == 2
    });
    let _ = tmux(&["kill-session", "-t", &term.0]);
    wait_for("lipmap to stop", Duration::from_secs(30), || gone(pid));
    assert!(!lipmap::session::store::lock_path(&session).exists(), "the lock file was left");
    assert_eq!(reviewed_after_restart(&session), 2, "edits lost");
}
