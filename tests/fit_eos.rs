//! The fit against eos: golden vectors of eos's functions on frame 0 (camera, affine matrix,
//! angles, linear shape fit) and accuracy on eos's synthetic test set at lipmap's defaults.
//!
//! Reads `../shared/peer/eos` in place and skips when it is absent. `sweep_settings`
//! (ignored) evaluates any setting on any set made by eos's `synthetic_eos_test.py`.

use lipmap::fit::camera::{self, OrthoPose};
use lipmap::fit::shape::{
    EOS_SIGMA_SQUARED, FrameObservations, LandmarkBasis, fit_coefficients_linear,
};
use lipmap::fit::{FitSettings, FrameFit, Solver, fit_clip, fitted_shape};
use lipmap::landmarks::{FrameLandmarks, LandmarkPoint, N_LANDMARKS};
use lipmap::math::{Matrix3, Point2, Point3, Real};
use lipmap::model::{LandmarkMap, MorphableModel};
use serde_json::Value;
use std::path::{Path, PathBuf};

fn json(path: &Path) -> Value {
    serde_json::from_str(&std::fs::read_to_string(path).unwrap()).unwrap()
}

fn floats(v: &Value) -> Vec<Real> {
    v.as_array().unwrap().iter().map(|x| x.as_f64().unwrap()).collect()
}

fn matrix(v: &Value) -> Vec<Vec<Real>> {
    v.as_array().unwrap().iter().map(floats).collect()
}

fn load_model(dir: &Path) -> MorphableModel {
    lipmap::io::npy_model::read_npy_folder(dir).unwrap()
}

/// eos's mapping (1-based iBUG id -> vertex) from the exported model folder, made 0-based.
fn load_map(dir: &Path) -> LandmarkMap {
    let j = json(&dir.join("landmarks_and_contours.json"));
    let to_vertex = j["ibug_to_sfm_vertex"]
        .as_object()
        .unwrap()
        .iter()
        .map(|(k, v)| (k.parse::<usize>().unwrap() - 1, v.as_u64().unwrap() as usize))
        .collect();
    LandmarkMap { to_vertex }
}

/// Relative difference `max|a − b| / max|b|`.
fn rel(a: &[Real], b: &[Real]) -> Real {
    assert_eq!(a.len(), b.len());
    let d = a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, Real::max);
    d / b.iter().map(|y| y.abs()).fold(0.0, Real::max)
}

struct Golden {
    model: MorphableModel,
    gold: Value,
    pairs: Vec<(usize, usize, Real)>,
    image_points: Vec<Point2>,
    height: Real,
}

fn golden() -> Option<Golden> {
    let eos = lipmap::testdata::shared("peer/eos")?;
    let model = load_model(&eos.join("model"));
    let gold = json(&eos.join("reference/golden_functions_frame0.json"));
    let ids: Vec<usize> =
        gold["ibug_ids"].as_array().unwrap().iter().map(|v| v.as_u64().unwrap() as usize).collect();
    let vids: Vec<usize> = gold["vertex_ids"]
        .as_array()
        .unwrap()
        .iter()
        .map(|v| v.as_u64().unwrap() as usize)
        .collect();
    let pairs = ids.iter().zip(&vids).map(|(&l, &v)| (l - 1, v, 1.0)).collect();
    let image_points =
        matrix(&gold["image_points"]).iter().map(|p| Point2::new(p[0], p[1])).collect();
    Some(Golden { model, gold, pairs, image_points, height: 720.0 })
}

impl Golden {
    fn mean_pose(&self) -> OrthoPose {
        let p3: Vec<Point3> =
            self.pairs.iter().map(|&(_, v, _)| self.model.mean_vertex(v).unwrap()).collect();
        camera::estimate_orthographic_pose(&self.image_points, &p3, self.height).unwrap()
    }
}

#[test]
fn camera_matches_eos_golden() {
    let Some(g) = golden() else { return };
    let pose = g.mean_pose();
    let e = &g.gold["estimate_orthographic_projection_linear"];
    let r_gold: Vec<Real> = matrix(&e["R"]).concat();
    let r: Vec<Real> =
        (0..3).flat_map(|i| (0..3).map(move |j| (i, j))).map(|(i, j)| pose.r[(i, j)]).collect();
    assert!(rel(&r, &r_gold) < 1e-4, "R {r:?} vs {r_gold:?}");
    for (name, v) in [("s", pose.s), ("tx", pose.tx), ("ty", pose.ty)] {
        let want = e[name].as_f64().unwrap();
        assert!(((v - want) / want).abs() < 1e-4, "{name} {v} vs {want}");
    }
    let aff = pose.affine_matrix(g.height);
    let aff_gold = matrix(&g.gold["get_3x4_affine_camera_matrix"]);
    for i in 0..2 {
        assert!(
            rel(&aff[i], &aff_gold[i]) < 1e-4,
            "affine row {i}: {:?} vs {:?}",
            aff[i],
            aff_gold[i]
        );
    }
    let (y, p, r) = pose.yaw_pitch_roll_deg();
    let ypr_gold = floats(&g.gold["rendering_params_ypr_deg"]);
    assert!(rel(&[y, p, r], &ypr_gold) < 1e-4, "ypr {:?} vs {ypr_gold:?}", [y, p, r]);
}

#[test]
fn linear_shape_fit_matches_eos_golden() {
    let Some(g) = golden() else { return };
    // eos's shape fit is given the affine matrix of the mean-shape camera and the mean as base.
    let pose = g.mean_pose();
    let basis = LandmarkBasis::from_vertices(&g.model, &g.pairs);
    let mut lm = FrameLandmarks::new(0, vec![LandmarkPoint::missing(); N_LANDMARKS]);
    for (&(l, _, _), p) in g.pairs.iter().zip(&g.image_points) {
        lm.points[l] = LandmarkPoint::tracked(p.x, p.y);
    }
    let obs = FrameObservations::new(&basis, &lm);
    let zeros = vec![0.0; basis.num_coefficients()];
    for lambda in [30.0, 3.0] {
        let a = fit_coefficients_linear(
            &basis,
            &obs,
            &pose,
            g.height,
            &zeros,
            0..basis.k_id,
            lambda,
            EOS_SIGMA_SQUARED,
        )
        .unwrap();
        let want = floats(&g.gold[format!("fit_shape_to_landmarks_linear_lambda{lambda}")]);
        let got: Vec<Real> = a.iter().copied().collect();
        let r = rel(&got, &want);
        assert!(r < 1e-4, "lambda {lambda}: relative difference {r:e}");
    }
}

/// A synthetic set written by eos's `synthetic_eos_test.py`.
pub struct SyntheticSet {
    pub frames: Vec<FrameLandmarks>,
    pub true_shapes: Vec<Vec<Real>>,
    pub true_r: Vec<Matrix3>,
    pub height: Real,
}

pub fn read_synthetic_set(dir: &Path) -> SyntheticSet {
    let tp = json(&dir.join("true_params.json"));
    let height = tp["H"].as_f64().unwrap();
    let n = tp["frames"].as_array().unwrap().len();
    let mut frames: Vec<FrameLandmarks> = (0..n)
        .map(|f| FrameLandmarks::new(f, vec![LandmarkPoint::missing(); N_LANDMARKS]))
        .collect();
    let text = std::fs::read_to_string(dir.join("landmarks.csv")).unwrap();
    for line in text.lines().skip(1) {
        let v: Vec<&str> = line.split(',').collect();
        let (f, id): (usize, usize) = (v[0].parse().unwrap(), v[1].parse().unwrap());
        frames[f].points[id - 1] =
            LandmarkPoint::tracked(v[2].parse().unwrap(), v[3].parse().unwrap());
    }
    let true_r = tp["frames"]
        .as_array()
        .unwrap()
        .iter()
        .map(|f| {
            let m = matrix(&f["R"]);
            Matrix3::from_fn(|i, j| m[i][j])
        })
        .collect();
    let arr = lipmap::io::npy_model::read_npy(&dir.join("frames_true_shapes.npy")).unwrap();
    let w = arr.shape[1];
    let true_shapes = arr.data.chunks(w).map(|c| c.to_vec()).collect();
    SyntheticSet { frames, true_shapes, true_r, height }
}

/// The judged figures: median mouth-vertex RMS (mm), mean inner-lip gap bias (mm), median
/// rotation error (degrees), plus the gap's mean absolute error.
#[derive(Debug)]
pub struct Figures {
    pub mouth_rms_mm: Real,
    pub gap_bias_mm: Real,
    pub gap_mae_mm: Real,
    pub rot_err_deg: Real,
    pub failed: usize,
}

fn median(mut v: Vec<Real>) -> Real {
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) }
}

/// Figures as eos's scripts compute them: `mouth18` = the mapped vertices of iBUG 49..68
/// (1-based), RMS of the 3D distance per frame, median over frames; the inner-lip gap is the
/// distance between the vertices of iBUG 63 and 67.
pub fn figures(
    model: &MorphableModel,
    map: &LandmarkMap,
    set: &SyntheticSet,
    fits: &[FrameFit],
) -> Figures {
    let mouth: Vec<usize> = (48..68).filter_map(|l| map.vertex(l)).collect();
    let (top, bottom) = (map.vertex(62).unwrap(), map.vertex(66).unwrap());
    let vtx = |s: &[Real], v: usize| Point3::new(s[3 * v], s[3 * v + 1], s[3 * v + 2]);
    let mut rms = Vec::new();
    let mut gaps = Vec::new();
    let mut rot = Vec::new();
    let mut failed = 0;
    for (f, fit) in fits.iter().enumerate() {
        if fit.failed.is_some() {
            failed += 1;
        }
        let shape = fitted_shape(model, fit);
        let s = shape.as_slice();
        let t = &set.true_shapes[f];
        let sse: Real = mouth.iter().map(|&v| (vtx(s, v) - vtx(t, v)).norm_squared()).sum();
        rms.push((sse / mouth.len() as Real).sqrt());
        let gap = |x: &[Real]| (vtx(x, top) - vtx(x, bottom)).norm();
        gaps.push(gap(s) - gap(t));
        let r = camera::rotation_from_yaw_pitch_roll_deg(fit.yaw, fit.pitch, fit.roll);
        rot.push(camera::rotation_angle_between_deg(&r, &set.true_r[f]));
    }
    Figures {
        mouth_rms_mm: median(rms),
        gap_bias_mm: gaps.iter().sum::<Real>() / gaps.len() as Real,
        gap_mae_mm: gaps.iter().map(|g| g.abs()).sum::<Real>() / gaps.len() as Real,
        rot_err_deg: median(rot),
        failed,
    }
}

#[test]
fn defaults_beat_eos_on_its_synthetic_set() {
    let Some(eos) = lipmap::testdata::shared("peer/eos") else { return };
    let model = load_model(&eos.join("model"));
    let map = load_map(&eos.join("model"));
    let set = read_synthetic_set(&eos.join("reference"));
    let settings = FitSettings { clip: true, ..FitSettings::default() };
    let fits = fit_clip(&model, &map, &set.frames, set.height, &settings, None);
    let fig = figures(&model, &map, &set, &fits);
    eprintln!("clip at defaults: {fig:?}");
    assert_eq!(fig.failed, 0);
    assert!(fig.mouth_rms_mm <= 2.0, "mouth RMS {} mm (eos 3.69)", fig.mouth_rms_mm);
    assert!(fig.gap_bias_mm.abs() <= 0.5, "inner-lip gap bias {} mm (eos +3.8)", fig.gap_bias_mm);
    assert!(fig.rot_err_deg <= 1.5, "rotation error {}° (eos 2.4)", fig.rot_err_deg);
}

#[test]
fn per_frame_defaults_are_no_worse_than_eos() {
    let Some(eos) = lipmap::testdata::shared("peer/eos") else { return };
    let model = load_model(&eos.join("model"));
    let map = load_map(&eos.join("model"));
    let set = read_synthetic_set(&eos.join("reference"));
    let settings = FitSettings { clip: false, ..FitSettings::default() };
    let fits = fit_clip(&model, &map, &set.frames, set.height, &settings, None);
    let fig = figures(&model, &map, &set, &fits);
    eprintln!("per frame at defaults: {fig:?}");
    assert_eq!(fig.failed, 0);
    assert!(fig.mouth_rms_mm <= 3.69 && fig.rot_err_deg <= 2.43, "{fig:?}");
}

/// Evaluates a grid of settings on sets made by eos's `synthetic_eos_test.py`:
/// `LIPMAP_SET_DIRS` (comma-separated, default eos's reference set) and `LIPMAP_GRID`, lines
/// `key=value,key=value` separated by `;` (keys: lambda, lexp, iters, clip, smooth, fset, pose).
#[test]
#[ignore]
fn sweep_settings() {
    let Some(eos) = lipmap::testdata::shared("peer/eos") else { return };
    let model = load_model(&eos.join("model"));
    let map = load_map(&eos.join("model"));
    let dirs: Vec<PathBuf> = std::env::var("LIPMAP_SET_DIRS")
        .map(|v| v.split(',').map(PathBuf::from).collect())
        .unwrap_or_else(|_| vec![eos.join("reference")]);
    let sets: Vec<SyntheticSet> = dirs.iter().map(|d| read_synthetic_set(d)).collect();
    let grid = std::env::var("LIPMAP_GRID").unwrap_or_default();
    for line in grid.split(';') {
        let mut s = FitSettings::default();
        for kv in line.split(',').filter(|kv| !kv.is_empty()) {
            let (k, v) = kv.split_once('=').unwrap();
            match k.trim() {
                "lambda" => s.lambda = v.parse().unwrap(),
                "lexp" => s.lambda_expression = v.parse().unwrap(),
                "iters" => s.iterations = v.parse().unwrap(),
                "clip" => s.clip = v == "1",
                "smooth" => s.temporal_smoothness = v.parse().unwrap(),
                "fset" => s.set = v.parse().unwrap(),
                "pose" => {
                    let steps: usize = v.parse().unwrap();
                    s.solver = match s.solver {
                        _ if steps == 0 => Solver::Alternating,
                        Solver::Joint { estimate_noise, .. } => {
                            Solver::Joint { pose_refinement_steps: steps, estimate_noise }
                        }
                        Solver::Alternating => {
                            Solver::Joint { pose_refinement_steps: steps, estimate_noise: true }
                        }
                    };
                }
                "tol" => s.convergence_tolerance = v.parse().unwrap(),
                "noise" => {
                    if let Solver::Joint { estimate_noise, .. } = &mut s.solver {
                        *estimate_noise = v == "1";
                    }
                }
                "nonneg" => s.nonnegative_expressions = v == "1",
                other => panic!("unknown key {other}"),
            }
        }
        for (dir, set) in dirs.iter().zip(&sets) {
            let fits = fit_clip(&model, &map, &set.frames, set.height, &s, None);
            let fig = figures(&model, &map, set, &fits);
            println!(
                "RESULT {:>10} [{line}] mouth={:.3} gap_bias={:+.3} gap_mae={:.3} rot={:.3} failed={} reproj={:.3}",
                dir.file_name().unwrap().to_string_lossy(),
                fig.mouth_rms_mm,
                fig.gap_bias_mm,
                fig.gap_mae_mm,
                fig.rot_err_deg,
                fig.failed,
                median(fits.iter().map(|f| f.reproj_rms_px).collect())
            );
        }
    }
}
