//! Transfer benchmarks on the path `lipmap transfer` runs (`workflow::transfer`): the demo
//! speaker's model drives the MakeHuman head (`../shared/data/makehuman/base.obj`, map
//! `tests/fixtures/makehuman_ibug68.toml`) with the default 600 controls. Setup is
//! `set_up_for_head` (placement, projection, the biharmonic factor or the barycentric
//! bindings); a frame is `transfer_fits` on one fitted demo frame (the fitted shape, then
//! `Transfer::apply`), cycling through a clip's frames. Two heads: MakeHuman as it is
//! (19,158 vertices) and with every skin face subdivided once (the face four times denser,
//! over 20k vertices). Targets: setup ≤ 2 s, a frame ≤ 2 ms.
//! Run: `cargo bench --bench transfer` (skips with a notice when the data is absent).

#[path = "common/subdivide.rs"]
mod subdivide;

use criterion::Criterion;
use lipmap::demo::{DemoOptions, generate};
use lipmap::fit::{FitSettings, fit_clip};
use lipmap::io::landmark_format::read_track;
use lipmap::io::model_source::load_model;
use lipmap::io::{landmark_map_toml::read_landmark_map, obj};
use lipmap::transfer::Interpolation;
use lipmap::workflow::Resources;
use lipmap::workflow::transfer::{load_target, set_up_for_head, transfer_fits};
use std::hint::black_box;
use std::path::Path;
use std::time::Duration;

fn main() {
    let Some(dir) = lipmap::testdata::shared("data/makehuman") else { return };
    let tmp = tempfile::tempdir().expect("temporary folder");
    let opts = DemoOptions {
        out_dir: tmp.path().join("demo"),
        sentences: 1,
        write_frames: false,
        side_view: false,
        ..DemoOptions::default()
    };
    let demo = generate(&opts).expect("demo");
    let model = load_model(demo.model.as_ref().expect("demo model"), None).expect("model");
    let map = read_landmark_map(&demo.landmark_map).expect("demo map");
    let head = Some(obj::read_obj(&demo.head_obj).expect("demo head"));
    let res = Resources { model, map, head, head_map: None, accept_map_warnings: false };
    let clip = &demo.speakers[0].clips[0];
    let track = read_track(&clip.tracked_csv).expect("demo track");
    let settings = FitSettings::default();
    let fits = fit_clip(&res.model, &res.map, &track.frames, clip.height as f64, &settings, None);
    let fits: Vec<_> = fits.into_iter().filter(|f| f.failed.is_none()).collect();

    let base = dir.join("base.obj");
    let dense = tmp.path().join("base_subdivided.obj");
    let (text, vertices) =
        subdivide::subdivide_skin(&std::fs::read_to_string(&base).expect("base.obj"));
    std::fs::write(&dense, text).expect("subdivided head");
    let fixture =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/makehuman_ibug68.toml");

    let mut c = Criterion::default()
        .sample_size(10)
        .measurement_time(Duration::from_secs(20))
        .configure_from_args();
    for (path, label) in [(&base, "19,158".to_string()), (&dense, format!("{vertices}"))] {
        let target = load_target(path, &fixture).expect("head");
        for mode in [Interpolation::Biharmonic, Interpolation::Barycentric] {
            let name = |what: &str| format!("transfer {what}, {mode:?}, {label}-vertex head");
            let set_up = || set_up_for_head(&res, &target, mode, path).expect("setup");
            c.bench_function(&name("setup"), |b| b.iter(|| black_box(set_up())));
            let transfer = set_up();
            let mut k = 0;
            c.bench_function(&name("frame"), |b| {
                b.iter(|| {
                    k = (k + 1) % fits.len();
                    black_box(transfer_fits(&res, &transfer, &fits[k..=k]).expect("frame"))
                })
            });
        }
    }
    c.final_summary();
}
