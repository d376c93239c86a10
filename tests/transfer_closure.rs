//! Closure carried across heads: when the source's lips meet, the transferred head's lips
//! meet, whatever gap the head has at rest. The source is the demo head articulated (at
//! rest and pressed its lips are sealed; opened by the jaw they part); the targets are the
//! demo head posed with parted lips as its rest, and MakeHuman (`../shared/data/makehuman/`,
//! whose lips part by about 15 % of the widest opening at rest; skipped when absent). The
//! target's inner-lip gap (along its up direction, mean of the three inner-lip pairs) at the
//! source's seals must be at most 10 % of its widest opening; with the relative displacement
//! (`LipGap::Relative`) a head with parted lips keeps its rest gap, which the test also shows.

mod common;

use lipmap::demo::demo_head;
use lipmap::demo::visemes::Articulation;
use lipmap::math::{DVector, Point3};
use lipmap::model::{LandmarkMap, Mesh};
use lipmap::transfer::{HeadFrame, LipGap, SourceFace, TargetHead, Transfer, TransferOptions};

const INNER_LIP_PAIRS: [(usize, usize); 3] = [(61, 67), (62, 66), (63, 65)];

fn flat(points: &[Point3]) -> DVector {
    DVector::from_iterator(3 * points.len(), points.iter().flat_map(|p| [p.x, p.y, p.z]))
}

fn point(flat: &DVector, v: usize) -> Point3 {
    Point3::new(flat[3 * v], flat[3 * v + 1], flat[3 * v + 2])
}

/// Mean vertical gap of the inner-lip pairs of `shape` along the head's up direction.
fn inner_gap(shape: &DVector, map: &LandmarkMap, frame: &HeadFrame) -> f64 {
    let up = frame.up();
    let gaps: Vec<f64> = INNER_LIP_PAIRS
        .iter()
        .map(|&(u, l)| {
            (point(shape, map.vertex(u).unwrap()) - point(shape, map.vertex(l).unwrap())).dot(&up)
        })
        .collect();
    gaps.iter().sum::<f64>() / gaps.len() as f64
}

/// The source: the demo head's rest, then frames opening and closing the mouth. Returns
/// the reference, the frames, and which frames are sealed (the source's gap at most 2 % of
/// its widest).
struct Source {
    reference: DVector,
    frames: Vec<DVector>,
    sealed: Vec<bool>,
    triangles: Vec<[u32; 3]>,
    map: LandmarkMap,
}

fn source() -> Source {
    let (head, fields) = demo_head();
    let rest = head.mesh.vertices.clone();
    let poses = [
        Articulation::default(),
        Articulation { jaw_deg: 6.0, ..Articulation::default() },
        Articulation { jaw_deg: 14.0, lower_drop_mm: 2.0, ..Articulation::default() },
        Articulation { press_mm: 1.0, ..Articulation::default() },
        Articulation { jaw_deg: 3.0, spread_mm: 2.0, ..Articulation::default() },
        Articulation { round_mm: 3.0, protrude_mm: 3.0, press_mm: 0.5, ..Articulation::default() },
    ];
    let frames: Vec<DVector> = poses.iter().map(|a| flat(&fields.apply(&rest, a))).collect();
    let map = head.landmarks.clone();
    let frame = HeadFrame::from_landmarks(&map, &rest).unwrap();
    let gaps: Vec<f64> = frames.iter().map(|f| inner_gap(f, &map, &frame)).collect();
    let widest = gaps.iter().cloned().fold(0.0, f64::max);
    let sealed: Vec<bool> = gaps.iter().map(|g| g.abs() <= 0.02 * widest).collect();
    assert!(sealed.iter().filter(|s| **s).count() >= 2, "source gaps {gaps:?}");
    Source { reference: flat(&rest), frames, sealed, triangles: head.mesh.triangles(), map }
}

/// The target's gaps at the source's sealed frames over its widest gap (worst), and its
/// rest gap over its widest.
fn sealed_gap_ratio(
    s: &Source,
    target: &Mesh,
    skin: &[bool],
    map: &LandmarkMap,
    lip_gap: LipGap,
) -> (f64, f64) {
    let source = SourceFace {
        reference: &s.reference,
        triangles: &s.triangles,
        landmarks: &s.map,
        identity: None,
        face: None,
    };
    let head = TargetHead { mesh: target, skin, landmarks: map };
    let options = TransferOptions { lip_gap, ..TransferOptions::default() };
    let t = Transfer::new(source, head, &options).unwrap();
    let frame = HeadFrame::from_landmarks(map, &target.vertices).unwrap();
    let gaps: Vec<f64> =
        s.frames.iter().map(|f| inner_gap(&t.apply(f).unwrap(), map, &frame)).collect();
    let widest = gaps.iter().cloned().fold(0.0, f64::max);
    let worst_sealed = gaps
        .iter()
        .zip(&s.sealed)
        .filter(|(_, sealed)| **sealed)
        .map(|(g, _)| g.abs())
        .fold(0.0, f64::max);
    (worst_sealed / widest, inner_gap(&target.to_flat(), map, &frame) / widest)
}

#[test]
fn a_demo_head_with_parted_lips_closes_when_the_source_does() {
    let s = source();
    let (head, fields) = demo_head();
    // The target's rest: the demo head with its lips parted (jaw and lower lip down).
    let parted = Articulation { jaw_deg: 3.0, lower_drop_mm: 1.0, ..Articulation::default() };
    let target = Mesh { vertices: fields.apply(&head.mesh.vertices, &parted), ..head.mesh.clone() };
    let (absolute, rest) = sealed_gap_ratio(&s, &target, &[], &head.landmarks, LipGap::Absolute);
    let (relative, _) = sealed_gap_ratio(&s, &target, &[], &head.landmarks, LipGap::Relative);
    eprintln!(
        "demo head, rest gap {rest:.3} of the widest: sealed gap {absolute:.3} (absolute), {relative:.3} (relative)"
    );
    assert!(rest > 0.1, "the target's rest is parted: {rest:.3}");
    assert!(absolute <= 0.10, "sealed gap {absolute:.3} of the widest opening");
    assert!(relative > 0.5 * rest, "the relative displacement keeps the rest gap: {relative:.3}");
}

#[test]
fn makehuman_closes_when_the_source_does() {
    let Some((_, mesh, skin, map)) = common::makehuman() else { return };
    let s = source();
    let (absolute, rest) = sealed_gap_ratio(&s, &mesh, &skin, &map, LipGap::Absolute);
    let (relative, _) = sealed_gap_ratio(&s, &mesh, &skin, &map, LipGap::Relative);
    eprintln!(
        "MakeHuman, rest gap {rest:.3} of the widest: sealed gap {absolute:.3} (absolute), {relative:.3} (relative)"
    );
    assert!(absolute <= 0.10, "sealed gap {absolute:.3} of the widest opening");
    assert!(relative > 0.5 * rest, "the relative displacement keeps the rest gap: {relative:.3}");
}
