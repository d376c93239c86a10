//! How far `map suggest` lands from reference landmarks on faces it was not tuned on, each
//! placed four ways (as given; turned 30° and moved; z-up; facing −z and moved): six labels
//! (chin, nose tip, outer eye corners, mouth corners: the vertices nearest the reference
//! landmarks 9, 31, 37, 46, 49, 55) and the carphone frame `lipmap map suggest` picks by
//! default (frame 0) suggest the rest.
//!
//! The faces (docs/labelling.md, "Measured on held-out faces"):
//! - SFM identities sampled from eos's Surrey Face Model (seeds 11–30 by default; 1–10 are
//!   the ones looked at while choosing the method, `LIPMAP_SFM_SEEDS=1-10`; coefficients drawn
//!   from the model's own normal prior), reference = eos's `ibug_to_sfm.txt` vertices (no
//!   jaw but the chin: the jaw is reported as the distance to eos's frontal contour);
//! - MakeHuman identities: `base.obj` with random weights on its chin, head and mouth shape
//!   targets (seeds 1–5), reference = `tests/fixtures/makehuman_ibug68.toml`;
//! - scans with human 3D landmarks in `$LIPMAP_FACE_SCANS` (`NAME.obj` + `NAME.lm`, 68 lines
//!   `x y z` in mm, iBUG order), when set: every one there, grouped by the name up to its
//!   first `_` (docs/labelling.md says which faces chose the rules and which are held out:
//!   menpo3d's `james` and `template` chose them, ICT-FaceKit's `ict*` faces are held out).
//!
//! The suggestions are matched to the head's own face (drawn, read by dlib's shape
//! predictor) when the predictor is installed, as `map suggest` does; with
//! `LIPMAP_HELDOUT_FRAME=N` (or no predictor) to carphone's frame N, the older method.
//!
//! Run: `cargo test --release --test map_suggest_heldout -- --ignored --nocapture`.
//! Skips what is absent; asserts that no vertex is used twice and at least 55 of 62 are
//! suggested.

mod common;
use common::to_polyline;

use lipmap::fit::map_suggest::{suggest_map, suggest_map_on_own_face};
use lipmap::fit::suggest::{SuggestHead, surface_triangles};
use lipmap::io::landmark_format::read_track;
use lipmap::io::landmark_map_toml::read_landmark_map;
use lipmap::io::{makehuman_target, model_source, obj};
use lipmap::landmarks::FrameLandmarks;
use lipmap::math::{Matrix3, Point3, Vector3};
use lipmap::model::LandmarkMap;
use lipmap::track::{DEBIAN_PREDICTOR_PATH, ShapePredictor, read_shape_predictor};
use rand::{Rng, SeedableRng};
use std::path::{Path, PathBuf};

/// Carphone's frames are 176 × 144.
const IMAGE_HEIGHT: f64 = 144.0;
/// The hand labels, 0-based: chin, nose tip, outer eye corners, mouth corners.
const LABELS: [usize; 6] = [8, 30, 36, 45, 48, 54];

/// A face with its reference landmarks (model units) and how many mm a unit is.
struct Face {
    name: String,
    vertices: Vec<Point3>,
    triangles: Vec<[u32; 3]>,
    eligible: Option<Vec<bool>>,
    reference: Vec<Option<Point3>>,
    /// The jaw's reference when the landmarks lack it: the frontal contour's two sides.
    contour: Option<(Vec<Point3>, Vec<Point3>)>,
    mm_per_unit: f64,
}

/// One placement's figures.
struct Figures {
    suggested: usize,
    shared: usize,
    off_mm: Vec<(usize, f64)>,
    /// Suggested minus reference, in the reference's face axes (mm): x left, y up, z out.
    signed_mm: Vec<(usize, Vector3)>,
    jaw_contour_mm: Vec<f64>,
    left: Vec<String>,
}

fn quantile(x: &[f64], q: f64) -> f64 {
    let mut x = x.to_vec();
    x.sort_by(f64::total_cmp);
    if x.is_empty() {
        return f64::NAN;
    }
    x[((x.len() - 1) as f64 * q).round() as usize]
}

fn nearest(vertices: &[Point3], eligible: Option<&[bool]>, p: &Point3) -> usize {
    (0..vertices.len())
        .filter(|&v| eligible.is_none_or(|e| e[v]))
        .min_by(|&a, &b| (vertices[a] - p).norm().total_cmp(&(vertices[b] - p).norm()))
        .unwrap()
}

/// The rigid placements every face is tried in: rotation and translation (in face sizes).
fn placements() -> Vec<(&'static str, Matrix3, Vector3)> {
    let rot = |axis: Vector3, deg: f64| {
        *nalgebra::Rotation3::from_axis_angle(
            &nalgebra::Unit::new_normalize(axis),
            deg.to_radians(),
        )
        .matrix()
    };
    vec![
        ("as given", Matrix3::identity(), Vector3::zeros()),
        (
            "yaw 30°, moved",
            rot(Vector3::y(), 30.0) * rot(Vector3::x(), -10.0),
            Vector3::new(3.0, -1.0, 2.0),
        ),
        ("z-up", rot(Vector3::x(), 90.0), Vector3::zeros()),
        ("facing -z, moved", rot(Vector3::y(), 180.0), Vector3::new(-2.0, 5.0, 1.0)),
    ]
}

/// What the suggestions are matched to: the head's own face drawn and read by the shape
/// predictor (what `map suggest` does when the predictor is installed), or a video frame.
enum Source<'a> {
    OwnFace(&'a ShapePredictor),
    Frame(&'a FrameLandmarks),
}

fn evaluate(face: &Face, source: &Source, r: &Matrix3, t: &Vector3) -> Figures {
    let size = lipmap::transfer::surface::bounding_diagonal(&face.vertices);
    let place = |p: &Point3| Point3::from(r * p.coords + t * size);
    let vertices: Vec<Point3> = face.vertices.iter().map(place).collect();
    let reference: Vec<Option<Point3>> =
        face.reference.iter().map(|p| p.map(|p| place(&p))).collect();
    let eligible = face.eligible.as_deref();
    let mut labels = LandmarkMap::default();
    for l in LABELS {
        labels.to_vertex.insert(l, nearest(&vertices, eligible, &reference[l].unwrap()));
    }
    let head = SuggestHead { vertices: &vertices, triangles: &face.triangles, eligible };
    let proposal = match source {
        Source::OwnFace(predictor) => suggest_map_on_own_face(&head, &labels, predictor),
        Source::Frame(frame) => suggest_map(&head, &labels, frame, IMAGE_HEIGHT, None),
    }
    .unwrap();
    let map = proposal.applied_to(&labels);
    let mut used: Vec<usize> = map.to_vertex.values().copied().collect();
    let n = used.len();
    used.sort_unstable();
    used.dedup();
    let off_mm = proposal
        .accepted
        .iter()
        .filter_map(|s| {
            Some((
                s.landmark,
                (vertices[s.vertex] - reference[s.landmark]?).norm() * face.mm_per_unit,
            ))
        })
        .collect();
    let jaw_contour_mm = match &face.contour {
        Some((right, left)) => {
            let right: Vec<Point3> = right.iter().map(place).collect();
            let left: Vec<Point3> = left.iter().map(place).collect();
            proposal
                .accepted
                .iter()
                .filter(|s| s.landmark < 17 && s.landmark != 8)
                .map(|s| {
                    let side = if s.landmark < 8 { &right } else { &left };
                    to_polyline(&vertices[s.vertex], side) * face.mm_per_unit
                })
                .collect()
        }
        None => Vec::new(),
    };
    let left = proposal.left.iter().map(|(l, why)| format!("{}: {why}", l + 1)).collect();
    let known: std::collections::BTreeMap<usize, Point3> =
        reference.iter().enumerate().filter_map(|(l, p)| Some((l, (*p)?))).collect();
    let axes = lipmap::model::map_check::face_axes(&known).unwrap_or_else(Matrix3::identity);
    let signed_mm = proposal
        .accepted
        .iter()
        .filter_map(|s| {
            Some((
                s.landmark,
                axes * (vertices[s.vertex] - reference[s.landmark]?) * face.mm_per_unit,
            ))
        })
        .collect();
    Figures {
        suggested: proposal.accepted.len(),
        shared: n - used.len(),
        off_mm,
        signed_mm,
        jaw_contour_mm,
        left,
    }
}

fn report(face: &Face, source: &Source) -> Vec<f64> {
    let mut all = Vec::new();
    for (name, r, t) in placements() {
        let f = evaluate(face, source, &r, &t);
        let d: Vec<f64> = f.off_mm.iter().map(|x| x.1).collect();
        let jaw: Vec<f64> = f.off_mm.iter().filter(|x| x.0 < 17).map(|x| x.1).collect();
        let rest: Vec<f64> = f.off_mm.iter().filter(|x| x.0 >= 17).map(|x| x.1).collect();
        eprintln!(
            "{:<22} {:<17} suggested {:>2}/62 shared {} | all median {:>4.1} p90 {:>4.1} max {:>5.1} mm (n {}) | jaw median {:>4.1} p90 {:>4.1} | rest median {:>4.1} p90 {:>4.1}{}",
            face.name,
            name,
            f.suggested,
            f.shared,
            quantile(&d, 0.5),
            quantile(&d, 0.9),
            quantile(&d, 1.0),
            d.len(),
            quantile(&jaw, 0.5),
            quantile(&jaw, 0.9),
            quantile(&rest, 0.5),
            quantile(&rest, 0.9),
            if f.jaw_contour_mm.is_empty() {
                String::new()
            } else {
                format!(
                    " | jaw to eos contour median {:.1} p90 {:.1}",
                    quantile(&f.jaw_contour_mm, 0.5),
                    quantile(&f.jaw_contour_mm, 0.9)
                )
            }
        );
        if std::env::var_os("LIPMAP_HELDOUT_VERBOSE").is_some() && name == "as given" {
            for ((l, mm), (_, d)) in f.off_mm.iter().zip(&f.signed_mm) {
                eprintln!(
                    "    {:>2} {mm:>5.1}  x {:>5.1} y {:>5.1} z {:>5.1}",
                    l + 1,
                    d.x,
                    d.y,
                    d.z
                );
            }
            for why in &f.left {
                eprintln!("    left {why}");
            }
        }
        assert_eq!(f.shared, 0, "{}: no vertex twice", face.name);
        assert!(f.suggested >= 55, "{} {name}: {} of 62 suggested", face.name, f.suggested);
        all.extend(d);
    }
    all
}

/// The carphone frame `map suggest` picks by default (frame 0: the first with all 68
/// landmarks), or frame `N` with `LIPMAP_HELDOUT_FRAME=N`.
fn carphone() -> Option<FrameLandmarks> {
    let pts = lipmap::testdata::shared("data/carphone/dlib68_pts")?;
    let frames = read_track(&pts).unwrap().frames;
    let n = std::env::var("LIPMAP_HELDOUT_FRAME").ok().and_then(|v| v.parse::<usize>().ok());
    Some(frames.iter().find(|f| f.frame == n.unwrap_or(0)).unwrap().clone())
}

fn sfm_faces(seeds: std::ops::RangeInclusive<u64>) -> Vec<Face> {
    let Some(eos) = lipmap::testdata::shared("peer/eos") else { return Vec::new() };
    let model = model_source::load_model(&eos.join("share/sfm_shape_3448.bin"), None).unwrap();
    let map = read_landmark_map(&eos.join("share/ibug_to_sfm.txt")).unwrap();
    let contours: serde_json::Value = serde_json::from_str(
        &std::fs::read_to_string(eos.join("model/landmarks_and_contours.json")).unwrap(),
    )
    .unwrap();
    let side = |v: &[Point3], s: &str| -> Vec<Point3> {
        contours["model_contour"][s]
            .as_array()
            .unwrap()
            .iter()
            .map(|i| v[i.as_u64().unwrap() as usize])
            .collect()
    };
    seeds
        .map(|seed| {
            let mut rng = rand::rngs::StdRng::seed_from_u64(seed);
            let normal = rand_distr::StandardNormal;
            let alpha: Vec<f64> =
                (0..model.num_shape_components()).map(|_| rng.sample::<f64, _>(normal)).collect();
            let shape = model.shape.shape_at(&alpha);
            let mesh = model.to_mesh(&shape);
            let reference = (0..68).map(|l| map.vertex(l).map(|v| mesh.vertices[v])).collect();
            let contour =
                Some((side(&mesh.vertices, "right_contour"), side(&mesh.vertices, "left_contour")));
            Face {
                name: format!("SFM identity {seed}"),
                vertices: mesh.vertices,
                triangles: model.triangles.clone(),
                eligible: None,
                reference,
                contour,
                mm_per_unit: 1.0,
            }
        })
        .collect()
}

fn makehuman_faces() -> Vec<Face> {
    let Some(mh) = lipmap::testdata::shared("data/makehuman") else { return Vec::new() };
    let path = mh.join("base.obj");
    let mesh = obj::read_obj(&path).unwrap();
    let skin = obj::labelable_vertices(&path).unwrap().unwrap();
    let solid = obj::occluding_vertices(&path).unwrap().unwrap();
    let triangles = surface_triangles(&mesh.triangles(), Some(&solid));
    let fixture = read_landmark_map(
        &Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/makehuman_ibug68.toml"),
    )
    .unwrap();
    let mut targets: Vec<PathBuf> = ["chin", "head", "mouth"]
        .iter()
        .flat_map(|d| std::fs::read_dir(mh.join("shape_targets").join(d)).unwrap())
        .map(|e| e.unwrap().path())
        .collect();
    targets.sort();
    let n = mesh.vertices.len();
    let deltas: Vec<_> = targets
        .iter()
        .map(|p| makehuman_target::read_target_blendshape(p, n).unwrap().delta)
        .collect();
    (1..=5u64)
        .map(|seed| {
            let mut rng = rand::rngs::StdRng::seed_from_u64(100 + seed);
            let mut vertices = mesh.vertices.clone();
            // About a third of the targets, each at a weight up to 0.8.
            for d in &deltas {
                if rng.random_bool(0.35) {
                    let w: f64 = rng.random_range(0.0..0.8);
                    for (v, p) in vertices.iter_mut().enumerate() {
                        *p += w * Vector3::new(d[3 * v], d[3 * v + 1], d[3 * v + 2]);
                    }
                }
            }
            let reference = (0..68).map(|l| fixture.vertex(l).map(|v| vertices[v])).collect();
            Face {
                name: format!("MakeHuman identity {seed}"),
                vertices,
                triangles: triangles.clone(),
                eligible: Some(skin.clone()),
                reference,
                contour: None,
                mm_per_unit: 100.0,
            }
        })
        .collect()
}

fn scan(dir: &Path, name: &str) -> Option<Face> {
    let obj_path = dir.join(format!("{name}.obj"));
    let lm = std::fs::read_to_string(dir.join(format!("{name}.lm"))).ok()?;
    let mesh = obj::read_obj(&obj_path).unwrap();
    let reference: Vec<Option<Point3>> = lm
        .lines()
        .map(|l| {
            let x: Vec<f64> = l.split_whitespace().map(|t| t.parse().unwrap()).collect();
            Some(Point3::new(x[0], x[1], x[2]))
        })
        .collect();
    assert_eq!(reference.len(), 68);
    let triangles = mesh.triangles();
    Some(Face {
        name: name.to_string(),
        vertices: mesh.vertices,
        triangles,
        eligible: None,
        reference,
        contour: None,
        mm_per_unit: 1.0,
    })
}

/// The scans in `dir` (every `NAME.lm` with its `NAME.obj`), grouped by the name up to its
/// first `_` (`ict`, `ict_sample`, `ict_random1` are one group), groups and names sorted.
fn scan_groups(dir: &Path) -> Vec<(String, Vec<String>)> {
    let mut names: Vec<String> = std::fs::read_dir(dir)
        .map(|d| {
            d.filter_map(|e| {
                let path = e.ok()?.path();
                let stem = path.file_stem()?.to_str()?.to_string();
                (path.extension()? == "lm" && dir.join(format!("{stem}.obj")).exists())
                    .then_some(stem)
            })
            .collect()
        })
        .unwrap_or_default();
    names.sort();
    let mut groups: Vec<(String, Vec<String>)> = Vec::new();
    for name in names {
        let group = name.split('_').next().unwrap_or(&name).to_string();
        match groups.iter_mut().find(|(g, _)| *g == group) {
            Some((_, members)) => members.push(name),
            None => groups.push((group, vec![name])),
        }
    }
    groups
}

/// Seeds from `var` (`A-B`), else `default`.
fn seeds(var: &str, default: std::ops::RangeInclusive<u64>) -> std::ops::RangeInclusive<u64> {
    std::env::var(var)
        .ok()
        .and_then(|v| {
            let (a, b) = v.split_once('-')?;
            Some(a.parse().ok()?..=b.parse().ok()?)
        })
        .unwrap_or(default)
}

#[test]
#[ignore = "measurement: prints figures per held-out face"]
fn suggestions_on_held_out_faces() {
    let Some(frame) = carphone() else { return };
    // The head's own face when the predictor is installed (as `map suggest` does), unless
    // LIPMAP_HELDOUT_FRAME asks for the video frame's method.
    let predictor = (std::env::var_os("LIPMAP_HELDOUT_FRAME").is_none())
        .then(|| read_shape_predictor(Path::new(DEBIAN_PREDICTOR_PATH)).ok())
        .flatten();
    let source = match &predictor {
        Some(p) => Source::OwnFace(p),
        None => Source::Frame(&frame),
    };
    eprintln!(
        "matched to: {}",
        if predictor.is_some() { "the head's own face" } else { "carphone's frame" }
    );
    let only = std::env::var("LIPMAP_HELDOUT_ONLY").ok();
    let wanted = |group: &str| only.as_deref().is_none_or(|o| o.split(',').any(|g| g == group));
    let mut groups: Vec<(String, Vec<Face>)> = Vec::new();
    if wanted("sfm") {
        groups.push(("SFM identities".into(), sfm_faces(seeds("LIPMAP_SFM_SEEDS", 11..=30))));
    }
    if wanted("makehuman") {
        groups.push(("MakeHuman identities".into(), makehuman_faces()));
    }
    if let Some(dir) = std::env::var_os("LIPMAP_FACE_SCANS").map(PathBuf::from) {
        for (group, names) in scan_groups(&dir) {
            if wanted(&group) {
                let faces = names.iter().filter_map(|n| scan(&dir, n)).collect();
                groups.push((group, faces));
            }
        }
    } else {
        eprintln!("no scans: set LIPMAP_FACE_SCANS (docs/labelling.md)");
    }
    for (group, faces) in groups {
        let mut all = Vec::new();
        for face in &faces {
            all.extend(report(face, &source));
        }
        if !all.is_empty() {
            eprintln!(
                "== {group}: every suggestion with a reference, all placements: median {:.1} p90 {:.1} mm (n {})",
                quantile(&all, 0.5),
                quantile(&all, 0.9),
                all.len()
            );
        }
    }
}
