//! `Mesh`: vertices in file order (vertex order is identity for a 3DMM) and polygon faces.

use crate::math::Point3;
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
}
