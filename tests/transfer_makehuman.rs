//! Transfer on the real MakeHuman head (`../shared/data/makehuman/`): rigid motion of the
//! controls moves the head rigidly, and interpolation accuracy against the exact per-vertex
//! displacements of MakeHuman's face-unit targets. Skips when the shared data is absent.

use lipmap::io::makehuman_target::read_target;
use lipmap::io::{landmark_map_toml::read_landmark_map, obj};
use lipmap::math::{DVector, Point3, Vector3};
use lipmap::model::{LandmarkMap, Mesh};
use lipmap::transfer::projection::frontal_face_vertices;
use lipmap::transfer::{Interpolation, SourceFace, TargetHead, Transfer, TransferOptions};
use std::path::Path;

struct Head {
    mesh: Mesh,
    skin: Vec<bool>,
    map: LandmarkMap,
    triangles: Vec<[u32; 3]>,
    face: Vec<usize>,
}

fn head() -> Option<Head> {
    let dir = lipmap::testdata::shared("data/makehuman")?;
    let path = dir.join("base.obj");
    let mesh = obj::read_obj(&path).unwrap();
    let skin = obj::labelable_vertices(&path).unwrap().unwrap();
    let fixture =
        Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/fixtures/makehuman_ibug68.toml");
    let map = read_landmark_map(&fixture).unwrap();
    let triangles: Vec<[u32; 3]> =
        mesh.triangles().into_iter().filter(|t| t.iter().all(|&v| skin[v as usize])).collect();
    let face = frontal_face_vertices(&mesh.vertices, &skin, &map).unwrap();
    Some(Head { mesh, skin, map, triangles, face })
}

fn setup(h: &Head, interpolation: Interpolation) -> Transfer {
    setup_with(h, TransferOptions { interpolation, ..TransferOptions::default() })
}

fn setup_with(h: &Head, options: TransferOptions) -> Transfer {
    let reference = h.mesh.to_flat();
    let source = SourceFace {
        reference: &reference,
        triangles: &h.triangles,
        landmarks: &h.map,
        identity: None,
        face: Some(&h.face),
    };
    let target = TargetHead { mesh: &h.mesh, skin: &h.skin, landmarks: &h.map };
    Transfer::new(source, target, &options).unwrap()
}

fn target_displacements(n: usize, name: &str) -> Vec<Vector3> {
    let dir = lipmap::testdata::shared("data/makehuman/faceunits").unwrap();
    let mut d = vec![Vector3::zeros(); n];
    for o in read_target(&dir.join(format!("{name}.target"))).unwrap() {
        d[o.vertex] = o.delta;
    }
    d
}

/// Relative RMS error over `vertices` of the transferred displacements against the truth.
fn relative_rms(out: &DVector, rest: &[Point3], truth: &[Vector3], vertices: &[usize]) -> f64 {
    let (mut err, mut norm) = (0.0, 0.0);
    for &v in vertices {
        let got = Vector3::new(out[3 * v], out[3 * v + 1], out[3 * v + 2]) - rest[v].coords;
        err += (got - truth[v]).norm_squared();
        norm += truth[v].norm_squared();
    }
    (err / norm).sqrt()
}

#[test]
fn face_units_are_reproduced_from_their_controls() {
    let Some(h) = head() else { return };
    let rest = &h.mesh.vertices;
    let units = [
        "jawOpen",
        "mouthPucker",
        "mouthSmileLeft",
        "mouthSmileRight",
        "mouthStretchLeft",
        "mouthStretchRight",
        "mouthFunnel",
    ];
    let mut results = Vec::new();
    for mode in [Interpolation::Biharmonic, Interpolation::Barycentric] {
        let t = setup(&h, mode);
        let controls: std::collections::HashSet<usize> =
            t.target_controls.iter().copied().collect();
        let inner_lip: Vec<usize> = [61, 62, 63, 65, 66, 67]
            .iter()
            .map(|&l| rest[h.map.vertex(l).unwrap()])
            .flat_map(|c| (0..rest.len()).filter(move |&v| (rest[v] - c).norm() < 0.08))
            .filter(|v| h.skin[*v] && !controls.contains(v))
            .collect::<std::collections::BTreeSet<_>>()
            .into_iter()
            .collect();
        for unit in units {
            let truth = target_displacements(rest.len(), unit);
            let positions: Vec<Point3> =
                t.target_controls.iter().map(|&v| rest[v] + truth[v]).collect();
            let out = t.apply_controls(&positions).unwrap();
            let moved: Vec<usize> = (0..rest.len())
                .filter(|&v| h.skin[v] && !controls.contains(&v) && truth[v].norm() > 0.0)
                .collect();
            let e = relative_rms(&out, rest, &truth, &moved);
            results.push((mode, unit.to_string(), e));
            if unit == "jawOpen" {
                let inner = relative_rms(&out, rest, &truth, &inner_lip);
                results.push((mode, "jawOpen inner lip".to_string(), inner));
            }
        }
    }
    for (mode, unit, e) in &results {
        println!("{mode:?} {unit}: relative RMS {e:.3}");
    }
    let get = |mode: Interpolation, unit: &str| {
        results.iter().find(|r| r.0 == mode && r.1 == unit).unwrap().2
    };
    let limits = [
        ("jawOpen", 0.10),
        ("mouthPucker", 0.20),
        ("mouthSmileLeft", 0.15),
        ("mouthSmileRight", 0.15),
        ("mouthStretchLeft", 0.15),
        ("mouthStretchRight", 0.15),
        ("mouthFunnel", 0.45),
        ("jawOpen inner lip", 0.25),
    ];
    for (unit, limit) in limits {
        let e = get(Interpolation::Biharmonic, unit);
        assert!(e <= limit, "{unit}: biharmonic relative RMS {e:.3} > {limit}");
        assert!(
            e < get(Interpolation::Barycentric, unit),
            "{unit}: biharmonic no better than barycentric"
        );
    }
}

#[test]
fn rigid_motion_of_the_controls_moves_the_head_rigidly() {
    let Some(h) = head() else { return };
    let rotation = nalgebra::Rotation3::from_euler_angles(0.3, -0.5, 0.2);
    let shift = Vector3::new(0.7, -1.2, 2.0);
    let moved = |p: &Point3| rotation * p + shift;
    let size = lipmap::transfer::surface::bounding_diagonal(&h.mesh.vertices);
    for mode in [Interpolation::Biharmonic, Interpolation::Barycentric] {
        let t = setup(&h, mode);
        let positions: Vec<Point3> = t.rest_controls().iter().map(moved).collect();
        let out = t.apply_controls(&positions).unwrap();
        // The source moved rigidly gives the same.
        let source: Vec<f64> = h
            .mesh
            .vertices
            .iter()
            .flat_map(|p| {
                let q = moved(p);
                [q.x, q.y, q.z]
            })
            .collect();
        let out_source = t.apply(&DVector::from_vec(source)).unwrap();
        for result in [out, out_source] {
            let worst = h
                .mesh
                .vertices
                .iter()
                .enumerate()
                .map(|(v, p)| {
                    (Point3::new(result[3 * v], result[3 * v + 1], result[3 * v + 2]) - moved(p))
                        .norm()
                })
                .fold(0.0, f64::max);
            assert!(
                worst <= 1e-9 * size,
                "{mode:?}: worst rigid error {worst:e} (head size {size})"
            );
        }
    }
}
