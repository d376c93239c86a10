//! Model-building benchmarks: PCA of 161 poses × 6,000 vertices (target ≤ 1 s), the same
//! from a folder of 161 pose OBJs (parse + PCA), and loading eos's SFM `.bin` when present.
//!
//! Run: `cargo bench --bench model`. Poses are synthetic and seeded (20 smooth modes plus
//! small per-coordinate noise, so the data has full rank 160 like real scans); setup and
//! the OBJ files are made outside the timed part. The median of the PCA is printed with
//! its verdict against the target.

use criterion::Criterion;
use lipmap::io::model_source::build_model_from_obj_folder;
use lipmap::math::DVector;
use lipmap::model::Mesh;
use lipmap::model::pca::{Keep, build_pca_from_shapes, build_pca_with_summary};
use rand::{Rng, SeedableRng, rngs::StdRng};
use rand_distr::StandardNormal;
use std::hint::black_box;
use std::time::Instant;

const POSES: usize = 161;
const VERTICES: usize = 6_000;
const TARGET_S: f64 = 1.0;

fn synthetic_poses() -> Vec<DVector> {
    let mut rng = StdRng::seed_from_u64(2016);
    let d = 3 * VERTICES;
    let mean = DVector::from_fn(d, |i, _| ((i * 7919) % 1000) as f64 * 0.1);
    let modes: Vec<DVector> = (0..20)
        .map(|k| DVector::from_fn(d, |i, _| (i as f64 * 0.001 * (k + 1) as f64).sin()))
        .collect();
    (0..POSES)
        .map(|_| {
            let mut s = mean.clone();
            for (k, m) in modes.iter().enumerate() {
                let c: f64 = rng.sample::<f64, _>(StandardNormal) * 10.0 / (k + 1) as f64;
                s.axpy(c, m, 1.0);
            }
            for v in s.iter_mut() {
                *v += rng.sample::<f64, _>(StandardNormal) * 0.01;
            }
            s
        })
        .collect()
}

fn median_seconds(runs: usize, mut f: impl FnMut()) -> f64 {
    let mut t: Vec<f64> = (0..runs)
        .map(|_| {
            let start = Instant::now();
            f();
            start.elapsed().as_secs_f64()
        })
        .collect();
    t.sort_by(f64::total_cmp);
    t[runs / 2]
}

fn main() {
    let poses = synthetic_poses();
    let summary = build_pca_with_summary(&poses, Keep::default()).expect("pca");
    let pca = median_seconds(5, || {
        black_box(build_pca_from_shapes(black_box(&poses), Keep::default()).expect("pca"));
    });

    let dir = tempfile::tempdir().expect("temp dir");
    for (i, s) in poses.iter().enumerate() {
        let mesh = Mesh::from_flat(s.as_slice(), vec![]);
        lipmap::io::obj::write_obj(&dir.path().join(format!("pose_{i:03}.obj")), &mesh)
            .expect("write obj");
    }

    let mut c = Criterion::default().sample_size(10).configure_from_args();
    let mut g = c.benchmark_group("model");
    g.bench_function("pca_161x6000_gram", |b| {
        b.iter(|| build_pca_from_shapes(black_box(&poses), Keep::default()).expect("pca"))
    });
    g.bench_function("pca_from_161_obj_files", |b| {
        b.iter(|| {
            build_model_from_obj_folder(black_box(dir.path()), Keep::default()).expect("load")
        })
    });
    if let Some(bin) = lipmap::testdata::shared("peer/eos/share/sfm_shape_3448.bin") {
        g.bench_function("load_eos_sfm_bin", |b| {
            b.iter(|| lipmap::io::eos_bin::read_eos_model(black_box(&bin)).expect("bin"))
        });
    }
    g.finish();
    c.final_summary();

    let folder = median_seconds(3, || {
        black_box(build_model_from_obj_folder(dir.path(), Keep::default()).expect("load"));
    });
    println!(
        "PCA of {POSES} poses x {VERTICES} vertices: median {:.3} s (target <= {TARGET_S} s: {}); \
         {} components keep {:.1} % of the variance",
        pca,
        if pca <= TARGET_S { "met" } else { "MISSED" },
        summary.model.num_components(),
        100.0 * summary.variance_explained()
    );
    println!("Same from {POSES} OBJ files (parse + PCA): median {folder:.3} s");
}
