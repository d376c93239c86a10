//! The target head as a surface: its skin triangles (helper/joint geometry left out), the
//! edge graph with geodesic distances along it (Dijkstra), area-weighted vertex normals,
//! and the connected parts of the whole mesh. Checked once: faces in range, no degenerate
//! skin triangle, no edge shared by more than two skin triangles.

use super::TransferError;
use crate::math::{Point3, Vector3};
use crate::model::Mesh;
use std::cmp::Ordering;
use std::collections::{BinaryHeap, HashMap};

/// A checked target surface.
#[derive(Clone, Debug)]
pub struct Surface {
    pub vertices: Vec<Point3>,
    /// Whether each vertex may carry a control point and be interpolated as skin.
    pub skin: Vec<bool>,
    /// Skin triangles (all three corners skin), fan-triangulated from the mesh's polygons.
    pub triangles: Vec<[usize; 3]>,
    /// Neighbours of each vertex along skin-triangle edges.
    pub neighbours: Vec<Vec<usize>>,
    /// Unit area-weighted normals of skin vertices (zero elsewhere).
    pub normals: Vec<Vector3>,
    /// Connected-part id of every vertex over all faces of the mesh (skin or not).
    pub part: Vec<usize>,
}

impl Surface {
    /// Builds the surface of `mesh`, `skin` marking the usable vertices (empty: all).
    ///
    /// # Errors
    /// `FaceOutOfRange`, `DegenerateTriangle` (a skin triangle of zero area) and
    /// `NonManifoldEdge` (an edge of more than two skin triangles).
    pub fn new(mesh: &Mesh, skin: &[bool]) -> Result<Self, TransferError> {
        let n = mesh.vertices.len();
        if let Some((face, vertex)) = mesh.first_face_out_of_range() {
            return Err(TransferError::FaceOutOfRange {
                face,
                vertex: vertex as usize,
                vertices: n,
            });
        }
        if !skin.is_empty() && skin.len() != n {
            return Err(TransferError::SkinLength { len: skin.len(), vertices: n });
        }
        let skin: Vec<bool> = if skin.is_empty() { vec![true; n] } else { skin.to_vec() };
        let extent = bounding_diagonal(&mesh.vertices);
        let mut triangles = Vec::new();
        let mut normals = vec![Vector3::zeros(); n];
        let mut edge_use: HashMap<(usize, usize), u32> = HashMap::new();
        for (face, poly) in mesh.faces.iter().enumerate() {
            if !poly.iter().all(|&v| skin[v as usize]) {
                continue;
            }
            for k in 1..poly.len().saturating_sub(1) {
                let t = [poly[0] as usize, poly[k] as usize, poly[k + 1] as usize];
                let [a, b, c] = t.map(|v| mesh.vertices[v]);
                let cross = (b - a).cross(&(c - a));
                let twice_area = cross.norm();
                // Relative to the head's size, so units (mm, dm) do not matter.
                if twice_area.is_nan() || twice_area <= 1e-14 * extent * extent {
                    return Err(TransferError::DegenerateTriangle { face });
                }
                for v in t {
                    normals[v] += cross;
                }
                for (p, q) in [(t[0], t[1]), (t[1], t[2]), (t[2], t[0])] {
                    let count = edge_use.entry((p.min(q), p.max(q))).or_insert(0);
                    *count += 1;
                    if *count > 2 {
                        return Err(TransferError::NonManifoldEdge { a: p.min(q), b: p.max(q) });
                    }
                }
                triangles.push(t);
            }
        }
        let mut neighbours = vec![Vec::new(); n];
        for &(p, q) in edge_use.keys() {
            neighbours[p].push(q);
            neighbours[q].push(p);
        }
        for list in &mut neighbours {
            list.sort_unstable();
        }
        for normal in &mut normals {
            *normal = normal.try_normalize(0.0).unwrap_or_else(Vector3::zeros);
        }
        let part = connected_parts(n, &mesh.faces);
        Ok(Self { vertices: mesh.vertices.clone(), skin, triangles, neighbours, normals, part })
    }

    /// Geodesic distances (shortest paths along skin edges) from `source` to every vertex
    /// closer than `limit`; vertices farther away are absent.
    pub fn geodesic_within(&self, source: usize, limit: f64) -> HashMap<usize, f64> {
        let mut dist: HashMap<usize, f64> = HashMap::new();
        let mut heap = BinaryHeap::new();
        dist.insert(source, 0.0);
        heap.push(Entry { d: 0.0, v: source });
        while let Some(Entry { d, v }) = heap.pop() {
            if d > dist.get(&v).copied().unwrap_or(f64::INFINITY) {
                continue;
            }
            for &w in &self.neighbours[v] {
                let nd = d + (self.vertices[w] - self.vertices[v]).norm();
                if nd <= limit && nd < dist.get(&w).copied().unwrap_or(f64::INFINITY) {
                    dist.insert(w, nd);
                    heap.push(Entry { d: nd, v: w });
                }
            }
        }
        dist
    }
}

/// The diagonal of the axis-aligned bounding box of `points` (0 when empty).
pub fn bounding_diagonal(points: &[Point3]) -> f64 {
    let Some(first) = points.first() else { return 0.0 };
    let (lo, hi) = points
        .iter()
        .fold((first.coords, first.coords), |(lo, hi), p| (lo.inf(&p.coords), hi.sup(&p.coords)));
    (hi - lo).norm()
}

/// Connected parts over all faces by union–find; ids are the smallest vertex of each part.
fn connected_parts(n: usize, faces: &[Vec<u32>]) -> Vec<usize> {
    let mut parent: Vec<usize> = (0..n).collect();
    fn root(parent: &mut [usize], mut v: usize) -> usize {
        while parent[v] != v {
            parent[v] = parent[parent[v]];
            v = parent[v];
        }
        v
    }
    for poly in faces {
        for w in poly.windows(2) {
            let (a, b) = (root(&mut parent, w[0] as usize), root(&mut parent, w[1] as usize));
            parent[a.max(b)] = a.min(b);
        }
    }
    (0..n).map(|v| root(&mut parent, v)).collect()
}

/// A min-heap entry for Dijkstra.
#[derive(PartialEq)]
struct Entry {
    d: f64,
    v: usize,
}

impl Eq for Entry {}

impl Ord for Entry {
    fn cmp(&self, other: &Self) -> Ordering {
        other.d.total_cmp(&self.d).then(other.v.cmp(&self.v))
    }
}

impl PartialOrd for Entry {
    fn partial_cmp(&self, other: &Self) -> Option<Ordering> {
        Some(self.cmp(other))
    }
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A flat grid of `n × n` vertices, spacing 1, quads as polygons; plus a separate
    /// triangle (the "tooth") at z = −1.
    pub(crate) fn grid(n: usize) -> Mesh {
        let mut vertices = Vec::new();
        for j in 0..n {
            for i in 0..n {
                let (x, y) = (i as f64, j as f64);
                vertices.push(Point3::new(x, y, 0.05 * (x * 0.7).sin() * (y * 0.5).cos()));
            }
        }
        let mut faces = Vec::new();
        for j in 0..n - 1 {
            for i in 0..n - 1 {
                let v = (j * n + i) as u32;
                faces.push(vec![v, v + 1, v + 1 + n as u32, v + n as u32]);
            }
        }
        let t = vertices.len() as u32;
        let c = (n as f64 - 1.0) / 2.0;
        vertices.extend([
            Point3::new(c, c - 1.0, -1.0),
            Point3::new(c + 1.0, c - 1.0, -1.0),
            Point3::new(c, c, -1.0),
        ]);
        faces.push(vec![t, t + 1, t + 2]);
        Mesh { vertices, faces }
    }

    #[test]
    fn geodesics_parts_and_checks() {
        let mesh = grid(5);
        let s = Surface::new(&mesh, &[]).unwrap();
        assert_eq!(s.triangles.len(), 2 * 16 + 1);
        // Along the edges: 0 → 2 is two unit steps (the bump changes it by < 1 %).
        let d = s.geodesic_within(0, 10.0);
        assert!((d[&2] - 2.0).abs() < 0.02 && !d.contains_key(&25));
        assert!(!s.geodesic_within(0, 1.5).contains_key(&2));
        assert_eq!(s.part[24], 0);
        assert_eq!(s.part[26], 25);
        assert!(s.normals[12].z > 0.99);

        let mut bad = mesh.clone();
        bad.faces.push(vec![0, 1, 0]);
        assert!(matches!(Surface::new(&bad, &[]), Err(TransferError::DegenerateTriangle { .. })));
        let mut fan = mesh.clone();
        fan.faces.push(vec![0, 1, 26]);
        fan.faces.push(vec![1, 0, 27]);
        assert!(matches!(
            Surface::new(&fan, &[]),
            Err(TransferError::NonManifoldEdge { a: 0, b: 1 })
        ));
        let mut out = mesh;
        out.faces.push(vec![0, 1, 99]);
        assert!(matches!(Surface::new(&out, &[]), Err(TransferError::FaceOutOfRange { .. })));
    }
}
