//! `lipmap eval` at corpus scale: a session of about one GRID speaker (1,000 clips of 75
//! frames = 75,000 frames, 3 s sentences at 25 fps) with every fit cached, evaluated by the
//! use case the command line calls (open, load resources, fits from the cache, measure,
//! evaluate). Prints wall time and peak resident memory (VmHWM) against the targets
//! (≤ 10 s, ≤ 1 GB).
//!
//! `cargo bench --bench eval_corpus` (needs `../shared/peer/eos`: the SFM model, 3448
//! vertices, 63 identity and 6 expression coefficients). Each stage runs in its own process
//! so building the session does not count in the evaluation's peak memory:
//! `eval_corpus build DIR` writes the session, `eval_corpus eval DIR [meshes]` evaluates it
//! (`meshes`: the whole-mesh measuring path the use case had before, for comparison).

use lipmap::alignment::{Alignment, Phone};
use lipmap::fit::FrameFit;
use lipmap::landmarks::{FrameLandmarks, LandmarkPoint, N_LANDMARKS, Track};
use lipmap::session::{Clip, FramesRef, ModelRef, Session, View};
use lipmap::workflow::{self, HeadP, Normalisation, no_progress};
use rand::{Rng, SeedableRng};
use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Instant;

const CLIPS: usize = 1000;
const FRAMES: usize = 75;
const FPS: f64 = 25.0;
const PHONES: [&str; 10] = ["sil", "b", "ih", "n", "b", "l", "uw", "ae", "t", "sil"];

fn session_file(dir: &Path) -> PathBuf {
    dir.join("corpus.lipmap.json")
}

/// Peak resident set size of this process in MB (Linux `/proc/self/status` VmHWM).
fn peak_rss_mb() -> Option<f64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kb: f64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb / 1024.0)
}

/// Writes the corpus session: tracked landmarks (a mouth opening and closing around a fixed
/// face, with noise), a phone alignment per clip and one cached fit per frame (one identity
/// per speaker, expressions varying per frame).
fn build(dir: &Path, eos: &Path) {
    std::fs::create_dir_all(dir).unwrap();
    let path = session_file(dir);
    let mut session = Session::new(&path);
    session.model = Some(ModelRef {
        path: eos.join("share/sfm_shape_3448.bin"),
        blendshapes: Some(eos.join("share/expression_blendshapes_3448.bin")),
    });
    session.landmark_map.file = Some(eos.join("share/ibug_to_sfm.txt"));
    let settings = session.fit_settings.clone();
    let mut rng = rand::rngs::StdRng::seed_from_u64(11);
    let identity: Vec<f64> = (0..63).map(|_| rng.random_range(-1.0..1.0)).collect();
    let base: Vec<(f64, f64)> = (0..N_LANDMARKS)
        .map(|i| (300.0 + 6.0 * (i % 17) as f64, 200.0 + 9.0 * (i / 17) as f64))
        .collect();
    for c in 0..CLIPS {
        let frames_dir = dir.join(format!("clip_{c:04}"));
        let mut front = View::new(FramesRef::Images { dir: frames_dir }, FPS);
        front.size = Some([720, 576]);
        let mut clip = Clip::new(format!("s1_{c:04}"), front);
        let frames = (0..FRAMES)
            .map(|f| {
                let open = (std::f64::consts::PI * f as f64 / FRAMES as f64 * 4.0).sin().abs();
                let points = base
                    .iter()
                    .enumerate()
                    .map(|(i, &(x, y))| {
                        let dy = if (56..=59).contains(&i) || (65..=67).contains(&i) {
                            12.0 * open
                        } else {
                            0.0
                        };
                        LandmarkPoint::tracked(
                            x + rng.random_range(-0.5..0.5),
                            y + dy + rng.random_range(-0.5..0.5),
                        )
                    })
                    .collect();
                FrameLandmarks::new(f, points)
            })
            .collect();
        clip.set_tracked(Track::new(frames));
        let step = FRAMES as f64 / FPS / PHONES.len() as f64;
        clip.alignment = Some(Alignment {
            phones: PHONES
                .iter()
                .enumerate()
                .map(|(k, p)| Phone {
                    start: k as f64 * step,
                    end: (k + 1) as f64 * step,
                    label: p.to_string(),
                })
                .collect(),
        });
        session.add_clip(clip).unwrap();
        let fits = (0..FRAMES)
            .map(|f| FrameFit {
                identity: identity.clone(),
                expression: (0..6).map(|_| rng.random_range(-0.5..1.0)).collect(),
                scale: 1.0,
                reproj_rms_px: rng.random_range(0.5..2.0),
                ..FrameFit::unposed(f)
            })
            .collect();
        session.store_fits(c, &settings, fits).unwrap();
    }
    session.save(&path).unwrap();
}

/// The use case `lipmap eval SESSION` runs, timed, with the peak memory of this process.
fn eval(dir: &Path, whole_meshes: bool) {
    let t0 = Instant::now();
    let mut opened = workflow::open_for_read(session_file(dir).to_str().unwrap()).unwrap();
    let (res, _) = workflow::load_resources(&opened.session, &opened.path).unwrap();
    let t_load = t0.elapsed();
    let clips = workflow::select_clips(&opened.session, None).unwrap();
    let settings = opened.session.fit_settings.clone();
    let which =
        workflow::ClipsToMeasure { clips: &clips, head_p: HeadP::Mesh, pose: Default::default() };
    let mut done =
        workflow::utterances_with(&mut opened.session, &res, which, &settings, &no_progress)
            .unwrap();
    if whole_meshes {
        // The path before: every clip's fitted meshes built whole, then measured.
        let map = res.map.with_commissures_completed();
        for (u, (_, fits)) in done.utterances.iter_mut().zip(&done.fits) {
            let n = u.head.w.len();
            let shapes = workflow::shapes_by_frame(&res.model, fits, n);
            let head = lipmap::measure::mesh::trajectory_from_shapes(
                shapes.iter().map(|s| s.as_ref()),
                &map,
                &Default::default(),
            );
            assert_eq!(head.w, u.head.w, "{}: the two paths differ", u.name);
        }
    }
    assert!(opened.session.stale_frames_with(0, &settings).unwrap().is_empty(), "fits not cached");
    let report = workflow::evaluate(&done.utterances, &done.fit_refs(), Normalisation::MinMax, 10);
    let elapsed = t0.elapsed();
    let frames: usize = done.fits.iter().map(|(_, f)| f.len()).sum();
    let peak = peak_rss_mb().unwrap_or(f64::NAN);
    println!(
        "eval_corpus{}: {} clips, {frames} frames, {} phoneme rows: {:.2} s (session and model \
         load {:.2} s), peak RSS {peak:.0} MB; targets ≤ 10 s ({:.2}×), ≤ 1024 MB ({:.2}×)",
        if whole_meshes { " (whole meshes too)" } else { "" },
        done.utterances.len(),
        report.phonemes.rows.len(),
        elapsed.as_secs_f64(),
        t_load.as_secs_f64(),
        elapsed.as_secs_f64() / 10.0,
        peak / 1024.0,
    );
}

fn main() {
    let args: Vec<String> = std::env::args().skip(1).filter(|a| a != "--bench").collect();
    match args.first().map(String::as_str) {
        Some("build") => {
            let eos = lipmap::testdata::shared("peer/eos").expect("needs ../shared/peer/eos");
            build(Path::new(&args[1]), &eos);
        }
        Some("eval") => eval(Path::new(&args[1]), args.get(2).is_some_and(|a| a == "meshes")),
        _ => {
            if lipmap::testdata::shared("peer/eos").is_none() {
                return;
            }
            let dir =
                std::env::temp_dir().join(format!("lipmap_eval_corpus_{}", std::process::id()));
            let me = std::env::current_exe().unwrap();
            let run = |args: &[&str]| {
                let status = Command::new(&me).args(args).status().unwrap();
                assert!(status.success(), "{args:?} failed");
            };
            let d = dir.to_str().unwrap();
            let t = Instant::now();
            run(&["build", d]);
            println!("eval_corpus: session built in {:.1} s", t.elapsed().as_secs_f64());
            run(&["eval", d]);
            let _ = std::fs::remove_dir_all(&dir);
        }
    }
}
