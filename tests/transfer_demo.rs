//! End to end: the demo speaker's fitted motion transferred onto the MakeHuman head
//! (`../shared/data/makehuman/`, landmark map `tests/fixtures/makehuman_ibug68.toml`), W
//! and H read on the head's own mouth landmarks, which are not landmark controls. The
//! transferred head's W and H follow the fitted model's: Pearson r ≥ 0.95 and an RMSE
//! of at most 5 % of the model's range (both series centred on their means, since the two
//! heads' proportions differ). Slow in a debug build (demo + fit + 2 setups): `#[ignore]`d;
//! run with `cargo test --release --test transfer_demo -- --ignored`.

use lipmap::demo::{DemoOptions, generate};
use lipmap::fit::{FitSettings, fit_clip, fitted_shape};
use lipmap::io::landmark_format::read_track;
use lipmap::io::model_source::load_model;
use lipmap::io::{landmark_map_toml::read_landmark_map, obj};
use lipmap::math::DVector;
use lipmap::measure::measure_points;
use lipmap::measure::mesh::frontal_landmarks;
use lipmap::model::LandmarkMap;
use lipmap::transfer::{Interpolation, SourceFace, TargetHead, Transfer, TransferOptions};
use std::path::Path;

fn wh(shape: &DVector, map: &LandmarkMap) -> (f64, f64) {
    let m = measure_points(&frontal_landmarks(shape, map)).unwrap();
    (m.w, m.h)
}

fn centred(x: &[f64]) -> Vec<f64> {
    let mean = x.iter().sum::<f64>() / x.len() as f64;
    x.iter().map(|v| v - mean).collect()
}

/// Pearson r and the RMSE over the range of `truth`, both series centred.
fn agreement(got: &[f64], truth: &[f64]) -> (f64, f64) {
    let (a, b) = (centred(got), centred(truth));
    let dot = |x: &[f64], y: &[f64]| x.iter().zip(y).map(|(p, q)| p * q).sum::<f64>();
    let r = dot(&a, &b) / (dot(&a, &a) * dot(&b, &b)).sqrt();
    let rmse =
        (a.iter().zip(&b).map(|(p, q)| (p - q).powi(2)).sum::<f64>() / a.len() as f64).sqrt();
    let range = truth.iter().cloned().fold(f64::NEG_INFINITY, f64::max)
        - truth.iter().cloned().fold(f64::INFINITY, f64::min);
    (r, rmse / range)
}

#[test]
#[ignore]
fn demo_motion_drives_makehuman_with_the_same_w_and_h() {
    let Some(dir) = lipmap::testdata::shared("data/makehuman") else { return };
    let tmp = tempfile::tempdir().unwrap();
    let opts = DemoOptions {
        out_dir: tmp.path().join("demo"),
        sentences: 2,
        write_frames: false,
        side_view: false,
        ..DemoOptions::default()
    };
    let out = generate(&opts).unwrap();
    let model = load_model(out.model.as_ref().unwrap(), None).unwrap();
    let source_map = read_landmark_map(&out.landmark_map).unwrap().with_commissures_completed();
    let head_path = dir.join("base.obj");
    let mesh = obj::read_obj(&head_path).unwrap();
    let skin = obj::labelable_vertices(&head_path).unwrap().unwrap();
    let fixture =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/makehuman_ibug68.toml");
    let target_map = read_landmark_map(&fixture).unwrap().with_commissures_completed();
    let settings = FitSettings::default();
    let mut shapes = Vec::new();
    for clip in &out.speakers[0].clips {
        let track = read_track(&clip.tracked_csv).unwrap();
        let fits =
            fit_clip(&model, &source_map, &track.frames, clip.height as f64, &settings, None);
        shapes.extend(fits.iter().filter(|f| f.failed.is_none()).map(|f| fitted_shape(&model, f)));
    }
    assert!(shapes.len() > 50, "{} fitted frames", shapes.len());
    // The demo head at rest (same vertex order as the model): the motion's reference.
    let reference = obj::read_obj(&out.head_obj).unwrap().to_flat();
    // The mouth landmarks (iBUG 49–68) are left out of the placement and of the landmark
    // controls, so the head's own mouth landmarks follow through the interpolation: with them
    // as controls W and H would be copied from the source by construction.
    let held_out = LandmarkMap {
        to_vertex: source_map
            .to_vertex
            .iter()
            .filter(|e| *e.0 < 48)
            .map(|(&l, &v)| (l, v))
            .collect(),
    };
    for mode in [Interpolation::Biharmonic, Interpolation::Barycentric] {
        let source = SourceFace {
            reference: &reference,
            triangles: &model.triangles,
            landmarks: &held_out,
            identity: None,
            face: None,
        };
        let target = TargetHead { mesh: &mesh, skin: &skin, landmarks: &target_map };
        let options = TransferOptions { interpolation: mode, ..TransferOptions::default() };
        let transfer = Transfer::new(source, target, &options).unwrap();
        let mouth: Vec<usize> = (48..68).filter_map(|l| target_map.vertex(l)).collect();
        let mouth_controls = transfer.target_controls.iter().filter(|v| mouth.contains(v)).count();
        let (mut src, mut dst) = ((Vec::new(), Vec::new()), (Vec::new(), Vec::new()));
        for s in &shapes {
            let (w, h) = wh(s, &source_map);
            src.0.push(w);
            src.1.push(h);
            let (w, h) = wh(&transfer.apply(s).unwrap(), &target_map);
            dst.0.push(w);
            dst.1.push(h);
        }
        let (rw, ew) = agreement(&dst.0, &src.0);
        let (rh, eh) = agreement(&dst.1, &src.1);
        println!(
            "{mode:?}: placement residual {:.4} dm; {mouth_controls} of {} mouth landmark vertices are (projected) controls; W r = {rw:.3}, NRMSE = {ew:.3}; H r = {rh:.3}, NRMSE = {eh:.3}",
            transfer.placement.residual,
            mouth.len()
        );
        if mode == Interpolation::Biharmonic {
            assert!(rw >= 0.95 && rh >= 0.95, "r: W {rw:.3}, H {rh:.3}");
            assert!(ew <= 0.05 && eh <= 0.05, "NRMSE: W {ew:.3}, H {eh:.3}");
        }
    }
}
