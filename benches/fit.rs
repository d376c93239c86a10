//! Fit speed on eos's synthetic test set (SFM model + 6 blendshapes, 60 frames, 50 mapped
//! landmarks) at lipmap's default settings, per frame and as a clip, against eos-py's 1.83 ms.
//!
//! `cargo bench --bench fit` prints the median time per frame and its ratio to eos's; when
//! `python3 -c "import eos"` works (or `LIPMAP_EOS_PYTHON` names such a python) it also times
//! eos-py live on the same frames. Skips when `../shared` is absent.

use criterion::{Criterion, criterion_group, criterion_main};
use lipmap::fit::{FitSettings, Fitter};
use lipmap::landmarks::{FrameLandmarks, LandmarkPoint, N_LANDMARKS};
use lipmap::model::{LandmarkMap, MorphableModel};
use std::hint::black_box;
use std::path::Path;
use std::time::Instant;

#[path = "common/eos_py.rs"]
mod eos_py;

/// eos-py's median time per frame on this set (fixed landmarks, 5 iterations), from
/// `peer/eos/reference/summary.json`.
const EOS_MS_PER_FRAME: f64 = 1.83;

struct Data {
    model: MorphableModel,
    map: LandmarkMap,
    frames: Vec<FrameLandmarks>,
    height: f64,
}

fn load(eos: &Path) -> Data {
    let model = lipmap::io::npy_model::read_npy_folder(&eos.join("model")).expect("model");
    let j: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(eos.join("model/landmarks_and_contours.json")).expect("map"),
    )
    .expect("map json");
    let to_vertex = j["ibug_to_sfm_vertex"]
        .as_object()
        .expect("map object")
        .iter()
        .map(|(k, v)| (k.parse::<usize>().expect("id") - 1, v.as_u64().expect("vertex") as usize))
        .collect();
    let text = std::fs::read_to_string(eos.join("reference/landmarks.csv")).expect("landmarks");
    let mut frames: Vec<FrameLandmarks> = Vec::new();
    for line in text.lines().skip(1) {
        let v: Vec<&str> = line.split(',').collect();
        let (f, id): (usize, usize) = (v[0].parse().expect("frame"), v[1].parse().expect("id"));
        while frames.len() <= f {
            frames.push(FrameLandmarks::new(
                frames.len(),
                vec![LandmarkPoint::missing(); N_LANDMARKS],
            ));
        }
        frames[f].points[id - 1] =
            LandmarkPoint::tracked(v[2].parse().expect("u"), v[3].parse().expect("v"));
    }
    Data { model, map: LandmarkMap { to_vertex }, frames, height: 720.0 }
}

/// Median over `reps` runs of `f`, in milliseconds.
fn median_ms(reps: usize, mut f: impl FnMut()) -> f64 {
    let mut t: Vec<f64> = (0..reps)
        .map(|_| {
            let t0 = Instant::now();
            f();
            t0.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    t.sort_by(|a, b| a.total_cmp(b));
    t[reps / 2]
}

/// This thread's CPU time in seconds (Linux `/proc/thread-self/stat`, 100 Hz ticks), so a
/// long loop can be timed without counting other processes on a busy machine.
fn thread_cpu_seconds() -> Option<f64> {
    let stat = std::fs::read_to_string("/proc/thread-self/stat").ok()?;
    let after = &stat[stat.rfind(')')? + 2..];
    let f: Vec<&str> = after.split_whitespace().collect();
    // Fields 14 and 15 (utime, stime) are at 11 and 12 after the command name.
    Some((f.get(11)?.parse::<f64>().ok()? + f.get(12)?.parse::<f64>().ok()?) / 100.0)
}

/// CPU milliseconds per call of `f` on this thread, over at least two CPU seconds.
fn cpu_ms_per_call(mut f: impl FnMut()) -> Option<f64> {
    let start = thread_cpu_seconds()?;
    let mut calls = 0usize;
    while thread_cpu_seconds()? - start < 2.0 {
        for _ in 0..10 {
            f();
        }
        calls += 10;
    }
    Some((thread_cpu_seconds()? - start) * 1e3 / calls as f64)
}

/// Times eos-py live on the same landmarks when it is importable; returns ms per frame.
fn eos_live_ms(eos: &Path) -> Option<f64> {
    let python = std::env::var("LIPMAP_EOS_PYTHON").unwrap_or_else(|_| "python3".into());
    let script = [
        r#"
import sys, csv, time, statistics, eos
share, lms = sys.argv[1], sys.argv[2]
"#,
        eos_py::LOAD_MODEL,
        r#"frames = {}
for r in csv.DictReader(open(lms)):
    frames.setdefault(int(r['frame']), []).append(eos.core.Landmark(r['ibug_id'], [float(r['u']), float(r['v'])]))
ts = []
for f in sorted(frames):
    for _ in range(5):
        t0 = time.perf_counter(); eos.fitting.fit_shape_and_pose(mm, frames[f], mapper, 1280, 720, num_iterations=5, lambda_identity=30.0); ts.append(time.perf_counter() - t0)
print(statistics.median(ts) * 1e3)
"#,
    ]
    .concat();
    let out = std::process::Command::new(python)
        .arg("-c")
        .arg(script)
        .arg(eos.join("share"))
        .arg(eos.join("reference/landmarks.csv"))
        .output()
        .ok()?;
    if !out.status.success() {
        return None;
    }
    String::from_utf8_lossy(&out.stdout).trim().parse().ok()
}

fn bench_fit(c: &mut Criterion) {
    let Some(eos) = lipmap::testdata::shared("peer/eos") else { return };
    let d = load(&eos);
    let n = d.frames.len() as f64;
    let eos_ms = eos_live_ms(&eos);
    for clip in [false, true] {
        let settings = FitSettings { clip, ..FitSettings::default() };
        let fitter = Fitter::new(&d.model, &d.map, &settings);
        let label = if clip { "clip" } else { "per-frame" };
        let ms = median_ms(31, || {
            black_box(fitter.fit_frames(black_box(&d.frames), d.height, None));
        }) / n;
        let single = median_ms(301, || {
            black_box(fitter.fit_frame(black_box(&d.frames[7]), d.height));
        });
        // Single-threaded CPU time per frame: the clip (or all frames) fitted on one thread.
        let pool = rayon::ThreadPoolBuilder::new().num_threads(1).build().expect("pool");
        let cpu = pool.install(|| {
            cpu_ms_per_call(|| {
                black_box(fitter.fit_frames(black_box(&d.frames), d.height, None));
            })
        });
        println!(
            "fit {label}: {ms:.4} ms/frame wall (total/frames, {} threads); one frame alone {single:.4} ms; \
             1-thread CPU {} ms/frame; eos {EOS_MS_PER_FRAME} ms -> ratio {:.3}{}",
            rayon::current_num_threads(),
            cpu.map_or("?".into(), |c| format!("{:.4}", c / n)),
            ms / EOS_MS_PER_FRAME,
            eos_ms.map_or(String::new(), |e| format!(
                "; eos-py live {e:.3} ms -> ratio {:.3}",
                ms / e
            )),
        );
        c.bench_function(&format!("fit_60_frames_{label}"), |b| {
            b.iter(|| fitter.fit_frames(black_box(&d.frames), d.height, None))
        });
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = bench_fit
}
criterion_main!(benches);
