//! Whole-process throughput of `lipmap fit` in files mode (the command users run: process
//! start, model load, fit, measures, `fit.csv` and `shapes.npy` with every frame's full mesh)
//! on eos's synthetic test set repeated to 1,000 frames, on one core, against eos-py's
//! library fit of the same frames in the same run.
//!
//! `cargo bench --bench fit_process` spawns the release binary cargo built for the bench with
//! `RAYON_NUM_THREADS=1`, pinned to CPU 0 with `taskset` where it exists, and reads its CPU
//! time (user + system, from `getrusage`) and wall time. eos-py is timed inside Python: only
//! its `fit_shape_and_pose` calls (fixed landmarks, 5 iterations, λ = 30, as in
//! `peer/eos/reference/summary.json`), each frame's landmark list built beforehand, so
//! Python's start-up, the model load and all file reading are left out of eos's time and
//! kept in lipmap's. Runs alternate between the two so both see the same machine load; the
//! medians are compared. eos-py is looked for as `LIPMAP_EOS_PYTHON` (a python with
//! `eos-py==1.5.0`), else `python3`; without it the bench compares with eos's recorded
//! median from `summary.json` and says so. `LIPMAP_FIT_PROCESS_RUNS` sets lipmap's runs
//! (default 7; eos-py gets up to 3). `LIPMAP_EOS_SET` names another synthetic set made by
//! eos's `synthetic_eos_test.py` (the folder holding its `landmarks.csv`; default
//! `peer/eos/reference`), to measure on a held-out seed. Each run times the command without
//! `--clip` (every frame its own identity, as eos fits) and with it (one identity for the
//! clip); each has its verdict. Skips when `../shared` is absent.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

#[path = "common/eos_py.rs"]
mod eos_py;

/// Frames in the benchmarked clip: eos's 60 frames cycled.
const FRAMES: usize = 1000;
/// The target: lipmap's whole process at least this many times eos-py's library fit.
const TARGET_RATIO: f64 = 10.0;

/// Writes eos's landmarks (`frame,ibug_id,u,v,…`, 1-based ids) as a lipmap landmark CSV of
/// `frames` frames, frame f holding eos frame f mod 60.
fn write_landmarks(eos_csv: &Path, out: &Path, frames: usize) {
    let text = std::fs::read_to_string(eos_csv).expect("eos landmarks");
    let mut by_frame: Vec<Vec<(usize, f64, f64)>> = Vec::new();
    for line in text.lines().skip(1) {
        let v: Vec<&str> = line.split(',').collect();
        let f: usize = v[0].parse().expect("frame");
        if by_frame.len() <= f {
            by_frame.resize(f + 1, Vec::new());
        }
        let id: usize = v[1].parse().expect("id");
        by_frame[f].push((id, v[2].parse().expect("u"), v[3].parse().expect("v")));
    }
    let mut csv = String::from("frame,point,x,y\n");
    for f in 0..frames {
        for &(id, u, v) in &by_frame[f % by_frame.len()] {
            csv.push_str(&format!("{f},{},{u},{v}\n", id - 1));
        }
    }
    std::fs::write(out, csv).expect("write landmarks");
}

/// The command, pinned to CPU 0 when `taskset` is available (RAYON_NUM_THREADS alone leaves
/// the main thread and the OS free to use the second core).
fn one_core(program: &Path, taskset: bool) -> Command {
    let mut c = if taskset {
        let mut c = Command::new("taskset");
        c.arg("-c").arg("0").arg(program);
        c
    } else {
        Command::new(program)
    };
    c.env("RAYON_NUM_THREADS", "1").env("OMP_NUM_THREADS", "1");
    c
}

/// CPU seconds (user + system) used so far by this process's waited-for children.
fn children_cpu_seconds() -> f64 {
    // SAFETY: rusage is plain data that getrusage fills.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let ok = unsafe { libc::getrusage(libc::RUSAGE_CHILDREN, &mut usage) };
    assert_eq!(ok, 0, "getrusage failed");
    let secs = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    secs(usage.ru_utime) + secs(usage.ru_stime)
}

/// Runs the command to completion; its stdout, wall and CPU seconds. Panics with its stderr
/// when it fails.
fn timed(mut cmd: Command) -> (String, f64, f64) {
    let cpu0 = children_cpu_seconds();
    let t0 = Instant::now();
    let out = cmd.output().expect("spawn");
    let wall = t0.elapsed().as_secs_f64();
    let cpu = children_cpu_seconds() - cpu0;
    assert!(out.status.success(), "{cmd:?} failed: {}", String::from_utf8_lossy(&out.stderr));
    (String::from_utf8_lossy(&out.stdout).into_owned(), wall, cpu)
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) }
}

/// eos-py's library fit timed call by call: load the model, blendshapes and map and build
/// every frame's landmark list first (untimed), fit five frames to warm up, then time each
/// `fit_shape_and_pose` call (CPU and wall) and print the medians and totals as JSON.
const EOS_SCRIPT: [&str; 3] = [
    r#"
import sys, csv, json, time
import eos
share, lms, w, h = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
"#,
    eos_py::LOAD_MODEL,
    r#"frames = {}
for r in csv.DictReader(open(lms)):
    frames.setdefault(int(r['frame']), []).append(
        eos.core.Landmark(str(int(r['point']) + 1), [float(r['x']), float(r['y'])]))
keys = sorted(frames)
def fit(k):
    return eos.fitting.fit_shape_and_pose(mm, frames[k], mapper, w, h, num_iterations=5,
                                          lambda_identity=30.0)
for k in keys[:5]:
    fit(k)
cpu, wall = [], []
for k in keys:
    c0, t0 = time.process_time(), time.perf_counter()
    fit(k)
    t1, c1 = time.perf_counter(), time.process_time()
    cpu.append(c1 - c0)
    wall.append(t1 - t0)
med = lambda v: sorted(v)[len(v) // 2]
print(json.dumps(dict(frames=len(keys), cpu_median=med(cpu), wall_median=med(wall),
                      cpu_total=sum(cpu), wall_total=sum(wall))))
"#,
];

/// The python that has eos-py, if any.
fn eos_python() -> Option<String> {
    let python = std::env::var("LIPMAP_EOS_PYTHON").unwrap_or_else(|_| "python3".into());
    let ok =
        Command::new(&python).args(["-c", "import eos"]).output().is_ok_and(|o| o.status.success());
    ok.then_some(python)
}

/// eos-py's median ms per frame recorded in the set's `summary.json` (fixed landmarks, 5
/// iterations).
fn recorded_eos_ms(set: &Path) -> Option<f64> {
    let text = std::fs::read_to_string(set.join("summary.json")).ok()?;
    let v: serde_json::Value = serde_json::from_str(&text).ok()?;
    v["variants"]["fixed_5it"]["median_fit_ms"].as_f64()
}

/// One eos-py run's per-frame figures (ms): median CPU and wall per call, mean CPU per call.
struct EosRun {
    cpu_median_ms: f64,
    wall_median_ms: f64,
    cpu_mean_ms: f64,
}

fn parse_eos(stdout: &str) -> EosRun {
    let line = stdout.lines().last().unwrap_or_default();
    let v: serde_json::Value = serde_json::from_str(line).expect("eos-py script output");
    let num = |k: &str| v[k].as_f64().expect("number in eos-py output");
    EosRun {
        cpu_median_ms: num("cpu_median") * 1e3,
        wall_median_ms: num("wall_median") * 1e3,
        cpu_mean_ms: num("cpu_total") * 1e3 / num("frames"),
    }
}

fn main() {
    // `cargo bench` passes `--bench`; a plain `cargo test --benches` run passes nothing and
    // should not spend a minute timing processes.
    if !std::env::args().any(|a| a == "--bench") {
        return;
    }
    let Some(eos) = lipmap::testdata::shared("peer/eos") else { return };
    let share = eos.join("share");
    let runs: usize = std::env::var("LIPMAP_FIT_PROCESS_RUNS")
        .ok()
        .and_then(|v| v.parse().ok())
        .filter(|&n| n > 0)
        .unwrap_or(7);
    let dir = tempfile::tempdir().expect("temp dir");
    let landmarks = dir.path().join("landmarks.csv");
    let set = std::env::var_os("LIPMAP_EOS_SET")
        .map(PathBuf::from)
        .unwrap_or_else(|| eos.join("reference"));
    println!("eos synthetic set: {}", set.display());
    write_landmarks(&set.join("landmarks.csv"), &landmarks, FRAMES);
    let taskset = Command::new("taskset").arg("-V").output().is_ok_and(|o| o.status.success());
    let lipmap = PathBuf::from(env!("CARGO_BIN_EXE_lipmap"));
    let out = dir.path().join("lipmap");
    // `--clip` (one identity for the clip, the mode README's command uses) or each frame
    // on its own (no `--clip`).
    let lipmap_cmd = |clip: bool| {
        let mut c = one_core(&lipmap, taskset);
        c.arg("fit")
            .arg("--model")
            .arg(share.join("sfm_shape_3448.bin"))
            .arg("--blendshapes")
            .arg(share.join("expression_blendshapes_3448.bin"))
            .arg("--mapping")
            .arg(share.join("ibug_to_sfm.txt"))
            .arg("--landmarks")
            .arg(&landmarks)
            .args(["--image-size", "1280x720", "--out"])
            .arg(&out);
        if clip {
            c.arg("--clip");
        }
        c
    };
    let python = eos_python().map(PathBuf::from);
    let script = dir.path().join("eos_fit.py");
    std::fs::write(&script, EOS_SCRIPT.concat()).expect("write script");
    let eos_cmd = |python: &Path| {
        let mut c = one_core(python, taskset);
        c.arg(&script).arg(&share).arg(&landmarks).args(["1280", "720"]);
        c
    };
    // Alternate the two so that both see the same load; eos-py takes seconds per run.
    let eos_runs = runs.min(3);
    let (mut cpu, mut wall, mut eos_runs_done) = (Vec::new(), Vec::new(), Vec::new());
    let mut per_frame_cpu = Vec::new();
    for r in 0..runs {
        let (_, w, c) = timed(lipmap_cmd(true));
        cpu.push(c);
        wall.push(w);
        per_frame_cpu.push(timed(lipmap_cmd(false)).2);
        if let Some(p) = python.as_deref().filter(|_| r < eos_runs) {
            eos_runs_done.push(parse_eos(&timed(eos_cmd(p)).0));
        }
    }
    let (cpu_ms, wall_ms) = (median(cpu) * 1e3 / FRAMES as f64, median(wall) * 1e3 / FRAMES as f64);
    let per_frame_ms = median(per_frame_cpu) * 1e3 / FRAMES as f64;
    let shapes = std::fs::metadata(out.join("shapes.npy")).map(|m| m.len()).unwrap_or(0);
    println!(
        "lipmap fit, whole process ({FRAMES} frames, --clip, RAYON_NUM_THREADS=1{}, median of \
         {runs}): {cpu_ms:.4} ms/frame CPU (user + sys), {wall_ms:.4} ms/frame wall; shapes.npy \
         {:.1} MB",
        if taskset { ", taskset -c 0" } else { "" },
        shapes as f64 / 1e6
    );
    println!(
        "lipmap fit, whole process, each frame on its own (no --clip, median of {runs}): \
         {per_frame_ms:.4} ms/frame CPU"
    );
    let verdict = |ratio: f64| if ratio >= TARGET_RATIO { "met" } else { "NOT met" };
    if eos_runs_done.is_empty() {
        let recorded = recorded_eos_ms(&set).unwrap_or(1.83);
        println!(
            "eos-py not importable (pip install eos-py==1.5.0, or set LIPMAP_EOS_PYTHON): \
             comparing with eos's recorded library fit, {recorded:.3} ms/frame \
             (the set's summary.json, median wall time of fit_shape_and_pose)"
        );
        let (ratio, per_frame) = (recorded / cpu_ms, recorded / per_frame_ms);
        println!(
            "ratio eos-py library (recorded) / lipmap whole process: each frame on its own \
             {per_frame:.1}x (target >= {TARGET_RATIO}x: {}); --clip {ratio:.1}x ({})",
            verdict(per_frame),
            verdict(ratio),
        );
        return;
    }
    let pick = |f: fn(&EosRun) -> f64| median(eos_runs_done.iter().map(f).collect());
    let (eos_cpu, eos_wall, eos_mean) =
        (pick(|r| r.cpu_median_ms), pick(|r| r.wall_median_ms), pick(|r| r.cpu_mean_ms));
    println!(
        "eos-py library fit_shape_and_pose ({FRAMES} frames, fixed landmarks, 5 iterations, \
         1 core, median of {} runs): {eos_cpu:.4} ms/frame CPU (median call; mean \
         {eos_mean:.4}), {eos_wall:.4} ms/frame wall (median call)",
        eos_runs_done.len()
    );
    // The smaller of the two CPU figures of eos-py (median call, mean call) is the fairer
    // to eos-py; the verdict uses it.
    let (ratio, per_frame) = (eos_cpu.min(eos_mean) / cpu_ms, eos_cpu.min(eos_mean) / per_frame_ms);
    println!(
        "ratio eos-py library / lipmap whole process (CPU time): each frame on its own \
         {per_frame:.1}x (target >= {TARGET_RATIO}x: {}); --clip {ratio:.1}x ({}; wall {:.1}x)",
        verdict(per_frame),
        verdict(ratio),
        eos_wall / wall_ms,
    );
}
