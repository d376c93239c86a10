//! Memory on hostile and long inputs, through the release binary as a user runs it: the
//! issue's bound is under 1 GB of memory for an input under 1 MB, and memory that grows with
//! the data, never with a number read from a file.
//!
//! Inputs, all made here from the demo (4 sentences, no frames):
//! - `far`: the session with clip 0's last tracked frame moved to 900,000 (within the
//!   session's frame budget) and the fit cache dropped, as a hand edit would leave it;
//! - `over`: every clip's last tracked frame at 1,048,575 (past the budget: refused);
//! - a 62 s WAV (the demo voice repeated) animated by a speech model trained on the demo,
//!   carried onto the MakeHuman head when `../shared/data` is present.
//!
//! Each command's peak resident memory is read from `wait4`'s rusage; prints MB and the
//! ratio to the 1 GB bound. Run: `cargo bench --bench hostile`.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

const BOUND_MB: f64 = 1024.0;

/// Runs `lipmap args`, returning (exit code, peak RSS in MB, seconds).
// The child is reaped by `wait4`, which also gives its rusage; `Child::wait` cannot.
#[allow(clippy::zombie_processes)]
fn run(args: &[&str]) -> (i32, f64, f64) {
    let start = Instant::now();
    let child = Command::new(env!("CARGO_BIN_EXE_lipmap"))
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("lipmap runs");
    let pid = child.id() as libc::pid_t;
    let mut status = 0;
    // SAFETY: rusage is plain data that wait4 fills; the pid is our own child, reaped here
    // once (the `Child` is never waited on).
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let waited = unsafe { libc::wait4(pid, &mut status, 0, &mut usage) };
    assert_eq!(waited, pid, "wait4 failed");
    let code = if libc::WIFEXITED(status) { libc::WEXITSTATUS(status) } else { -1 };
    // Linux reports ru_maxrss in kilobytes.
    (code, usage.ru_maxrss as f64 / 1024.0, start.elapsed().as_secs_f64())
}

fn report(what: &str, input_bytes: u64, args: &[&str]) {
    let (code, mb, s) = run(args);
    println!(
        "hostile/{what} (input {:.0} KB, exit {code}): peak {mb:.0} MB in {s:.2} s (bound {BOUND_MB:.0} MB, ratio {:.3})",
        input_bytes as f64 / 1024.0,
        mb / BOUND_MB
    );
}

fn size(p: &Path) -> u64 {
    std::fs::metadata(p).map_or(0, |m| m.len())
}

fn s(p: &Path) -> &str {
    p.to_str().expect("UTF-8 temporary path")
}

/// The session at `from` with each listed clip's last tracked frame set to `frame` and
/// no fit cache, written to `to`.
fn edited(from: &Path, to: &Path, clips: &[usize], frame: u64) -> PathBuf {
    let mut v: serde_json::Value =
        serde_json::from_slice(&std::fs::read(from).expect("session")).expect("JSON");
    for &c in clips {
        let tracked = v["clips"][c]["tracked"].as_array_mut().expect("tracked frames");
        let last = tracked.last_mut().expect("a tracked frame");
        last["frame"] = serde_json::json!(frame);
    }
    v.as_object_mut().expect("object").remove("fit_cache");
    std::fs::write(to, serde_json::to_vec(&v).expect("JSON")).expect("write");
    to.to_path_buf()
}

fn main() {
    let tmp = tempfile::tempdir().expect("temporary folder");
    let demo = tmp.path().join("demo");
    let (code, _, _) =
        run(&["demo", "--no-tui", "--no-frames", "--sentences", "4", "--out", s(&demo)]);
    assert_eq!(code, 0, "demo");
    let session = demo.join("demo.lipmap.json");

    let far = edited(&session, &demo.join("far.lipmap.json"), &[0], 900_000);
    let out = tmp.path().join("out");
    let far_len = size(&far);
    report("far frame: eval", far_len, &["eval", s(&far)]);
    report("far frame: export --all", far_len, &["export", s(&far), "--out", s(&out), "--all"]);
    report("far frame: saqp markers", far_len, &["saqp", "markers", s(&far)]);
    let sp_far = tmp.path().join("sp_far.json");
    report(
        "far frame: speech train",
        far_len,
        &["speech", "train", s(&far), "--states", "2", "--mixtures", "1", "--out", s(&sp_far)],
    );
    let over = edited(&session, &demo.join("over.lipmap.json"), &[0, 1, 2, 3], 1_048_575);
    report("every clip at frame 2^20-1: eval (refused)", size(&over), &["eval", s(&over)]);

    // Long audio: the demo voice repeated to 62 s.
    let model = tmp.path().join("speech.json");
    let (code, _, _) = run(&["speech", "train", s(&session), "--out", s(&model)]);
    assert_eq!(code, 0, "speech train");
    let loaded = lipmap::session::Session::load(&session).expect("demo session");
    let voice = &loaded.clips[0].audio.as_ref().expect("demo audio").file;
    let audio = lipmap::io::wav::read_wav(voice).expect("demo voice");
    let seconds = 62.0;
    let n = (seconds * f64::from(audio.sample_rate)) as usize;
    let long: Vec<f32> = audio.samples.iter().copied().cycle().take(n).collect();
    let wav = tmp.path().join("long.wav");
    lipmap::io::wav::write_wav(&wav, &long, audio.sample_rate).expect("write WAV");
    let anim = tmp.path().join("anim");
    report(
        "speech animate 62 s",
        size(&wav),
        &["speech", "animate", s(&model), "--audio", s(&wav), "--out", s(&anim)],
    );
    let map = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/makehuman_ibug68.toml");
    match lipmap::testdata::shared("data/makehuman") {
        Some(dir) => report(
            "speech animate 62 s onto MakeHuman (19,158 vertices)",
            size(&wav),
            &[
                "speech",
                "animate",
                s(&model),
                "--audio",
                s(&wav),
                "--head",
                s(&dir.join("base.obj")),
                "--mapping",
                s(&map),
                "--out",
                s(&anim),
            ],
        ),
        None => println!("hostile: ../shared/data absent; the MakeHuman animation is skipped"),
    }
}
