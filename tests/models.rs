//! Model and mesh formats against real files (eos's Surrey Face Model, MakeHuman's base
//! mesh and targets) and synthetic pose folders; shared data is skipped when absent.

use lipmap::io::error::Location;
use lipmap::io::landmark_map_toml::{format_landmark_map, parse_landmark_map, read_landmark_map};
use lipmap::io::model_file::{Precision, read_model_file, write_model_file};
use lipmap::io::model_source::{ModelSourceKind, detect_model_source, load_model, load_model_with};
use lipmap::io::{eos_bin, npy_model, obj};
use lipmap::landmarks::LandmarkSet;
use lipmap::math::{DVector, Point3};
use lipmap::model::pca::Keep;
use lipmap::model::{Mesh, MorphableModel};
use lipmap::testdata::shared;

/// Field-by-field equality, without printing 300k numbers on failure.
fn assert_same_model(a: &MorphableModel, b: &MorphableModel, tol: f64) {
    assert!(max_abs_diff(a.shape.mean.as_slice(), b.shape.mean.as_slice()) <= tol, "mean");
    assert_eq!(a.shape.basis.shape(), b.shape.basis.shape());
    assert!(max_abs_diff(a.shape.basis.as_slice(), b.shape.basis.as_slice()) <= tol, "basis");
    let (ea, eb) = (a.shape.eigenvalues.as_slice(), b.shape.eigenvalues.as_slice());
    assert!(max_abs_diff(ea, eb) <= tol, "eigenvalues");
    assert_eq!(a.expression_names(), b.expression_names());
    if let (Some(x), Some(y)) = (&a.expressions, &b.expressions) {
        assert!(max_abs_diff(x.deltas.as_slice(), y.deltas.as_slice()) <= tol, "expressions");
    }
    assert_eq!(a.num_expressions(), b.num_expressions());
    assert!(a.triangles == b.triangles, "triangles differ");
}

fn max_abs_diff(a: &[f64], b: &[f64]) -> f64 {
    assert_eq!(a.len(), b.len());
    a.iter().zip(b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max)
}

#[test]
fn eos_bin_equals_the_npy_export() {
    let (Some(bin), Some(dir)) =
        (shared("peer/eos/share/sfm_shape_3448.bin"), shared("peer/eos/model"))
    else {
        return;
    };
    let from_bin = eos_bin::read_eos_model(&bin).unwrap();
    let from_npy = npy_model::read_npy_folder(&dir).unwrap();
    assert_eq!(from_bin.num_vertices(), 3448);
    assert_eq!(from_bin.num_shape_components(), 63);
    assert_eq!(from_bin.triangles.len(), 6736);
    // Both store f32; widening is exact, so equality holds to f32 precision and beyond.
    let s = |m: &MorphableModel| m.shape.mean.as_slice().to_vec();
    assert!(max_abs_diff(&s(&from_bin), &s(&from_npy)) <= 1e-6);
    assert!(max_abs_diff(from_bin.shape.basis.as_slice(), from_npy.shape.basis.as_slice()) <= 1e-7);
    assert!(
        max_abs_diff(from_bin.shape.eigenvalues.as_slice(), from_npy.shape.eigenvalues.as_slice())
            <= 1e-3
    );
    assert_eq!(from_bin.triangles, from_npy.triangles);
    // The basis really is orthonormal.
    let b = &from_bin.shape.basis;
    let gram = b.transpose() * b;
    let err = (gram - lipmap::math::DMatrix::identity(63, 63)).abs().max();
    assert!(err < 1e-4, "orthonormality error {err}");
}

#[test]
fn eos_blendshapes_equal_the_npy_export() {
    let (Some(bin), Some(dir)) =
        (shared("peer/eos/share/expression_blendshapes_3448.bin"), shared("peer/eos/model"))
    else {
        return;
    };
    let e = eos_bin::read_eos_blendshapes(&bin).unwrap();
    assert_eq!(e.names, ["anger", "disgust", "fear", "happiness", "sadness", "surprise"]);
    let folder = npy_model::read_npy_folder(&dir).unwrap();
    let fe = folder.expressions.as_ref().unwrap();
    assert_eq!(fe.names, e.names, "names come from summary.json beside the arrays");
    assert!(max_abs_diff(e.deltas.as_slice(), fe.deltas.as_slice()) <= 1e-7);
    // load_model with --blendshapes gives the same model either way.
    let bin_model = shared("peer/eos/share/sfm_shape_3448.bin").unwrap();
    let m = load_model(&bin_model, Some(&bin)).unwrap();
    assert_eq!(m.num_expressions(), 6);
    let s1 = m.shape_at(&[0.5, -1.0], &[0.0, 0.0, 0.0, 1.0]);
    let s2 = folder.shape_at(&[0.5, -1.0], &[0.0, 0.0, 0.0, 1.0]);
    assert!(max_abs_diff(s1.as_slice(), s2.as_slice()) < 1e-3);
}

#[test]
fn truncated_eos_bin_reports_the_offset() {
    let Some(bin) = shared("peer/eos/share/sfm_shape_3448.bin") else { return };
    let bytes = std::fs::read(&bin).unwrap();
    for cut in [2, 100, 41_000, bytes.len() / 2, bytes.len() - 5] {
        let e = eos_bin::parse_eos_model(&bytes[..cut], &bin).unwrap_err();
        let Location::Offset(o) = e.location else { panic!("no offset: {e}") };
        assert!(o as usize <= cut);
        assert!(e.to_string().contains("byte"), "{e}");
    }
}

#[test]
fn mean_obj_matches_the_mean_array_in_file_order() {
    let (Some(objp), Some(dir)) = (shared("peer/eos/model/mean.obj"), shared("peer/eos/model"))
    else {
        return;
    };
    let mesh = obj::read_obj(&objp).unwrap();
    let model = npy_model::read_npy_folder(&dir).unwrap();
    assert_eq!(mesh.num_vertices(), 3448);
    assert!(max_abs_diff(mesh.to_flat().as_slice(), model.shape.mean.as_slice()) < 1e-5);
    assert_eq!(mesh.triangles(), model.triangles);
    assert!((model.mean_mesh().vertices[114] - mesh.vertices[114]).norm() < 1e-5);
}

#[test]
fn every_source_kind_loads_the_same_model() {
    let Some(dir) = shared("peer/eos/model") else { return };
    let reference = load_model(&dir, None).unwrap();
    assert_eq!(detect_model_source(&dir).unwrap(), ModelSourceKind::NpyFolder);
    let tmp = tempfile::tempdir().unwrap();
    let npz = tmp.path().join("sfm.npz");
    npy_model::write_npz(&npz, &reference).unwrap();
    assert_same_model(&load_model(&npz, None).unwrap(), &reference, 0.0);
    // lipmap's own file, with a misleading extension: detected by magic.
    let lmm = tmp.path().join("sfm.bin");
    write_model_file(&lmm, &reference, Precision::F32).unwrap();
    assert_eq!(detect_model_source(&lmm).unwrap(), ModelSourceKind::LipmapFile);
    let back = load_model(&lmm, None).unwrap();
    // f32 payload of f32-born data is exact.
    assert_same_model(&back, &reference, 0.0);
    let size = std::fs::metadata(&lmm).unwrap().len();
    println!("lipmap model file (f32) for the SFM with 6 expressions: {size} bytes");
    assert_eq!(read_model_file(&lmm).unwrap().num_expressions(), 6);
}

#[test]
fn ibug_mapping_reads_writes_and_agrees_with_json() {
    let (Some(toml), Some(json)) = (
        shared("peer/eos/share/ibug_to_sfm.txt"),
        shared("peer/eos/model/landmarks_and_contours.json"),
    ) else {
        return;
    };
    let map = read_landmark_map(&toml).unwrap();
    assert_eq!(map.len(), 50);
    assert_eq!(map.vertex(30), Some(114), "iBUG 31 (nose tip) is point 30");
    assert_eq!(map.vertex(8), Some(33));
    assert_eq!(map.vertex(60), None, "iBUG 61 is not defined in eos's file");
    assert_eq!(read_landmark_map(&json).unwrap(), map);
    let again = parse_landmark_map(
        &format_landmark_map(&map, &lipmap::landmarks::LandmarkNames::builtin()),
        &toml,
    )
    .unwrap();
    assert_eq!(again, map);
    let lips = map.restricted_to(LandmarkSet::F1);
    assert_eq!(lips.len(), 18, "48..68 minus the two undefined inner corners");
    assert_eq!(map.restricted_to(LandmarkSet::F5).len(), 50);
}

#[test]
fn makehuman_base_and_face_units_build_a_blendshape_model() {
    let (Some(base), Some(units)) =
        (shared("data/makehuman/base.obj"), shared("data/makehuman/faceunits"))
    else {
        return;
    };
    let m = load_model(&base, Some(&units)).unwrap();
    assert_eq!(m.num_vertices(), 19_158);
    assert_eq!(m.num_shape_components(), 0);
    assert_eq!(m.num_expressions(), 52);
    let j = m.expression_names().iter().position(|n| n == "jawOpen").unwrap();
    // jawOpen moves vertices down (−y, y up) more than anything else it does.
    let d = m.expressions.as_ref().unwrap().deltas.column(j);
    let (imin, _) =
        d.iter().enumerate().fold((0, 0.0), |a, (i, v)| if *v < a.1 { (i, *v) } else { a });
    assert_eq!(imin % 3, 1, "largest jawOpen offset is along y");
    let open = m.shape_at(&[], &{
        let mut b = vec![0.0; 52];
        b[j] = 1.0;
        b
    });
    assert!(open[imin] < m.shape.mean[imin]);
}

#[test]
fn gzipped_makehuman_shape_targets_load() {
    let (Some(base), Some(mouth)) =
        (shared("data/makehuman/base.obj"), shared("data/makehuman/shape_targets/mouth"))
    else {
        return;
    };
    let m = load_model(&base, Some(&mouth)).unwrap();
    assert!(m.num_expressions() > 5);
    assert!(m.expression_names().iter().any(|n| n == "mouth-trans-up"));
    let e = m.expressions.as_ref().unwrap();
    assert!(e.deltas.column_iter().all(|c| c.norm() > 0.0), "every target moves something");
}

/// Poses along 3 known directions on a 40-vertex mesh, written as OBJ files.
fn write_pose_folder(dir: &std::path::Path, poses: usize) -> Vec<DVector> {
    let n = 40;
    let base: Vec<Point3> =
        (0..n).map(|i| Point3::new(i as f64, (i % 7) as f64, (i % 3) as f64 * 0.5)).collect();
    // Faces refer to vertices out of order and as a quad; vertex identity must not change.
    let faces = vec![vec![5, 2, 9], vec![39, 0, 17, 3]];
    let mut shapes = Vec::new();
    for p in 0..poses {
        let t = p as f64 / poses as f64;
        let (a, b, c) = ((t * 6.0).sin() * 3.0, (t * 11.0).cos(), (t * 17.0).sin() * 0.2);
        let vertices = base
            .iter()
            .enumerate()
            .map(|(i, v)| {
                let w = i as f64 / n as f64;
                Point3::new(v.x + a * w, v.y + b * (1.0 - w), v.z + c)
            })
            .collect();
        let mesh = Mesh { vertices, faces: faces.clone() };
        obj::write_obj(&dir.join(format!("pose_{p:03}.obj")), &mesh).unwrap();
        shapes.push(mesh.to_flat());
    }
    shapes
}

#[test]
fn pose_folder_pca_reconstructs_every_pose() {
    let tmp = tempfile::tempdir().unwrap();
    let shapes = write_pose_folder(tmp.path(), 25);
    assert_eq!(detect_model_source(tmp.path()).unwrap(), ModelSourceKind::PoseFolder);
    let m = load_model_with(tmp.path(), None, Keep::VarianceFraction(1.0)).unwrap();
    assert_eq!(m.num_shape_components(), 3);
    assert_eq!(m.triangles, vec![[5, 2, 9], [39, 0, 17], [39, 17, 3]]);
    for s in &shapes {
        let a = m.shape.coefficients_of(s).unwrap();
        let r = m.shape_at(a.as_slice(), &[]);
        assert!((r - s).norm() < 1e-8);
    }
    let default = load_model(tmp.path(), None).unwrap();
    assert!(default.num_shape_components() <= 3);
    // One pose with a different vertex count: the error names that file.
    std::fs::write(tmp.path().join("pose_999.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n")
        .unwrap();
    let e = load_model(tmp.path(), None).unwrap_err();
    assert!(e.path.ends_with("pose_999.obj"), "{e}");
}

#[test]
fn model_build_counts_the_pose_files_it_read() {
    let tmp = tempfile::tempdir().unwrap();
    let poses = tmp.path().join("poses");
    std::fs::create_dir(&poses).unwrap();
    write_pose_folder(&poses, 25);
    // Copies of one pose add files but no direction of variation.
    for k in 0..6 {
        std::fs::copy(poses.join("pose_000.obj"), poses.join(format!("copy_{k}.obj"))).unwrap();
    }
    let out = tmp.path().join("m.lmm");
    let run = std::process::Command::new(env!("CARGO_BIN_EXE_lipmap"))
        .args(["model", "build"])
        .arg(&poses)
        .arg("--out")
        .arg(&out)
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&run.stdout);
    assert!(run.status.success(), "{}", String::from_utf8_lossy(&run.stderr));
    assert!(
        text.contains("31 pose files read (40 vertices each), varying in 3 directions"),
        "{text}"
    );
    assert!(text.contains("% of the variance)"), "{text}");
}

#[test]
fn fitted_mesh_exports_with_vertex_order_kept() {
    let Some(dir) = shared("peer/eos/model") else { return };
    let m = load_model(&dir, None).unwrap();
    let shape = m.shape_at(&[1.0, -0.5, 0.25], &[0.0, 1.0]);
    let tmp = tempfile::tempdir().unwrap();
    let p = tmp.path().join("fit.obj");
    obj::write_obj(&p, &m.to_mesh(&shape)).unwrap();
    let back = obj::read_obj(&p).unwrap();
    assert_eq!(back.to_flat(), shape, "shortest-decimal output reads back exactly");
    assert_eq!(back.triangles(), m.triangles);
    assert_eq!(m.vertex(&shape, 114), Some(back.vertices[114]));
}

mod properties {
    use super::*;
    use proptest::prelude::*;

    fn mesh_strategy() -> impl Strategy<Value = Mesh> {
        (3usize..30).prop_flat_map(|n| {
            let vertices = proptest::collection::vec(
                (-1e3f64..1e3, -1e3f64..1e3, -1e3f64..1e3)
                    .prop_map(|(x, y, z)| Point3::new(x, y, z)),
                n,
            );
            let faces =
                proptest::collection::vec(proptest::collection::vec(0..n as u32, 3..6), 0..20);
            (vertices, faces).prop_map(|(vertices, faces)| Mesh { vertices, faces })
        })
    }

    proptest! {
        /// Written OBJ reads back identically: no vertex is renumbered, dropped or moved,
        /// whatever order the faces reference them in (unreferenced vertices included).
        #[test]
        fn obj_round_trip_keeps_identity(mesh in mesh_strategy()) {
            let mut out = Vec::new();
            obj::write_obj_to(&mut out, &mesh).unwrap();
            let back = obj::parse_obj(std::str::from_utf8(&out).unwrap(), std::path::Path::new("p.obj")).unwrap();
            prop_assert_eq!(back, mesh);
        }

        /// Faces written with negative (relative) indices after all vertices resolve to the
        /// same vertices as 1-based ones.
        #[test]
        fn relative_indices_resolve_like_absolute(mesh in mesh_strategy()) {
            let n = mesh.vertices.len() as i64;
            let mut text = String::new();
            for p in &mesh.vertices {
                text.push_str(&format!("v {} {} {}\n", p.x, p.y, p.z));
            }
            for f in &mesh.faces {
                let refs: Vec<String> = f.iter().map(|&v| format!("{}/1/1", v as i64 - n)).collect();
                text.push_str(&format!("f {}\n", refs.join(" ")));
            }
            let back = obj::parse_obj(&text, std::path::Path::new("p.obj")).unwrap();
            prop_assert_eq!(back, mesh);
        }
    }
}
