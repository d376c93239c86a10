//! `LandmarkMap`: which mesh vertex is which iBUG point. lipmap indices are 0-based here;
//! eos's TOML mapping files are 1-based in the iBUG id and are converted at the boundary.

use crate::landmarks::LandmarkSet;
use std::collections::BTreeMap;

/// 0-based iBUG index -> 0-based vertex index. Unmapped points are absent.
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct LandmarkMap {
    pub to_vertex: BTreeMap<usize, usize>,
}

impl LandmarkMap {
    /// The map for measuring (not fitting): where the inner lip corners 60/64 are unmapped,
    /// they take the vertices of the mouth corners 48/54. In the iBUG-68 markup both pairs
    /// mark the same commissures, which is why eos's maps leave 61/65 out; for a fit that
    /// would count the corners twice, but W needs a corner on each side.
    pub fn with_commissures_completed(&self) -> LandmarkMap {
        let mut map = self.clone();
        for (inner, outer) in [(60, 48), (64, 54)] {
            if !map.to_vertex.contains_key(&inner)
                && let Some(v) = map.vertex(outer)
            {
                map.to_vertex.insert(inner, v);
            }
        }
        map
    }

    /// The vertex mapped to the 0-based iBUG point `landmark`, if any.
    pub fn vertex(&self, landmark: usize) -> Option<usize> {
        self.to_vertex.get(&landmark).copied()
    }

    /// Number of mapped points.
    pub fn len(&self) -> usize {
        self.to_vertex.len()
    }

    /// Whether no point is mapped.
    pub fn is_empty(&self) -> bool {
        self.to_vertex.is_empty()
    }

    /// The mapping restricted to the points of a fitting set (F1..F5); points of the set
    /// that are unmapped stay absent.
    ///
    /// ```
    /// use lipmap::{landmarks::LandmarkSet, model::LandmarkMap};
    /// let map = LandmarkMap { to_vertex: [(30, 114), (62, 423)].into_iter().collect() };
    /// assert_eq!(map.restricted_to(LandmarkSet::F1).len(), 1); // lips only: 62
    /// ```
    pub fn restricted_to(&self, set: LandmarkSet) -> LandmarkMap {
        let to_vertex = self
            .to_vertex
            .iter()
            .filter(|(l, _)| set.contains(**l))
            .map(|(&l, &v)| (l, v))
            .collect();
        LandmarkMap { to_vertex }
    }

    /// The largest mapped vertex index, to check the map against a model's vertex count.
    pub fn max_vertex(&self) -> Option<usize> {
        self.to_vertex.values().copied().max()
    }

    /// (landmark, vertex) pairs in ascending landmark order.
    pub fn pairs(&self) -> impl Iterator<Item = (usize, usize)> + '_ {
        self.to_vertex.iter().map(|(&l, &v)| (l, v))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn restriction_keeps_only_set_points() {
        let map = LandmarkMap { to_vertex: (0..68).map(|l| (l, l * 10)).collect() };
        for set in LandmarkSet::ALL {
            let r = map.restricted_to(set);
            assert_eq!(r.len(), set.indices().len());
            assert!(r.pairs().all(|(l, v)| set.contains(l) && v == l * 10));
        }
        assert_eq!(map.max_vertex(), Some(670));
    }
}
