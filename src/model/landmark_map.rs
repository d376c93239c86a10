//! `LandmarkMap`: which mesh vertex is which iBUG point. lipmap indices are 0-based here;
//! eos's TOML mapping files are 1-based in the iBUG id and are converted at the boundary.

use std::collections::BTreeMap;

/// 0-based iBUG index -> 0-based vertex index. Unmapped points are absent.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LandmarkMap {
    pub to_vertex: BTreeMap<usize, usize>,
}

impl LandmarkMap {
    pub fn vertex(&self, landmark: usize) -> Option<usize> {
        self.to_vertex.get(&landmark).copied()
    }

    pub fn len(&self) -> usize {
        self.to_vertex.len()
    }

    pub fn is_empty(&self) -> bool {
        self.to_vertex.is_empty()
    }
}
