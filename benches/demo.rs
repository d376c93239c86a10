//! Demo generation and rasteriser benchmarks: the whole `lipmap demo` (target ≤ 10 s on two
//! cores, release) timed once end to end, then the rasteriser on one demo frame (criterion).
//!
//! Run: `cargo bench --bench demo`. The demo is written into a temp folder with the default
//! options (1 speaker, 4 GRID sentences, 720×480 front and side PNGs, 161 poses + model).

use criterion::Criterion;
use lipmap::demo::{DemoOptions, demo_head, generate, visemes::Viseme};
use lipmap::math::Point3;
use lipmap::render::{Camera, RenderOptions, View, render_mesh};
use std::hint::black_box;
use std::time::Instant;

fn time_generate() {
    let dir = tempfile::tempdir().expect("temp dir");
    // LIPMAP_DEMO_KEEP=DIR keeps the output for inspection.
    let out_dir =
        std::env::var_os("LIPMAP_DEMO_KEEP").map_or_else(|| dir.path().to_path_buf(), Into::into);
    let opts = DemoOptions { out_dir, ..DemoOptions::default() };
    let start = Instant::now();
    let out = generate(&opts).expect("demo generates");
    let secs = start.elapsed().as_secs_f64();
    let frames: usize = out.speakers.iter().flat_map(|s| &s.clips).map(|c| c.n_frames).sum();
    println!(
        "demo/generate: {secs:.2} s for {frames} frames × 2 views, 161 poses + model, {} threads",
        rayon::current_num_threads()
    );
}

fn bench_render(c: &mut Criterion) {
    let (head, fields) = demo_head();
    let verts = fields.apply(&head.mesh.vertices, &Viseme::Aa.target());
    let tris = head.mesh.triangles();
    let cam = Camera::looking_at(
        View::Front,
        &lipmap::math::Matrix3::identity(),
        0.0,
        &Point3::new(0.0, -5.0, 70.0),
        1.75,
        720,
        480,
    );
    let opts = RenderOptions::default();
    c.bench_function("render/demo_head_720x480", |b| {
        b.iter(|| {
            black_box(render_mesh(&verts, &tris, &head.colours, &cam, &opts).expect("renders"))
        })
    });
}

fn main() {
    time_generate();
    let mut c = Criterion::default().configure_from_args().sample_size(20);
    bench_render(&mut c);
    c.final_summary();
}
