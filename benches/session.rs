//! Session open benchmark: `Session::load` + `FrameSource::open` on one 10,000-frame clip
//! (target ≤ 1 s and ≤ 200 MB), with peak memory measured in a fresh child process.
//!
//! Run: `cargo bench --bench session`. Setup (10,000 tiny PNGs and a session with 68 tracked
//! points on every frame, written to a temp folder) is outside the timed part. Peak memory is
//! the child's `VmHWM` from /proc/self/status, so the fixture-building parent does not count.

use criterion::Criterion;
use lipmap::io::frames::FrameSource;
use lipmap::landmarks::{FrameLandmarks, LandmarkPoint, N_LANDMARKS, Track};
use lipmap::session::{Clip, FramesRef, Session, View, open_view};
use std::hint::black_box;
use std::path::{Path, PathBuf};
use std::time::Instant;

const FRAMES: usize = 10_000;
const CHILD_ENV: &str = "LIPMAP_BENCH_SESSION_CHILD";

struct Fixture {
    _dir: tempfile::TempDir,
    session: PathBuf,
    json_bytes: u64,
}

fn create_fixture() -> Fixture {
    let dir = tempfile::tempdir().expect("temp dir");
    let frames = dir.path().join("frames");
    std::fs::create_dir_all(&frames).expect("frames dir");
    // One encoded 8x8 PNG copied 10,000 times: names without zero padding, so opening
    // also exercises the natural sort.
    let img =
        image::RgbImage::from_fn(8, 8, |x, y| image::Rgb([(x * 30) as u8, (y * 30) as u8, 128]));
    let first = frames.join("frame1.png");
    img.save(&first).expect("png");
    for i in 2..=FRAMES {
        std::fs::copy(&first, frames.join(format!("frame{i}.png"))).expect("copy png");
    }
    let session_path = dir.path().join("sessions").join("bench.lipmap.json");
    let mut s = Session::new(&session_path);
    let mut clip = Clip::new("s1_bbaf2n", View::new(FramesRef::Images { dir: frames }, 25.0));
    clip.front.size = Some([8, 8]);
    // Realistic sub-pixel coordinates (full f64 precision), a few hidden points.
    clip.set_tracked(Track::new(
        (0..FRAMES)
            .map(|f| {
                let pts = (0..N_LANDMARKS)
                    .map(|i| {
                        let t = f as f64 * 0.04 + i as f64;
                        let mut p = LandmarkPoint::tracked(
                            320.0 + 80.0 * t.sin(),
                            240.0 + 60.0 * (1.3 * t).cos(),
                        );
                        p.visible = (f + i) % 97 != 0;
                        p
                    })
                    .collect();
                FrameLandmarks::new(f, pts)
            })
            .collect(),
    ));
    let ci = s.add_clip(clip).expect("clip");
    for f in (0..FRAMES).step_by(50) {
        s.set_correction(ci, f, 62, LandmarkPoint::tracked(321.25, 250.5)).expect("correction");
    }
    s.save(&session_path).expect("save");
    let json_bytes = std::fs::metadata(&session_path).map(|m| m.len()).unwrap_or(0);
    Fixture { _dir: dir, session: session_path, json_bytes }
}

fn open_session(path: &Path) -> (Session, FrameSource) {
    let s = Session::load(path).expect("load");
    let frames = open_view(&s.clips[0].front, 256).expect("open frames");
    assert_eq!(frames.len(), FRAMES);
    (s, frames)
}

fn status_kb(field: &str) -> Option<u64> {
    let text = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = text.lines().find(|l| l.starts_with(field))?;
    line.split_whitespace().nth(1)?.parse().ok()
}

/// In the child: one open, then the peak resident size.
fn child(path: &Path) {
    let before = status_kb("VmRSS:").unwrap_or(0);
    let t = Instant::now();
    let opened = open_session(path);
    let secs = t.elapsed().as_secs_f64();
    let peak = status_kb("VmHWM:").unwrap_or(0);
    black_box(&opened);
    println!("{before} {peak} {secs}");
}

fn report_peak_memory(fx: &Fixture) {
    let exe = std::env::current_exe().expect("own path");
    let out =
        std::process::Command::new(exe).env(CHILD_ENV, &fx.session).output().expect("run child");
    let text = String::from_utf8_lossy(&out.stdout);
    let nums: Vec<f64> = text.split_whitespace().filter_map(|w| w.parse().ok()).collect();
    if let [before, peak, secs] = nums[..] {
        println!(
            "session open, {FRAMES} frames ({:.1} MB JSON): first open {:.0} ms in a fresh process; \
             peak RSS {:.1} MB (VmHWM; {:.1} MB before loading, so +{:.1} MB)",
            fx.json_bytes as f64 / 1e6,
            secs * 1e3,
            peak / 1024.0,
            before / 1024.0,
            (peak - before) / 1024.0
        );
    } else {
        println!("peak memory: child gave no figures (no /proc?): {text}");
    }
}

fn main() {
    if let Some(path) = std::env::var_os(CHILD_ENV) {
        child(Path::new(&path));
        return;
    }
    let fx = create_fixture();
    report_peak_memory(&fx);
    let mut c = Criterion::default().sample_size(10).configure_from_args();
    let mut group = c.benchmark_group("session");
    group.bench_function("load_and_open_10000_frames", |b| {
        b.iter_with_large_drop(|| open_session(black_box(&fx.session)))
    });
    group.bench_function("save_10000_frames", |b| {
        let (s, _) = open_session(&fx.session);
        let out = fx.session.with_file_name("copy.lipmap.json");
        b.iter(|| s.save(black_box(&out)).expect("save"))
    });
    group.finish();
    bench_video(&mut c);
    c.final_summary();
}

/// Opening (probe only) and decoding from the shared carphone video, when ffmpeg and the
/// shared data are present.
fn bench_video(c: &mut Criterion) {
    let Some(video) = lipmap::testdata::shared("data/carphone/carphone_pristine.mp4") else {
        return;
    };
    let opts = lipmap::io::frames::FrameOptions::default();
    if FrameSource::open(&video, &opts).is_err() {
        println!("skipping video benchmarks: ffmpeg/ffprobe missing (apt-get install ffmpeg)");
        return;
    }
    let mut group = c.benchmark_group("video");
    group.bench_function("open_carphone_probe", |b| {
        b.iter(|| FrameSource::open(black_box(&video), &opts).expect("open"))
    });
    // A cold chunk: a fresh source each time, so frame 60 needs one ffmpeg run (16 frames).
    group.bench_function("first_frame_of_a_cold_chunk", |b| {
        b.iter_with_setup(
            || FrameSource::open(&video, &opts).expect("open"),
            |src| src.get(black_box(60)).expect("frame").len(),
        )
    });
    group.finish();
}
