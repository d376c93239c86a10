//! Transfer benchmarks on the real MakeHuman head (19,158 vertices, `../shared/data`):
//! setup (placement, projection, factoring the biharmonic system / binding vertices) and
//! one frame, in both interpolation modes. Targets: setup ≤ 2 s, a frame ≤ 2 ms.
//! Run: `cargo bench --bench transfer` (skips with a notice when the data is absent).

use criterion::Criterion;
use lipmap::io::makehuman_target::read_target;
use lipmap::io::{landmark_map_toml::read_landmark_map, obj};
use lipmap::transfer::projection::frontal_face_vertices;
use lipmap::transfer::{Interpolation, SourceFace, TargetHead, Transfer, TransferOptions};
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

fn main() {
    let Some(dir) = lipmap::testdata::shared("data/makehuman") else { return };
    let obj_path = dir.join("base.obj");
    let mesh = obj::read_obj(&obj_path).expect("base.obj");
    let skin = obj::labelable_vertices(&obj_path).expect("base.obj").unwrap_or_default();
    let map_path =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/makehuman_ibug68.toml");
    let map = read_landmark_map(&map_path).expect("fixture");
    let triangles: Vec<[u32; 3]> =
        mesh.triangles().into_iter().filter(|t| t.iter().all(|&v| skin[v as usize])).collect();
    let face = frontal_face_vertices(&mesh.vertices, &skin, &map).expect("face outline");
    let reference = mesh.to_flat();
    let jaw = read_target(&dir.join("faceunits/jawOpen.target")).expect("jawOpen");

    let mut c = Criterion::default()
        .sample_size(10)
        .measurement_time(Duration::from_secs(20))
        .configure_from_args();
    for mode in [Interpolation::Biharmonic, Interpolation::Barycentric] {
        let options = TransferOptions { interpolation: mode, ..TransferOptions::default() };
        let build = || {
            let source = SourceFace {
                reference: &reference,
                triangles: &triangles,
                landmarks: &map,
                identity: None,
                face: Some(&face),
            };
            let target = TargetHead { mesh: &mesh, skin: &skin, landmarks: &map };
            Transfer::new(source, target, &options).expect("setup")
        };
        c.bench_function(&format!("transfer setup, {mode:?}, 19k-vertex head"), |b| {
            b.iter(|| black_box(build()))
        });
        let transfer = build();
        let mut frame = reference.clone();
        for o in &jaw {
            for (k, dk) in o.delta.iter().enumerate() {
                frame[3 * o.vertex + k] += 0.7 * dk;
            }
        }
        c.bench_function(&format!("transfer frame, {mode:?}, 19k-vertex head"), |b| {
            b.iter(|| black_box(transfer.apply(black_box(&frame)).expect("frame")))
        });
    }
    c.final_summary();
}
