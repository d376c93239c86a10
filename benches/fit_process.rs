//! Whole-process throughput of `lipmap fit` in files mode (the command users run: process
//! start, model load, fit, measures, `fit.csv` and `shapes.npy` with every frame's full mesh)
//! on eos's synthetic test set repeated to 1,000 frames, on one core, against eos-py fitting
//! and writing the same frames in the same run.
//!
//! `cargo bench --bench fit_process` spawns the release binary cargo built for the bench with
//! `RAYON_NUM_THREADS=1` and pinned to one CPU where `taskset` exists, prints its wall and CPU
//! time per frame (CPU time is what compares on a shared machine), and, when `python3 -c "import eos, numpy"` works (or `LIPMAP_EOS_PYTHON` names such a
//! python), eos-py's and the ratio; without eos-py it says so and reports lipmap alone. Skips
//! when `../shared` is absent. `LIPMAP_FIT_PROCESS_RUNS` sets the runs per side (default 5; the
//! median is reported, whole processes being noisy on a shared machine).

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

#[path = "common/eos_py.rs"]
mod eos_py;

/// Frames in the benchmarked clip: eos's 60 frames cycled.
const FRAMES: usize = 1000;
/// The target: at least this many times eos-py's throughput.
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

/// CPU seconds (user + system) of this process's waited-for children, from
/// `/proc/self/stat` (cutime, cstime; 100 Hz ticks). None off Linux.
fn children_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/self/stat").ok()?;
    let after = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = after.split_whitespace().collect();
    // Fields 16 and 17 (cutime, cstime) are at 13 and 14 after the command name.
    Some((f.get(13)?.parse::<f64>().ok()? + f.get(14)?.parse::<f64>().ok()?) / 100.0)
}

/// Wall-clock and CPU seconds of one whole process.
#[derive(Clone, Copy)]
struct Timing {
    wall: f64,
    cpu: Option<f64>,
}

/// The run with the median CPU time (wall time when CPU time is unavailable) of `runs` runs of
/// the command `make()` builds; panics with its stderr when it fails. CPU time is the figure
/// that compares on a shared machine: wall time also counts waiting for the core.
fn median_run(runs: usize, mut make: impl FnMut() -> Command) -> Timing {
    let mut t: Vec<Timing> = (0..runs)
        .map(|_| {
            let mut cmd = make();
            let cpu0 = children_cpu_seconds();
            let t0 = Instant::now();
            let out = cmd.output().expect("spawn");
            let wall = t0.elapsed().as_secs_f64();
            assert!(
                out.status.success(),
                "{:?} failed: {}",
                cmd,
                String::from_utf8_lossy(&out.stderr)
            );
            let cpu = children_cpu_seconds().zip(cpu0).map(|(b, a)| b - a);
            Timing { wall, cpu }
        })
        .collect();
    t.sort_by(|a, b| a.cpu.unwrap_or(a.wall).total_cmp(&b.cpu.unwrap_or(b.wall)));
    t[runs / 2]
}

/// `"W ms wall, C ms CPU = c ms/frame, F frames/s"` for one timing of `FRAMES` frames, and
/// the seconds the throughput is computed from (CPU when known).
fn describe(t: Timing) -> (String, f64) {
    let basis = t.cpu.unwrap_or(t.wall);
    let cpu = t.cpu.map_or("CPU time unknown".into(), |c| format!("{:.0} ms CPU", c * 1e3));
    let text = format!(
        "{:.0} ms wall, {cpu} = {:.4} ms/frame, {:.0} frames/s",
        t.wall * 1e3,
        basis * 1e3 / FRAMES as f64,
        FRAMES as f64 / basis
    );
    (text, basis)
}

/// eos-py doing what `lipmap fit` does: load the model, blendshapes and map, read the
/// landmark CSV, fit every frame (eos's fixed landmarks, 5 iterations, λ = 30, as in
/// `peer/eos/reference/summary.json`), write one pose row per frame and every frame's mesh.
const EOS_SCRIPT: [&str; 3] = [
    r#"
import sys, csv
import numpy as np
import eos
share, lms, out, w, h = sys.argv[1], sys.argv[2], sys.argv[3], int(sys.argv[4]), int(sys.argv[5])
"#,
    eos_py::LOAD_MODEL,
    r#"frames = {}
for r in csv.DictReader(open(lms)):
    frames.setdefault(int(r['frame']), []).append(
        eos.core.Landmark(str(int(r['point']) + 1), [float(r['x']), float(r['y'])]))
keys = sorted(frames)
meshes = None
with open(out + '/fit.csv', 'w') as f:
    f.write('frame,yaw,pitch,roll\n')
    for n, k in enumerate(keys):
        mesh, pose, a, b = eos.fitting.fit_shape_and_pose(mm, frames[k], mapper, w, h,
                                                          num_iterations=5, lambda_identity=30.0)
        v = np.asarray(mesh.vertices, dtype=np.float32).reshape(-1)
        if meshes is None:
            meshes = np.empty((len(keys), v.size), dtype=np.float32)
        meshes[n] = v
        y, p, r = pose.get_yaw_pitch_roll()
        f.write('%d,%.6f,%.6f,%.6f\n' % (k, y, p, r))
np.save(out + '/shapes.npy', meshes)
"#,
];

/// The python that has eos-py and numpy, if any.
fn eos_python() -> Option<String> {
    let python = std::env::var("LIPMAP_EOS_PYTHON").unwrap_or_else(|_| "python3".into());
    let ok = Command::new(&python)
        .args(["-c", "import eos, numpy"])
        .output()
        .is_ok_and(|o| o.status.success());
    ok.then_some(python)
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
        .unwrap_or(5);
    let dir = tempfile::tempdir().expect("temp dir");
    let landmarks = dir.path().join("landmarks.csv");
    write_landmarks(&eos.join("reference/landmarks.csv"), &landmarks, FRAMES);
    let taskset = Command::new("taskset").arg("-V").output().is_ok_and(|o| o.status.success());
    let lipmap = PathBuf::from(env!("CARGO_BIN_EXE_lipmap"));

    let out = dir.path().join("lipmap");
    let lipmap_t = median_run(runs, || {
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
            .args(["--image-size", "1280x720", "--clip", "--out"])
            .arg(&out);
        c
    });
    let shapes = std::fs::metadata(out.join("shapes.npy")).map(|m| m.len()).unwrap_or(0);
    let (text, lipmap_s) = describe(lipmap_t);
    println!(
        "lipmap fit (whole process, {FRAMES} frames, clip, 1 core{}, median of {runs}): {text}; \
         shapes.npy {:.1} MB",
        if taskset { ", taskset" } else { "" },
        shapes as f64 / 1e6
    );

    let Some(python) = eos_python() else {
        println!(
            "eos-py not importable (pip install eos-py==1.5.0 numpy, or set LIPMAP_EOS_PYTHON): \
             no side-by-side ratio; the target is {TARGET_RATIO}x eos-py's ~1.83 ms/frame, i.e. \
             <= {:.3} ms/frame",
            1.83 / TARGET_RATIO
        );
        return;
    };
    let script = dir.path().join("eos_fit.py");
    std::fs::write(&script, EOS_SCRIPT.concat()).expect("write script");
    let eos_out = dir.path().join("eos");
    std::fs::create_dir_all(&eos_out).expect("eos out");
    let python = PathBuf::from(python);
    // eos-py takes seconds per run; three runs are enough for its median.
    let eos_runs = runs.min(3);
    let eos_t = median_run(eos_runs, || {
        let mut c = one_core(&python, taskset);
        c.arg(&script).arg(&share).arg(&landmarks).arg(&eos_out).args(["1280", "720"]);
        c
    });
    let (text, eos_s) = describe(eos_t);
    println!(
        "eos-py (whole process, {FRAMES} frames, fixed landmarks, 5 iterations, 1 core, median \
         of {eos_runs}): {text}"
    );
    let ratio = eos_s / lipmap_s;
    println!(
        "throughput ratio lipmap/eos-py ({}): {ratio:.1}x (target >= {TARGET_RATIO}x: {})",
        if lipmap_t.cpu.is_some() { "CPU time" } else { "wall time" },
        if ratio >= TARGET_RATIO { "met" } else { "NOT met" }
    );
}
