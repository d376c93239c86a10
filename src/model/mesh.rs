//! `Mesh`: vertices in file order (vertex order is identity for a 3DMM) and polygon faces.
//! Conversions to and from the flat `x0 y0 z0 x1 …` vectors the models use live here too.

use crate::math::{DVector, Point3};
use serde::{Deserialize, Serialize};

/// A polygon mesh. Model space: y up, the face looks along +z, units as the source.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Mesh {
    pub vertices: Vec<Point3>,
    /// Polygons as 0-based vertex indices, as written (not triangulated).
    pub faces: Vec<Vec<u32>>,
}

impl Mesh {
    /// Fan-triangulated faces, for rendering only.
    pub fn triangles(&self) -> Vec<[u32; 3]> {
        let mut out = Vec::with_capacity(self.faces.len() * 2);
        for f in &self.faces {
            for k in 1..f.len().saturating_sub(1) {
                out.push([f[0], f[k], f[k + 1]]);
            }
        }
        out
    }

    /// Builds a mesh from a flat `x0 y0 z0 x1 …` slice; a trailing partial vertex is dropped.
    ///
    /// ```
    /// let m = lipmap::model::Mesh::from_flat(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0], vec![]);
    /// assert_eq!(m.vertices[1].y, 5.0);
    /// ```
    pub fn from_flat(flat: &[f64], faces: Vec<Vec<u32>>) -> Self {
        let vertices = flat.chunks_exact(3).map(|c| Point3::new(c[0], c[1], c[2])).collect();
        Self { vertices, faces }
    }

    /// The vertices as one flat vector `x0 y0 z0 x1 …` (3N), the layout of model shapes.
    pub fn to_flat(&self) -> DVector {
        DVector::from_iterator(
            3 * self.vertices.len(),
            self.vertices.iter().flat_map(|p| [p.x, p.y, p.z]),
        )
    }

    /// Number of vertices N.
    pub fn num_vertices(&self) -> usize {
        self.vertices.len()
    }

    /// The first face (index, vertex) that points past the last vertex, if any.
    pub fn first_face_out_of_range(&self) -> Option<(usize, u32)> {
        let n = self.vertices.len();
        self.faces
            .iter()
            .enumerate()
            .find_map(|(i, f)| f.iter().find(|&&v| v as usize >= n).map(|&v| (i, v)))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn flat_round_trip_and_fan() {
        let m = Mesh::from_flat(
            &[0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 1.0, 1.0, 0.0, 0.0, 1.0, 0.0],
            vec![vec![0, 1, 2, 3]],
        );
        assert_eq!(Mesh::from_flat(m.to_flat().as_slice(), m.faces.clone()), m);
        assert_eq!(m.triangles(), vec![[0, 1, 2], [0, 2, 3]]);
        assert_eq!(m.first_face_out_of_range(), None);
        let bad = Mesh { faces: vec![vec![0, 4, 1]], ..m };
        assert_eq!(bad.first_face_out_of_range(), Some((0, 4)));
    }
}
