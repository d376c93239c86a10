//! Setting a transfer up, once per source/target pair: check the inputs, place the source,
//! choose and project the controls, and build the interpolation (its factor or bindings)
//! and the plan for the disconnected parts.

use super::TransferError;
use super::barycentric::{Binding, bind_vertices};
use super::biharmonic::Biharmonic;
use super::frame::HeadFrame;
use super::parts::{JawZone, PartsMode, PartsPlan, plan_parts};
use super::placement::{Identity, Placement, place_source};
use super::projection::{project_controls, select_controls, triangulate_controls};
use super::surface::Surface;
use crate::math::{DVector, Point3, Vector3};
use crate::model::{LandmarkMap, Mesh};
use std::collections::HashSet;

/// iBUG points (0-based) that expressions barely move: nose bridge and eye corners. The
/// head's rigid pose is estimated on them, so articulation does not leak into it.
const STABLE_LANDMARKS: [usize; 7] = [27, 28, 29, 36, 39, 42, 45];

/// The face model whose motion drives the target.
#[derive(Clone, Copy, Debug)]
pub struct SourceFace<'a> {
    /// The reference (neutral) shape, flat `x0 y0 z0 …`, in model space (y up, face +z).
    pub reference: &'a DVector,
    pub triangles: &'a [[u32; 3]],
    pub landmarks: &'a LandmarkMap,
    /// The identity part of the model, for adapting it to the target.
    pub identity: Option<Identity<'a>>,
    /// Vertices that may become controls (`None`: all, as for a face model).
    pub face: Option<&'a [usize]>,
}

/// The head to animate.
#[derive(Clone, Copy, Debug)]
pub struct TargetHead<'a> {
    pub mesh: &'a Mesh,
    /// Per-vertex skin mask (false for helper/joint geometry); empty: all skin.
    pub skin: &'a [bool],
    pub landmarks: &'a LandmarkMap,
}

/// How vertices follow the controls.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Interpolation {
    /// Smooth thin-plate displacements over the head region (the default).
    #[default]
    Biharmonic,
    /// The paper's per-triangle interpolation, in frames that move with the triangles.
    Barycentric,
}

/// How the inner lips' opening is carried from the source to the target.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum LipGap {
    /// The target's opening is the source's (scaled by the placement): when the source's
    /// lips meet, the target's do, whatever gap the target has at rest (the default).
    #[default]
    Absolute,
    /// The opening changes by the source's change from its reference, so the target keeps
    /// its own rest gap as an offset (a head modelled with parted lips never closes them).
    Relative,
}

/// Setup choices; the defaults suit a face model driving a head.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TransferOptions {
    pub interpolation: Interpolation,
    pub parts: PartsMode,
    pub lip_gap: LipGap,
    /// Controls wanted (landmarks included). The paper's Candide-3 has 113; around the mouth
    /// corners a face unit's displacement varies faster than 300 spread controls resolve
    /// (smile and stretch errors 0.17 at 300, 0.09–0.12 at 600; docs/transfer.md).
    pub controls: usize,
    /// Landmarks labelled on both sides needed for the placement.
    pub min_landmarks: usize,
    pub closest_point_rounds: usize,
    /// A control triangle is dropped when an edge is this many times longer along the
    /// target surface than straight.
    pub geodesic_ratio: f64,
    /// Least cosine between a control's normal and its target vertex's.
    pub min_normal_cos: f64,
    /// Head region radius as a fraction of the controls' bounding-box diagonal: beyond it
    /// vertices only follow the head's rigid pose.
    pub region_scale: f64,
    /// Barycentric depth gate as a multiple of the median control-triangle edge.
    pub depth_gate_scale: f64,
}

impl Default for TransferOptions {
    fn default() -> Self {
        Self {
            interpolation: Interpolation::Biharmonic,
            parts: PartsMode::Jaw,
            lip_gap: LipGap::Absolute,
            controls: 600,
            min_landmarks: 6,
            closest_point_rounds: 0,
            geodesic_ratio: 2.0,
            min_normal_cos: 0.3,
            region_scale: 0.25,
            depth_gate_scale: 0.5,
        }
    }
}

#[derive(Debug)]
pub(crate) enum Interpolator {
    Biharmonic(Biharmonic),
    Barycentric(Vec<Binding>),
}

/// A transfer set up for one source and one target; apply it per frame.
#[derive(Debug)]
pub struct Transfer {
    pub placement: Placement,
    /// Source vertex of each control.
    pub source_controls: Vec<usize>,
    /// Target vertex of each control (all distinct).
    pub target_controls: Vec<usize>,
    /// Control triangles kept (indices into the controls) and how many were dropped.
    pub triangles: Vec<[usize; 3]>,
    pub triangles_dropped: usize,
    /// Target vertices inside the head region.
    pub region: Vec<bool>,
    pub(crate) rest: Vec<Point3>,
    pub(crate) reference: Vec<Point3>,
    /// Controls the rigid pose is estimated on.
    pub(crate) stable: Vec<usize>,
    /// Inner-lip control pairs (upper, lower) whose vertical gap is carried absolutely, and
    /// the source's up direction (source model space) the gap is measured along.
    pub(crate) lip_pairs: Vec<(usize, usize)>,
    pub(crate) source_up: Vector3,
    pub(crate) interpolator: Interpolator,
    pub(crate) parts: PartsPlan,
}

impl Transfer {
    /// Sets a transfer up.
    ///
    /// # Errors
    /// `ShapeLength` (reference not 3N), `LandmarkOutOfRange` (a map for another mesh),
    /// `TooFewLandmarks`, the target surface's checks (`FaceOutOfRange`,
    /// `DegenerateTriangle`, `NonManifoldEdge`, `SkinLength`), `DegeneratePlacement`,
    /// `NoTargetVertex`, `NoControlTriangles` (barycentric) and `Solver` (biharmonic).
    pub fn new(
        source: SourceFace<'_>,
        target: TargetHead<'_>,
        options: &TransferOptions,
    ) -> Result<Self, TransferError> {
        let len = source.reference.len();
        if !len.is_multiple_of(3) || len == 0 {
            return Err(TransferError::ShapeLength { len, expected: 3 * (len / 3).max(1) });
        }
        if source.reference.iter().any(|x| !x.is_finite()) {
            return Err(TransferError::NonFinite);
        }
        let reference: Vec<Point3> = source
            .reference
            .as_slice()
            .chunks_exact(3)
            .map(|c| Point3::new(c[0], c[1], c[2]))
            .collect();
        check_map(source.landmarks, reference.len(), "source")?;
        check_map(target.landmarks, target.mesh.vertices.len(), "target")?;
        let surface = Surface::new(target.mesh, target.skin)?;
        let pairs: Vec<(usize, usize, usize)> = source
            .landmarks
            .pairs()
            .filter_map(|(l, sv)| target.landmarks.vertex(l).map(|tv| (l, sv, tv)))
            .collect();
        let needed = options.min_landmarks.max(3);
        if pairs.len() < needed {
            return Err(TransferError::TooFewLandmarks { found: pairs.len(), needed });
        }
        let all: Vec<usize> = (0..reference.len()).collect();
        let face = source.face.unwrap_or(&all);
        let skin_points: Vec<Point3> = (0..surface.vertices.len())
            .filter(|&v| surface.skin[v])
            .map(|v| surface.vertices[v])
            .collect();
        let landmark_pairs: Vec<(usize, Point3)> =
            pairs.iter().map(|&(_, sv, tv)| (sv, surface.vertices[tv])).collect();
        let placement = place_source(
            &reference,
            source.identity,
            &landmark_pairs,
            face,
            &skin_points,
            options.closest_point_rounds,
        )?;

        // Controls: landmarks first, each tied to its labelled target vertex.
        let landmark_sources: Vec<usize> = pairs.iter().map(|&(_, sv, _)| sv).collect();
        let source_controls =
            select_controls(&placement.adapted, &landmark_sources, face, options.controls);
        let mut fixed_taken = HashSet::new();
        let control_landmark: Vec<Option<usize>> = source_controls
            .iter()
            .map(|&sv| pairs.iter().find(|p| p.1 == sv).map(|p| p.0))
            .collect();
        let fixed: Vec<Option<usize>> = control_landmark
            .iter()
            .map(|l| {
                l.and_then(|l| target.landmarks.vertex(l)).filter(|&tv| fixed_taken.insert(tv))
            })
            .collect();
        let source_normals = vertex_normals(&placement.adapted, source.triangles);
        let t = &placement.similarity;
        let positions: Vec<Point3> =
            source_controls.iter().map(|&v| t.apply(&placement.adapted[v])).collect();
        let normals: Vec<Vector3> =
            source_controls.iter().map(|&v| t.rotation * source_normals[v]).collect();
        let target_controls =
            project_controls(&positions, &normals, &fixed, &surface, options.min_normal_cos)?;
        let rest_controls: Vec<Point3> =
            target_controls.iter().map(|&v| surface.vertices[v]).collect();

        // The source's frontal plane is its own face's (model space when its landmarks do
        // not give the axes: y up, looking along +z).
        let source_frame = HeadFrame::from_landmarks(source.landmarks, &placement.adapted)
            .map_or_else(crate::math::Matrix3::identity, |f| f.axes);
        let frontal: Vec<Point3> = source_controls
            .iter()
            .map(|&v| Point3::from(source_frame * placement.adapted[v].coords))
            .collect();
        let triangles =
            triangulate_controls(&frontal, &target_controls, &surface, options.geodesic_ratio);
        let all_triangles = delaunay_count(&frontal);

        // Every decision below is taken in the target head's own frame, so that the result
        // turns and moves with the head and does not depend on the world's axes.
        let frame = HeadFrame::of_head(target.landmarks, &surface.vertices, &rest_controls);
        // The head region: skin within a radius of the controls.
        let radius = options.region_scale * frame.extent_diagonal(&rest_controls);
        let near: Vec<bool> = surface
            .vertices
            .iter()
            .map(|p| rest_controls.iter().any(|c| (c - p).norm_squared() <= radius * radius))
            .collect();
        // Only parts a control reaches can move: a free part with no control would leave the
        // biharmonic system singular.
        let control_parts: HashSet<usize> =
            target_controls.iter().map(|&v| surface.part[v]).collect();
        let region: Vec<bool> = (0..near.len())
            .map(|v| near[v] && surface.skin[v] && control_parts.contains(&surface.part[v]))
            .collect();
        let is_control: HashSet<usize> = target_controls.iter().copied().collect();
        let interpolator = match options.interpolation {
            Interpolation::Biharmonic => {
                Interpolator::Biharmonic(Biharmonic::new(&surface, &target_controls, &region)?)
            }
            Interpolation::Barycentric => {
                if triangles.is_empty() {
                    return Err(TransferError::NoControlTriangles);
                }
                let mut edges: Vec<f64> = triangles
                    .iter()
                    .flat_map(|t| [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])])
                    .map(|(a, b)| (rest_controls[a] - rest_controls[b]).norm())
                    .collect();
                edges.sort_by(f64::total_cmp);
                let gate = options.depth_gate_scale * edges[edges.len() / 2];
                let bound: Vec<usize> =
                    (0..region.len()).filter(|&v| region[v] && !is_control.contains(&v)).collect();
                Interpolator::Barycentric(bind_vertices(
                    &surface.vertices,
                    &bound,
                    &rest_controls,
                    &triangles,
                    gate,
                ))
            }
        };

        // Parts no control reaches, near the head.
        let part_vertices: Vec<usize> = (0..near.len())
            .filter(|&v| near[v] && !control_parts.contains(&surface.part[v]))
            .collect();
        let jaw = frame
            .anatomical
            .then(|| jaw_zone(&frame, target.landmarks, &surface.vertices, &rest_controls))
            .flatten();
        let moving_skin: Vec<usize> = (0..region.len()).filter(|&v| region[v]).collect();
        let parts = plan_parts(
            options.parts,
            &surface.vertices,
            &part_vertices,
            &surface.part,
            jaw,
            &moving_skin,
        );
        let mut stable: Vec<usize> = (0..source_controls.len())
            .filter(|&c| control_landmark[c].is_some_and(|l| STABLE_LANDMARKS.contains(&l)))
            .collect();
        if stable.len() < 3 {
            stable = (0..source_controls.len()).collect();
        }
        let lip_pairs = match options.lip_gap {
            LipGap::Absolute => inner_lip_pairs(&control_landmark),
            LipGap::Relative => Vec::new(),
        };
        let source_up = HeadFrame::from_landmarks(source.landmarks, &reference)
            .map_or_else(Vector3::y, |f| f.up());
        Ok(Self {
            placement,
            source_controls,
            target_controls,
            triangles_dropped: all_triangles - triangles.len(),
            triangles,
            region,
            rest: surface.vertices,
            reference,
            stable,
            lip_pairs,
            source_up,
            interpolator,
            parts,
        })
    }
}

/// Every mapped vertex must exist; the error names the iBUG point as people number it.
fn check_map(map: &LandmarkMap, vertices: usize, side: &'static str) -> Result<(), TransferError> {
    match map.pairs().find(|&(_, v)| v >= vertices) {
        Some((l, vertex)) => Err(TransferError::LandmarkOutOfRange {
            side,
            landmark: crate::landmarks::PointNo(l),
            vertex,
            vertices,
        }),
        None => Ok(()),
    }
}

/// iBUG inner-lip pairs (0-based upper, lower): 62–68, 63–67, 64–66 in 1-based ids.
const INNER_LIP_PAIRS: [(usize, usize); 3] = [(61, 67), (62, 66), (63, 65)];

/// The control indices of each inner-lip pair both of whose landmarks are controls.
fn inner_lip_pairs(control_landmark: &[Option<usize>]) -> Vec<(usize, usize)> {
    let control_of = |l: usize| control_landmark.iter().position(|&c| c == Some(l));
    INNER_LIP_PAIRS.iter().filter_map(|&(u, l)| Some((control_of(u)?, control_of(l)?))).collect()
}

/// Where the jaw's loose parts (lower teeth, tongue) are, in the head's frame: below the
/// mouth corners and within 1.25 mouth widths of the mouth's middle (the tongue's centroid
/// is about 0.8 of a width behind it on MakeHuman), so that loose pieces far from the mouth
/// (a scan's fragments on the neck, hair) stay with the head. The jaw's motion is the chin
/// controls': below the lower lip, within 0.75 mouth widths of it across the face. `None`
/// without mouth corners and the lower lip's middle, or with fewer than three chin controls.
fn jaw_zone(
    frame: &HeadFrame,
    map: &LandmarkMap,
    points: &[Point3],
    rest_controls: &[Point3],
) -> Option<JawZone> {
    let at = |l: usize| map.vertex(l).and_then(|v| points.get(v).copied());
    let (left, right, lower) = (at(48)?, at(54)?, at(57)?);
    let (up, across) = (frame.up(), frame.left());
    let width = (right - left).norm();
    let controls: Vec<usize> = (0..rest_controls.len())
        .filter(|&c| {
            let d = rest_controls[c] - lower;
            d.dot(&up) < 0.0 && d.dot(&across).abs() < 0.75 * width
        })
        .collect();
    (controls.len() >= 3).then(|| JawZone {
        up,
        corner_height: 0.5 * (left.coords + right.coords).dot(&up),
        centre: Point3::from(0.5 * (left.coords + right.coords)),
        reach: 1.25 * width,
        controls,
    })
}

fn delaunay_count(frontal: &[Point3]) -> usize {
    let points: Vec<delaunator::Point> =
        frontal.iter().map(|p| delaunator::Point { x: p.x, y: p.y }).collect();
    delaunator::triangulate(&points).len()
}

/// Unit area-weighted vertex normals (zero for vertices of no triangle).
fn vertex_normals(points: &[Point3], triangles: &[[u32; 3]]) -> Vec<Vector3> {
    let mut normals = vec![Vector3::zeros(); points.len()];
    for t in triangles {
        let [a, b, c] = t.map(|v| v as usize);
        if a.max(b).max(c) >= points.len() {
            continue;
        }
        let n = (points[b] - points[a]).cross(&(points[c] - points[a]));
        for v in [a, b, c] {
            normals[v] += n;
        }
    }
    normals.iter().map(|n| n.try_normalize(0.0).unwrap_or_else(Vector3::zeros)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transfer::surface::tests::grid;

    /// The grid as both source and target, landmarks on ten spread vertices.
    fn case() -> (Mesh, LandmarkMap) {
        let mesh = grid(12);
        let map =
            LandmarkMap { to_vertex: (0..10).map(|l| (l + 27, 13 * l + 2 * (l % 3))).collect() };
        (mesh, map)
    }

    fn build(
        mesh: &Mesh,
        source_map: &LandmarkMap,
        target_map: &LandmarkMap,
        mode: Interpolation,
    ) -> Result<Transfer, TransferError> {
        let reference = mesh.to_flat();
        let triangles = mesh.triangles();
        let source = SourceFace {
            reference: &reference,
            triangles: &triangles,
            landmarks: source_map,
            identity: None,
            face: None,
        };
        let target = TargetHead { mesh, skin: &[], landmarks: target_map };
        let options =
            TransferOptions { interpolation: mode, controls: 40, ..TransferOptions::default() };
        Transfer::new(source, target, &options)
    }

    #[test]
    fn sets_up_and_reproduces_the_rest_shape() {
        let (mesh, map) = case();
        for mode in [Interpolation::Biharmonic, Interpolation::Barycentric] {
            let t = build(&mesh, &map, &map, mode).unwrap();
            assert_eq!(t.target_controls.len(), 40);
            assert!(t.placement.residual < 1e-9);
            let out = t.apply(&mesh.to_flat()).unwrap();
            assert!((out - mesh.to_flat()).amax() < 1e-9, "{mode:?}");
            assert!(matches!(
                t.apply(&DVector::zeros(5)),
                Err(TransferError::ShapeLength { len: 5, .. })
            ));
        }
    }

    #[test]
    fn bad_inputs_are_typed_errors() {
        let (mesh, map) = case();
        let few = LandmarkMap {
            to_vertex: map.to_vertex.iter().take(2).map(|(&l, &v)| (l, v)).collect(),
        };
        assert!(matches!(
            build(&mesh, &few, &map, Interpolation::Biharmonic),
            Err(TransferError::TooFewLandmarks { found: 2, needed: 6 })
        ));
        let mut other = map.clone();
        other.to_vertex.insert(30, 10_000);
        let err = build(&mesh, &map, &other, Interpolation::Biharmonic).unwrap_err();
        assert!(matches!(
            err,
            TransferError::LandmarkOutOfRange {
                side: "target",
                landmark: crate::landmarks::PointNo(30),
                vertex: 10_000,
                ..
            }
        ));
        assert!(err.to_string().contains("another mesh"));
        let mut flat = mesh.clone();
        flat.faces.push(vec![0, 1, 0]);
        assert!(matches!(
            build(&flat, &map, &map, Interpolation::Biharmonic),
            Err(TransferError::DegenerateTriangle { .. })
        ));
    }
}
