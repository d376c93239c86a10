//! Side-view protrusion benchmarks: one demo side frame (720×480, rendered once outside the
//! timed closures) measured with a fixed and with a head-following reference line, the
//! one-off automatic setup, and the head's P by render (`eval --head-p render`): one side
//! render of the demo head plus its measurement. Run: `cargo bench --bench profile`.

use criterion::Criterion;
use image::GrayImage;
use lipmap::demo::visemes::Viseme;
use lipmap::demo::{SIDE_BACKGROUND, demo_head};
use lipmap::math::{Matrix3, Point3, Vector3};
use lipmap::measure::profile::{
    Facing, ProfileSetup, measure_lip_profile, measure_render, propose_setup,
};
use lipmap::render::{Camera, RenderOptions, SideRenderer, View, render_mesh};
use std::hint::black_box;

/// A demo side frame as `lipmap demo` renders it (same camera and lighting).
fn side_frame() -> GrayImage {
    let (head, fields) = demo_head();
    let verts = fields.apply(&head.mesh.vertices, &Viseme::Uw.target());
    let cam = Camera::looking_at(
        View::Side,
        &Matrix3::identity(),
        0.0,
        &Point3::new(0.0, -5.0, 60.0),
        2.0,
        720,
        480,
    );
    let opts = RenderOptions {
        background: SIDE_BACKGROUND,
        light: Vector3::new(0.2, 0.3, 1.0),
        ambient: 0.6,
    };
    let img = render_mesh(&verts, &head.mesh.triangles(), &head.colours, &cam, &opts)
        .expect("demo head renders");
    image::imageops::grayscale(&img)
}

fn bench_profile(c: &mut Criterion) {
    let frame = side_frame();
    let anchored = propose_setup(&frame, Facing::Right).expect("demo frame has a profile");
    let fixed = ProfileSetup { anchor: None, ..anchored.clone() };
    let mut g = c.benchmark_group("profile");
    g.bench_function("measure_frame_fixed_line", |b| {
        b.iter(|| measure_lip_profile(black_box(&frame), &fixed).expect("measures"))
    });
    g.bench_function("measure_frame_following_head", |b| {
        b.iter(|| measure_lip_profile(black_box(&frame), &anchored).expect("measures"))
    });
    g.bench_function("propose_setup", |b| {
        b.iter(|| propose_setup(black_box(&frame), Facing::Right).expect("proposes"))
    });
    // One frame of `eval --head-p render`: render the posed head from the side (camera and
    // setup fixed once per clip, outside the timing) and measure the render.
    let (head, fields) = demo_head();
    let posed = fields.apply(&head.mesh.vertices, &Viseme::Uw.target());
    let triangles = head.mesh.triangles();
    let renderer = SideRenderer::new(&head.mesh.vertices, 0.0, Facing::Right, 720, 480)
        .expect("the demo head frames");
    let setup = renderer.profile_setup(&head.mesh.vertices, &head.landmarks).expect("sets up");
    g.bench_function("head_render_and_measure", |b| {
        b.iter(|| {
            let img = renderer.render(black_box(&posed), &triangles).expect("renders");
            measure_render(&img, &setup).expect("measures")
        })
    });
    g.finish();
}

fn main() {
    let mut c = Criterion::default().configure_from_args();
    bench_profile(&mut c);
    c.final_summary();
}
