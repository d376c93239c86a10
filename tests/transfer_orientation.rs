//! The transfer does not depend on where the target head stands: everything it decides (the
//! head region, which loose parts go with the jaw, the controls' vertices) is taken in the
//! head's own frame, so turning and moving the target changes the result only by that
//! rigid motion, to within 1e-6 of the head's size. Checked on the demo head (always) in
//! random orientations and positions (a property test) and y-up, z-up and facing −z, and on
//! MakeHuman (`../shared/data/makehuman/`, skipped when absent) in the same three
//! orientations. Loose parts far from the mouth stay with the head, near ones follow the jaw.

mod common;

use lipmap::demo::demo_head;
use lipmap::demo::visemes::Articulation;
use lipmap::io::makehuman_target::read_target;
use lipmap::math::{DVector, Point3, Vector3};
use lipmap::model::{LandmarkMap, Mesh};
use lipmap::transfer::projection::frontal_face_vertices;
use lipmap::transfer::surface::bounding_diagonal;
use lipmap::transfer::{SourceFace, TargetHead, Transfer, TransferOptions};
use nalgebra::{Rotation3, Unit};
use proptest::prelude::*;

/// A rigid motion: rotation then translation.
#[derive(Clone, Copy, Debug)]
struct Motion {
    rotation: Rotation3<f64>,
    shift: Vector3,
}

impl Motion {
    fn apply(&self, p: &Point3) -> Point3 {
        self.rotation * p + self.shift
    }
}

/// The head standing z-up (y ↦ z) and facing −z (turned half round about y), unmoved.
fn named_orientations() -> Vec<(&'static str, Motion)> {
    let none = Vector3::zeros();
    vec![
        (
            "z-up",
            Motion {
                rotation: Rotation3::from_axis_angle(
                    &Vector3::x_axis(),
                    0.5 * std::f64::consts::PI,
                ),
                shift: none,
            },
        ),
        (
            "facing -z",
            Motion {
                rotation: Rotation3::from_axis_angle(&Vector3::y_axis(), std::f64::consts::PI),
                shift: none,
            },
        ),
        (
            "z-up, facing -y, moved",
            Motion {
                rotation: Rotation3::from_axis_angle(
                    &Vector3::x_axis(),
                    -0.5 * std::f64::consts::PI,
                ),
                shift: Vector3::new(120.0, -40.0, 900.0),
            },
        ),
    ]
}

/// A source (its reference and one moved frame) and a target head.
struct Case {
    reference: DVector,
    frame: DVector,
    triangles: Vec<[u32; 3]>,
    source_map: LandmarkMap,
    face: Option<Vec<usize>>,
    target: Mesh,
    skin: Vec<bool>,
    target_map: LandmarkMap,
}

impl Case {
    fn transfer(&self, target: &Mesh) -> DVector {
        let source = SourceFace {
            reference: &self.reference,
            triangles: &self.triangles,
            landmarks: &self.source_map,
            identity: None,
            face: self.face.as_deref(),
        };
        let head = TargetHead { mesh: target, skin: &self.skin, landmarks: &self.target_map };
        let t = Transfer::new(source, head, &TransferOptions::default()).unwrap();
        t.apply(&self.frame).unwrap()
    }

    /// The worst distance, over the head's size, between the transfer onto the moved head
    /// and the transfer onto the head, moved.
    fn worst_relative_error(&self, motion: &Motion) -> f64 {
        let still = self.transfer(&self.target);
        let mut moved_head = self.target.clone();
        for p in &mut moved_head.vertices {
            *p = motion.apply(p);
        }
        let moved = self.transfer(&moved_head);
        let size = bounding_diagonal(&self.target.vertices);
        (0..self.target.vertices.len())
            .map(|v| {
                let a = motion.apply(&point(&still, v));
                (a - point(&moved, v)).norm()
            })
            .fold(0.0, f64::max)
            / size
    }
}

fn point(flat: &DVector, v: usize) -> Point3 {
    Point3::new(flat[3 * v], flat[3 * v + 1], flat[3 * v + 2])
}

fn flat(points: &[Point3]) -> DVector {
    DVector::from_iterator(3 * points.len(), points.iter().flat_map(|p| [p.x, p.y, p.z]))
}

/// The demo head driving itself with its jaw open and its mouth spread, plus two loose
/// pieces: one inside the mouth below the corners (a "lower tooth") and one on the neck,
/// 30 mm below the chin.
fn demo_case() -> (Case, usize, usize) {
    let (head, fields) = demo_head();
    let rest = head.mesh.vertices.clone();
    let open = Articulation { jaw_deg: 14.0, spread_mm: 3.0, ..Articulation::default() };
    let frame = flat(&fields.apply(&rest, &open));
    let mut target = head.mesh.clone();
    let map = head.landmarks.clone();
    let chin = rest[map.vertex(8).unwrap()];
    let mouth = Point3::from(
        0.5 * (rest[map.vertex(48).unwrap()].coords + rest[map.vertex(54).unwrap()].coords),
    );
    let mut add_piece = |at: Point3| {
        let first = target.vertices.len() as u32;
        target.vertices.extend([
            at,
            at + Vector3::new(4.0, 0.0, 0.0),
            at + Vector3::new(0.0, -3.0, 1.0),
        ]);
        target.faces.push(vec![first, first + 1, first + 2]);
        first as usize
    };
    let tooth = add_piece(mouth + Vector3::new(-2.0, -6.0, -12.0));
    let neck = add_piece(chin + Vector3::new(0.0, -30.0, -10.0));
    let case = Case {
        reference: flat(&rest),
        frame,
        triangles: head.mesh.triangles(),
        source_map: map.clone(),
        face: None,
        skin: Vec::new(),
        target,
        target_map: map,
    };
    (case, tooth, neck)
}

#[test]
fn demo_head_result_turns_with_the_head_in_named_orientations() {
    let (case, _, _) = demo_case();
    for (name, motion) in named_orientations() {
        let e = case.worst_relative_error(&motion);
        assert!(e <= 1e-6, "{name}: worst error {e:e} of the head's size");
    }
}

#[test]
fn loose_parts_far_from_the_mouth_stay_with_the_head() {
    let (case, tooth, neck) = demo_case();
    for (name, motion) in
        [("as built", Motion { rotation: Rotation3::identity(), shift: Vector3::zeros() })]
            .into_iter()
            .chain(named_orientations())
    {
        let mut head = case.target.clone();
        for p in &mut head.vertices {
            *p = motion.apply(p);
        }
        let out = case.transfer(&head);
        let moved_by = |v: usize| (point(&out, v) - head.vertices[v]).norm();
        // The source's head does not turn (only its jaw and lips move), so the neck piece
        // stays exactly where it was and the tooth goes down with the jaw.
        assert!(moved_by(neck) < 1e-9, "{name}: neck piece moved {:.3} mm", moved_by(neck));
        assert!(
            moved_by(tooth) > 1.0,
            "{name}: the tooth did not follow the jaw ({:.3} mm)",
            moved_by(tooth)
        );
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 6, ..ProptestConfig::default() })]

    #[test]
    fn demo_head_result_turns_with_any_rigid_motion(
        axis in prop::array::uniform3(-1.0f64..1.0),
        angle in -3.1f64..3.1,
        shift in prop::array::uniform3(-500.0f64..500.0),
    ) {
        let axis = Vector3::from(axis);
        prop_assume!(axis.norm() > 0.1);
        let motion = Motion {
            rotation: Rotation3::from_axis_angle(&Unit::new_normalize(axis), angle),
            shift: Vector3::from(shift),
        };
        let (case, _, _) = demo_case();
        let e = case.worst_relative_error(&motion);
        prop_assert!(e <= 1e-6, "worst error {:e} of the head's size", e);
    }
}

#[test]
fn makehuman_result_turns_with_the_head() {
    let Some((dir, mesh, skin, map)) = common::makehuman() else { return };
    let triangles: Vec<[u32; 3]> =
        mesh.triangles().into_iter().filter(|t| t.iter().all(|&v| skin[v as usize])).collect();
    let face = frontal_face_vertices(&mesh.vertices, &skin, &map).unwrap();
    // The source: MakeHuman itself opening its jaw (its face-unit target, exact).
    let mut moved = mesh.vertices.clone();
    for o in read_target(&dir.join("faceunits/jawOpen.target")).unwrap() {
        moved[o.vertex] += o.delta;
    }
    let case = Case {
        reference: mesh.to_flat(),
        frame: flat(&moved),
        triangles,
        source_map: map.clone(),
        face: Some(face),
        target: mesh,
        skin,
        target_map: map,
    };
    for (name, motion) in named_orientations() {
        let e = case.worst_relative_error(&motion);
        eprintln!("MakeHuman {name}: worst error {e:e} of the head's size");
        assert!(e <= 1e-6, "{name}: worst error {e:e} of the head's size");
    }
}
