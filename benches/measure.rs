//! Measure and evaluation benchmarks at real sizes: W/H of one 68-point frame, W/H/P of one
//! 3,448-vertex shape (the SFM model's size), a 1,000-frame mesh trajectory, per-phoneme
//! RMSE and a 5-configuration comparison over 100 sentences. Run: `cargo bench --bench measure`.

use criterion::Criterion;
use lipmap::alignment::{Alignment, Phone};
use lipmap::eval::{Configuration, RowKey, Utterance, compare_configurations, phoneme_rmse};
use lipmap::landmarks::{FrameLandmarks, LandmarkPoint};
use lipmap::math::DVector;
use lipmap::measure::mesh::trajectory_from_shapes;
use lipmap::measure::{MeshMeasureOptions, Trajectory, measure_frame, measure_shape};
use lipmap::model::LandmarkMap;
use rand::{Rng, SeedableRng};
use std::hint::black_box;

const N_VERTICES: usize = 3448;

/// A random frontal face layout: only the measured points need to be sensible.
fn frame(rng: &mut impl Rng) -> FrameLandmarks {
    let mut pts: Vec<LandmarkPoint> = (0..68)
        .map(|_| LandmarkPoint::tracked(rng.random_range(0.0..640.0), rng.random_range(0.0..480.0)))
        .collect();
    pts[39] = LandmarkPoint::tracked(290.0, 200.0);
    pts[42] = LandmarkPoint::tracked(350.0, 200.0);
    pts[30] = LandmarkPoint::tracked(320.0, 260.0);
    FrameLandmarks::new(0, pts)
}

/// A random shape with landmark k on vertex 50·k (so lookups stride through memory).
fn shape(rng: &mut impl Rng) -> (DVector, LandmarkMap) {
    let mut s = DVector::from_fn(3 * N_VERTICES, |_, _| rng.random_range(-80.0..80.0));
    let set = |s: &mut DVector, v: usize, p: [f64; 3]| {
        s.fixed_rows_mut::<3>(3 * v).copy_from_slice(&p);
    };
    set(&mut s, 50 * 27, [0.0, 35.0, 12.0]);
    set(&mut s, 50 * 30, [0.0, 0.0, 30.0]);
    set(&mut s, 50 * 39, [-15.0, 30.0, 9.0]);
    set(&mut s, 50 * 42, [15.0, 30.0, 11.0]);
    let map = LandmarkMap { to_vertex: (0..68).map(|k| (k, 50 * k)).collect() };
    (s, map)
}

fn utterance(rng: &mut impl Rng, k: usize, fps: f64, frames: usize) -> Utterance {
    let labels = ["sil", "B", "IH1", "N", "B", "L", "UW1", "AE1", "T", "F", "sp"];
    let dur = frames as f64 / fps / labels.len() as f64;
    let phones = labels
        .iter()
        .enumerate()
        .map(|(i, l)| Phone {
            start: i as f64 * dur,
            end: (i + 1) as f64 * dur,
            label: l.to_string(),
        })
        .collect();
    let mut series = |n| (0..n).map(|_| Some(rng.random_range(0.0..1.0))).collect::<Vec<_>>();
    Utterance {
        name: format!("s{k}"),
        speaker: Some(format!("spk{}", k % 4)),
        alignment: Alignment { phones },
        fps,
        video: Trajectory { w: series(frames), h: series(frames), p: series(frames) },
        head: Trajectory { w: series(frames), h: series(frames), p: series(frames) },
    }
}

fn bench_measure(c: &mut Criterion) {
    let mut rng = rand::rngs::StdRng::seed_from_u64(7);
    let f = frame(&mut rng);
    let (s, map) = shape(&mut rng);
    let opts = MeshMeasureOptions::default();
    let shapes: Vec<DVector> = (0..1000).map(|_| s.clone()).collect();
    let mut g = c.benchmark_group("measure");
    g.bench_function("frame_w_h_68pts", |b| b.iter(|| measure_frame(black_box(&f))));
    g.bench_function("shape_w_h_p_3448v", |b| b.iter(|| measure_shape(black_box(&s), &map, &opts)));
    g.bench_function("trajectory_1000_shapes", |b| {
        b.iter(|| trajectory_from_shapes(shapes.iter().map(Some), &map, &opts))
    });
    g.finish();

    let utts: Vec<Utterance> = (0..100).map(|k| utterance(&mut rng, k, 25.0, 75)).collect();
    let configs: Vec<Configuration> = ["F1", "F2", "F3", "F4", "F5"]
        .iter()
        .map(|n| Configuration {
            name: n.to_string(),
            utterances: (0..100).map(|k| utterance(&mut rng, k, 25.0, 75)).collect(),
        })
        .collect();
    let phones = lipmap::alignment::PhoneInventory::default();
    let mut g = c.benchmark_group("eval");
    g.bench_function("phoneme_rmse_100_sentences", |b| {
        b.iter(|| phoneme_rmse(black_box(&utts), &phones))
    });
    g.bench_function("compare_5_configs_100_sentences", |b| {
        b.iter(|| compare_configurations(black_box(&configs), 3, RowKey::Sentence))
    });
    g.finish();
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    bench_measure(&mut c);
    c.final_summary();
}
