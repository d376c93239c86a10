//! Projection (Terissi et al. 2011, §5.1): control points on the source, one and only one
//! target vertex for each, and the control triangles that survive the geodesic check.
//!
//! Controls are the source's mapped landmark vertices (which take the target's labelled
//! vertex for the same landmark) plus evenly spread face vertices (farthest-point
//! sampling), each projected to the nearest free target skin vertex whose normal agrees,
//! closest pairs first. Control triangles are the Delaunay triangles of the controls in the
//! source face's frontal plane, kept only where every edge is about as short along the
//! target surface as through space, so none spans the lip gap.

use super::TransferError;
use super::surface::Surface;
use crate::math::{Point3, Vector3};
use crate::model::LandmarkMap;
use std::collections::{HashMap, HashSet};

/// Side of the grid cells (in units of the outline's height) within which only the
/// front-most vertices count as visible.
const VISIBILITY_CELL: f64 = 0.015;

/// The vertices of a whole head that make up its face, for when the source is a head
/// rather than a face model: skin vertices inside the landmark outline (jaw 0–16, brows
/// 26–17) in the face's frontal plane and visible from the front (within a cell's depth of
/// the front-most vertex of their grid cell), so that no control lands inside the mouth.
/// The face's axes come from the map, so the head may stand in any orientation. `None`
/// when a point of the outline is unmapped or out of range, or the map gives no axes.
pub fn frontal_face_vertices(
    points: &[Point3],
    skin: &[bool],
    map: &LandmarkMap,
) -> Option<Vec<usize>> {
    let axes = super::frame::HeadFrame::from_landmarks(map, points)?;
    let points: Vec<Point3> = points.iter().map(|p| Point3::from(axes.local(p))).collect();
    let outline: Vec<Point3> = (0..17)
        .chain((17..27).rev())
        .map(|l| map.vertex(l).and_then(|v| points.get(v).copied()))
        .collect::<Option<_>>()?;
    let inside = |p: &Point3| {
        let mut crossings = 0;
        for k in 0..outline.len() {
            let (a, b) = (outline[k], outline[(k + 1) % outline.len()]);
            if (a.y > p.y) != (b.y > p.y) && p.x < a.x + (p.y - a.y) / (b.y - a.y) * (b.x - a.x) {
                crossings += 1;
            }
        }
        crossings % 2 == 1
    };
    let height = outline.iter().map(|p| p.y).fold(f64::NEG_INFINITY, f64::max)
        - outline.iter().map(|p| p.y).fold(f64::INFINITY, f64::min);
    let size = VISIBILITY_CELL * height;
    let cell = |p: &Point3| ((p.x / size).floor() as i64, (p.y / size).floor() as i64);
    let candidates: Vec<usize> = (0..points.len())
        .filter(|&v| skin.get(v).copied().unwrap_or(true) && inside(&points[v]))
        .collect();
    let mut front: HashMap<(i64, i64), f64> = HashMap::new();
    for &v in &candidates {
        let z = front.entry(cell(&points[v])).or_insert(f64::NEG_INFINITY);
        *z = z.max(points[v].z);
    }
    Some(
        candidates
            .into_iter()
            .filter(|&v| points[v].z >= front[&cell(&points[v])] - 2.0 * size)
            .collect(),
    )
}

/// Candidate target vertices considered per control before giving up.
const CANDIDATES: usize = 64;
/// Triangles whose shape quality (1 for equilateral) is below this are slivers whose local
/// frame would be ill-conditioned.
const MIN_TRIANGLE_QUALITY: f64 = 0.05;

/// Source vertices to use as controls: `landmarks` first (deduplicated), then vertices of
/// `face` by farthest-point sampling until `count` are chosen.
pub fn select_controls(
    points: &[Point3],
    landmarks: &[usize],
    face: &[usize],
    count: usize,
) -> Vec<usize> {
    let mut chosen: Vec<usize> = Vec::with_capacity(count);
    for &v in landmarks {
        if !chosen.contains(&v) {
            chosen.push(v);
        }
    }
    let mut nearest: Vec<f64> = face
        .iter()
        .map(|&v| {
            chosen
                .iter()
                .map(|&c| (points[c] - points[v]).norm_squared())
                .fold(f64::INFINITY, f64::min)
        })
        .collect();
    while chosen.len() < count {
        let Some((i, &d)) = nearest.iter().enumerate().max_by(|a, b| a.1.total_cmp(b.1)) else {
            break;
        };
        if d <= 0.0 {
            break;
        }
        let v = face[i];
        chosen.push(v);
        for (slot, &w) in nearest.iter_mut().zip(face) {
            *slot = slot.min((points[w] - points[v]).norm_squared());
        }
    }
    chosen
}

/// The target vertex of each control. `fixed` gives controls already tied to a target
/// vertex (landmarks: the labelled vertex); the others go to the nearest free skin vertex
/// whose normal is within `acos(min_cos)` of theirs (a zero normal agrees with any),
/// closest pairs first, so no target vertex serves two controls.
///
/// # Errors
/// `NoTargetVertex` when a control finds no free skin vertex with an agreeing normal.
pub fn project_controls(
    positions: &[Point3],
    normals: &[Vector3],
    fixed: &[Option<usize>],
    surface: &Surface,
    min_cos: f64,
) -> Result<Vec<usize>, TransferError> {
    let mut taken: HashSet<usize> = fixed.iter().flatten().copied().collect();
    let mut assigned: Vec<Option<usize>> = fixed.to_vec();
    let skin: Vec<usize> = (0..surface.vertices.len()).filter(|&v| surface.skin[v]).collect();
    let key = distance_key(surface, &skin);
    let agrees =
        |v: usize, n: &Vector3| n.norm_squared() == 0.0 || surface.normals[v].dot(n) >= min_cos;
    let mut pairs: Vec<(i64, usize, usize)> = Vec::new();
    for (c, (p, n)) in positions.iter().zip(normals).enumerate() {
        if assigned[c].is_some() {
            continue;
        }
        let mut cands: Vec<(i64, usize)> = skin
            .iter()
            .filter(|&&v| agrees(v, n))
            .map(|&v| (key((surface.vertices[v] - p).norm_squared()), v))
            .collect();
        let k = CANDIDATES.min(cands.len());
        if k == 0 {
            return Err(TransferError::NoTargetVertex { control: c });
        }
        cands.select_nth_unstable(k - 1);
        pairs.extend(cands[..k].iter().map(|&(d, v)| (d, c, v)));
    }
    pairs.sort_unstable();
    for (_, c, v) in pairs {
        if assigned[c].is_none() && taken.insert(v) {
            assigned[c] = Some(v);
        }
    }
    // Where controls crowd (a dense source), all of a control's nearest candidates can go to
    // closer pairs: it then takes the nearest vertex still free, however far.
    for c in 0..assigned.len() {
        if assigned[c].is_some() {
            continue;
        }
        let (p, n) = (positions[c], normals[c]);
        let nearest = skin
            .iter()
            .filter(|&&v| !taken.contains(&v) && agrees(v, &n))
            .min_by_key(|&&v| (key((surface.vertices[v] - p).norm_squared()), v));
        if let Some(&v) = nearest {
            taken.insert(v);
            assigned[c] = Some(v);
        }
    }
    assigned
        .iter()
        .enumerate()
        .map(|(c, a)| a.ok_or(TransferError::NoTargetVertex { control: c }))
        .collect()
}

/// Squared distances as integers on a grid of 1e-10 of the head's squared size, so that
/// distances equal but for rounding (a symmetric mesh's mirror vertices) compare equal
/// whichever way the head is turned, and ties go to the lower vertex index: the choice of
/// vertices must not depend on where the head stands.
fn distance_key(surface: &Surface, skin: &[usize]) -> impl Fn(f64) -> i64 + use<> {
    let origin = skin.first().map(|&v| surface.vertices[v]);
    let size2 = origin.map_or(0.0, |o| {
        skin.iter().map(|&v| (surface.vertices[v] - o).norm_squared()).fold(0.0, f64::max)
    });
    let quantum = (1e-10 * size2).max(f64::MIN_POSITIVE);
    move |d2: f64| (d2 / quantum).round() as i64
}

/// Control triangles (indices into the controls): Delaunay in the plane of `frontal`'s
/// x and y (the source's face axes), minus slivers and triangles with an edge whose geodesic length between the
/// projected corners `targets` exceeds `geodesic_ratio` × its straight length.
pub fn triangulate_controls(
    frontal: &[Point3],
    targets: &[usize],
    surface: &Surface,
    geodesic_ratio: f64,
) -> Vec<[usize; 3]> {
    let points: Vec<delaunator::Point> =
        frontal.iter().map(|p| delaunator::Point { x: p.x, y: p.y }).collect();
    let tri = delaunator::triangulate(&points).triangles;
    let triangles: Vec<[usize; 3]> = tri.chunks_exact(3).map(|t| [t[0], t[1], t[2]]).collect();
    let at = |c: usize| surface.vertices[targets[c]];
    // One bounded Dijkstra per control, as far as its longest allowed edge.
    let mut reach = vec![0.0f64; targets.len()];
    for t in &triangles {
        for (a, b) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
            let d = (at(a) - at(b)).norm() * geodesic_ratio;
            reach[a] = reach[a].max(d);
        }
    }
    let geodesics: Vec<_> =
        (0..targets.len()).map(|c| surface.geodesic_within(targets[c], reach[c])).collect();
    triangles
        .into_iter()
        .filter(|t| {
            let short = [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])].iter().all(|&(a, b)| {
                let straight = (at(a) - at(b)).norm();
                geodesics[a].get(&targets[b]).is_some_and(|&g| g <= geodesic_ratio * straight)
            });
            short && triangle_quality(at(t[0]), at(t[1]), at(t[2])) >= MIN_TRIANGLE_QUALITY
        })
        .collect()
}

/// `4√3·area / Σ edge²`: 1 for an equilateral triangle, 0 for a degenerate one.
pub fn triangle_quality(a: Point3, b: Point3, c: Point3) -> f64 {
    let area = 0.5 * (b - a).cross(&(c - a)).norm();
    let sum = (b - a).norm_squared() + (c - b).norm_squared() + (a - c).norm_squared();
    if sum > 0.0 { 4.0 * 3f64.sqrt() * area / sum } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::transfer::surface::tests::grid;

    #[test]
    fn controls_are_spread_unique_and_triangles_respect_gaps() {
        let mesh = grid(9);
        let s = Surface::new(&mesh, &[]).unwrap();
        let face: Vec<usize> = (0..81).collect();
        let controls = select_controls(&mesh.vertices, &[40], &face, 9);
        assert_eq!(controls[0], 40);
        assert!(controls.contains(&0) && controls.contains(&80), "{controls:?}");
        // Two controls at the same spot: the second takes the next-nearest vertex.
        let p = mesh.vertices[40] + Vector3::new(0.1, 0.0, 0.3);
        let up = Vector3::z();
        let got = project_controls(&[p, p], &[up, up], &[None, None], &s, 0.5).unwrap();
        assert_eq!(got[0], 40);
        assert_ne!(got[1], 40);
        assert!((s.vertices[got[1]] - s.vertices[40]).norm() < 1.01);
        // Normals that disagree with every vertex: nothing to project to.
        assert!(project_controls(&[p], &[-up], &[None], &s, 0.5).is_err());

        // Cut the grid between rows 4 and 5 (a "lip gap"): triangles across it go.
        let mut cut = mesh.clone();
        cut.faces.retain(|f| !(f.iter().any(|&v| v / 9 == 4) && f.iter().any(|&v| v / 9 == 5)));
        let s = Surface::new(&cut, &[]).unwrap();
        let targets: Vec<usize> = (0..81).step_by(2).collect();
        let frontal: Vec<Point3> = targets.iter().map(|&v| cut.vertices[v]).collect();
        let kept = triangulate_controls(&frontal, &targets, &s, 2.0);
        assert!(!kept.is_empty());
        for t in &kept {
            let rows: Vec<usize> = t.iter().map(|&c| targets[c] / 9).collect();
            assert!(rows.iter().all(|&r| r <= 4) || rows.iter().all(|&r| r >= 5), "{rows:?}");
        }
    }
}
