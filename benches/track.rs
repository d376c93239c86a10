//! Tracking speed: lipmap's tracker (`workflow::track::track_images`, the loop `lipmap track`
//! runs: grey conversion, detection on the first frame, two cascade runs per frame) on the
//! demo's 720×480 front frames, decoded beforehand (decoding is excluded; ffmpeg or the PNG
//! decoder does it in `lipmap track`). Prints frames per second against the ≥ 100 target,
//! the cascade alone and a re-alignment (with the shape prior it needs), all from the CPU
//! time of the timing thread (`getrusage` `RUSAGE_THREAD`: user + system) and from the wall
//! clock. On a machine shared by other builds the wall clock counts the time the thread
//! waited for a core, so the CPU figure is the one the target is read on. Skips with a notice
//! without Debian's predictor and detector. Run: `cargo bench --bench track`.

use lipmap::demo::{DemoOptions, generate};
use lipmap::io::frames::{FrameOptions, FrameSource};
use lipmap::track::realign::realign_shape;
use lipmap::track::{
    CascadeStart, DEBIAN_CASCADE_PATH, DEBIAN_PREDICTOR_PATH, GrayImage, ShapePrior,
    box_from_shape, run_cascade,
};
use lipmap::workflow::no_progress;
use lipmap::workflow::track::{Tracked, Tracker, TrackerFiles, load_tracker, track_images};
use std::path::Path;
use std::time::Instant;

/// CPU seconds (user + system) this thread has used so far.
fn thread_cpu_seconds() -> f64 {
    // SAFETY: rusage is plain data that getrusage fills.
    let mut usage: libc::rusage = unsafe { std::mem::zeroed() };
    let ok = unsafe { libc::getrusage(libc::RUSAGE_THREAD, &mut usage) };
    assert_eq!(ok, 0, "getrusage failed");
    let secs = |t: libc::timeval| t.tv_sec as f64 + t.tv_usec as f64 * 1e-6;
    secs(usage.ru_utime) + secs(usage.ru_stime)
}

/// Runs `f` and returns its result with the CPU and wall seconds it took.
fn timed<T>(f: impl FnOnce() -> T) -> (T, f64, f64) {
    let (cpu, wall) = (thread_cpu_seconds(), Instant::now());
    let out = f();
    (out, thread_cpu_seconds() - cpu, wall.elapsed().as_secs_f64())
}

/// Times `track_images` over `frames` (best of three passes, grey conversion from RGB copies
/// included as in `lipmap track`), prints the figures against the target, returns the tracks.
fn time_tracking(tracker: &Tracker, label: &str, frames: &[GrayImage]) -> Tracked {
    let (w, h) = (frames[0].width, frames[0].height);
    let rgb: Vec<Vec<u8>> =
        frames.iter().map(|g| g.pixels.iter().flat_map(|&v| [v, v, v]).collect()).collect();
    let (mut best_cpu, mut best_wall) = (f64::INFINITY, f64::INFINITY);
    let mut tracked = None;
    for _ in 0..3 {
        let (r, cpu, wall) = timed(|| {
            track_images(
                tracker,
                rgb.len(),
                |i| Ok(GrayImage::from_rgb(w, h, &rgb[i])),
                &no_progress,
            )
            .expect("tracks")
        });
        best_cpu = best_cpu.min(cpu);
        best_wall = best_wall.min(wall);
        tracked = Some(r);
    }
    let r = tracked.expect("ran");
    let n = rgb.len() as f64;
    let fps = n / best_cpu;
    println!(
        "track: {label}: {} frames of {w}×{h}, best of 3: CPU {:.1} ms ({:.2} ms a frame, {fps:.0} frames/s: target ≥ 100 {}); wall {:.1} ms ({:.0} frames/s); detected on {} frames, lost {}",
        rgb.len(),
        best_cpu * 1e3,
        best_cpu * 1e3 / n,
        if fps >= 100.0 { "met" } else { "NOT met" },
        best_wall * 1e3,
        n / best_wall,
        r.detected.len(),
        r.lost.len()
    );
    r
}

fn main() {
    for f in [DEBIAN_PREDICTOR_PATH, DEBIAN_CASCADE_PATH] {
        if !Path::new(f).is_file() {
            println!("track: skipped, {f} not found (apt-get install libdlib-data opencv-data)");
            return;
        }
    }
    let t0 = Instant::now();
    let tracker = load_tracker(&TrackerFiles::default()).expect("Debian's predictor and detector");
    println!("track: predictor and detector read in {:.2} s", t0.elapsed().as_secs_f64());
    let dir = tempfile::tempdir().expect("temp dir");
    let opts = DemoOptions {
        out_dir: dir.path().join("demo"),
        sentences: 2,
        side_view: false,
        write_model: false,
        ..DemoOptions::default()
    };
    let out = generate(&opts).expect("demo");
    let mut frames: Vec<GrayImage> = Vec::new();
    for clip in &out.speakers[0].clips {
        let src = FrameSource::open(
            clip.front_dir.as_ref().expect("front frames"),
            &FrameOptions::default(),
        )
        .expect("demo frames");
        for i in 0..src.len() {
            let img = src.get(i).expect("decodes");
            frames.push(GrayImage::from_rgb(
                img.width() as usize,
                img.height() as usize,
                img.as_raw(),
            ));
        }
    }
    let r = time_tracking(&tracker, "demo front frames", &frames);
    let carphone = Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/data/carphone/frames");
    if carphone.is_dir() {
        let src = FrameSource::open(&carphone, &FrameOptions::default()).expect("carphone frames");
        let real: Vec<GrayImage> = (0..src.len())
            .map(|i| {
                let img = src.get(i).expect("decodes");
                GrayImage::from_rgb(img.width() as usize, img.height() as usize, img.as_raw())
            })
            .collect();
        time_tracking(&tracker, "carphone (real clip)", &real);
    } else {
        println!("track: carphone skipped, {} not found", carphone.display());
    }
    // One cascade run alone (the tracker makes two per frame).
    let shape: Vec<_> =
        r.track.frames[0].points.iter().map(|p| nalgebra::Vector2::new(p.x, p.y)).collect();
    let face = box_from_shape(&tracker.predictor.mean_shape, &shape).expect("a box");
    let reps = 500;
    let ((), cpu, wall) = timed(|| {
        for _ in 0..reps {
            std::hint::black_box(run_cascade(
                &tracker.predictor,
                frames[0].view(),
                &face,
                &CascadeStart::default(),
            ));
        }
    });
    println!(
        "track: one cascade run (15 stages × 500 trees): CPU {:.3} ms, wall {:.3} ms",
        cpu * 1e3 / reps as f64,
        wall * 1e3 / reps as f64
    );
    // A re-alignment (the TUI's `a`): the shape prior made once, then one run with the lower
    // lip's midline held and the other points carried.
    let (prior, cpu, wall) = timed(|| ShapePrior::of_predictor(&tracker.predictor));
    println!(
        "track: the shape prior for re-alignment (once per session): CPU {:.0} ms, wall {:.0} ms",
        cpu * 1e3,
        wall * 1e3
    );
    let held: Vec<_> =
        [57, 66].iter().map(|&i| (i, shape[i] + nalgebra::Vector2::new(0.0, 3.0))).collect();
    let ((), cpu, wall) = timed(|| {
        for _ in 0..reps {
            std::hint::black_box(realign_shape(
                &tracker.predictor,
                &prior,
                frames[0].view(),
                &shape,
                &held,
            ));
        }
    });
    println!(
        "track: one re-alignment (2 points held, the gains and the cascade): CPU {:.3} ms, wall \
         {:.3} ms",
        cpu * 1e3 / reps as f64,
        wall * 1e3 / reps as f64
    );
}
