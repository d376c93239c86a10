//! The distances D1..D13 between iBUG points and the 12 indices computed from them, on
//! landmarks or on a model shape through its landmark map (see the parent for the points).

use super::FacialIndex;
use crate::landmarks::FrameLandmarks;
use crate::math::{DVector, Point2};
use crate::measure::MeasureError;
use crate::model::LandmarkMap;
use serde::{Deserialize, Serialize};

/// Landmarks of the distances (0-based iBUG).
mod lm {
    pub const ZYGION_R: usize = 0;
    pub const ZYGION_L: usize = 16;
    pub const GNATHION: usize = 8;
    pub const EXO_R: usize = 36;
    pub const EXO_L: usize = 45;
    pub const ENDO_R: usize = 39;
    pub const ENDO_L: usize = 42;
    pub const ALARE_R: usize = 31;
    pub const ALARE_L: usize = 35;
    pub const SUBNASALE: usize = 33;
    pub const LABIALE_SUP: usize = 51;
    pub const STOMION_1: usize = 62;
    pub const STOMION_2: usize = 66;
    pub const LABIALE_INF: usize = 57;
    pub const CHEILION_R: usize = 48;
    pub const CHEILION_L: usize = 54;
}

/// The distances D1..D13 (`d[0]` = D1) in the points' units.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FacialDistances {
    pub d: [f64; 13],
}

impl FacialDistances {
    /// Distance D`k` (1-based, 1..=13).
    ///
    /// # Panics
    /// When `k` is not in 1..=13 (a programming error: the numbers are fixed).
    pub fn get(&self, k: usize) -> f64 {
        self.d[k - 1]
    }
}

/// D1..D13 from 68 points (`None` = unavailable), in the points' units.
///
/// # Errors
/// `MissingLandmark` for an absent point, `NonFinite` for NaN coordinates.
pub fn facial_distances(points: &[Option<Point2>]) -> Result<FacialDistances, MeasureError> {
    use lm::*;
    let p = |i: usize| -> Result<Point2, MeasureError> {
        let q = points.get(i).copied().flatten().ok_or(MeasureError::MissingLandmark(i))?;
        if q.x.is_finite() && q.y.is_finite() { Ok(q) } else { Err(MeasureError::NonFinite) }
    };
    let dist = |a: Point2, b: Point2| (a - b).norm();
    let nasion = nalgebra::center(&p(ENDO_R)?, &p(ENDO_L)?);
    let d = [
        dist(p(GNATHION)?, nasion),
        dist(p(ZYGION_R)?, p(ZYGION_L)?),
        dist(p(EXO_R)?, p(EXO_L)?),
        dist(p(ENDO_R)?, p(ENDO_L)?),
        dist(nasion, p(SUBNASALE)?),
        dist(p(ALARE_R)?, p(ALARE_L)?),
        dist(p(LABIALE_SUP)?, p(LABIALE_INF)?),
        dist(p(CHEILION_R)?, p(CHEILION_L)?),
        dist(p(LABIALE_SUP)?, p(STOMION_1)?),
        dist(p(STOMION_2)?, p(LABIALE_INF)?),
        dist(p(LABIALE_INF)?, p(GNATHION)?),
        dist(p(SUBNASALE)?, p(LABIALE_SUP)?),
        dist(p(SUBNASALE)?, p(GNATHION)?),
    ];
    Ok(FacialDistances { d })
}

/// The 12 index values (×100), `values[i]` for `FacialIndex::ALL[i]`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct FacialIndices {
    pub values: [f64; 12],
}

impl FacialIndices {
    /// The value of one index.
    pub fn get(&self, index: FacialIndex) -> f64 {
        self.values[index.position()]
    }
}

/// The 12 indices from distances: `100 · D_num / D_den`.
///
/// # Errors
/// `DegenerateReference` when a denominator distance is zero (coincident points).
pub fn indices_from_distances(d: &FacialDistances) -> Result<FacialIndices, MeasureError> {
    let mut values = [0.0; 12];
    for (v, index) in values.iter_mut().zip(FacialIndex::ALL) {
        let (num, den) = index.ratio();
        let den = d.get(den);
        if den.is_nan() || den <= 1e-12 {
            return Err(MeasureError::DegenerateReference(den));
        }
        *v = 100.0 * d.get(num) / den;
    }
    Ok(FacialIndices { values })
}

/// The 12 facial indices of 68 points (`None` = unavailable): video landmarks of a neutral
/// frame, or a head's frontal landmark projection (`mesh::frontal_landmarks`).
///
/// # Errors
/// As [`facial_distances`] and [`indices_from_distances`].
///
/// ```
/// # use lipmap::math::Point2;
/// // Any face: indices are ratios, so scaling the points leaves them unchanged.
/// let pts: Vec<_> = (0..68)
///     .map(|i| Some(Point2::new((i as f64 * 1.3).sin() * 50.0, i as f64)))
///     .collect();
/// let a = lipmap::measure::facial_indices(&pts).unwrap();
/// let scaled: Vec<_> = pts.iter().map(|p| p.map(|p| Point2::new(p.x * 3.0, p.y * 3.0))).collect();
/// let b = lipmap::measure::facial_indices(&scaled).unwrap();
/// assert!((a.values[0] - b.values[0]).abs() < 1e-9);
/// ```
pub fn facial_indices(points: &[Option<Point2>]) -> Result<FacialIndices, MeasureError> {
    indices_from_distances(&facial_distances(points)?)
}

/// The indices whose points are all present, NaN for the others: a head whose landmark map
/// leaves points unmapped (eos's SFM map has no face contour, so no zygion: facial and
/// nose–face width are NaN, the other ten are computed). NaN values have no class
/// ([`BoundsTable::classify`]) and raise no matching warning. Same distances as
/// [`facial_distances`]; a unit test checks the two agree on complete points.
pub fn facial_indices_partial(points: &[Option<Point2>]) -> FacialIndices {
    use lm::*;
    let p =
        |i: usize| points.get(i).copied().flatten().filter(|q| q.x.is_finite() && q.y.is_finite());
    let dist = |a: Option<Point2>, b: Option<Point2>| match (a, b) {
        (Some(a), Some(b)) => (a - b).norm(),
        _ => f64::NAN,
    };
    let nasion = p(ENDO_R).zip(p(ENDO_L)).map(|(a, b)| nalgebra::center(&a, &b));
    let d = FacialDistances {
        d: [
            dist(p(GNATHION), nasion),
            dist(p(ZYGION_R), p(ZYGION_L)),
            dist(p(EXO_R), p(EXO_L)),
            dist(p(ENDO_R), p(ENDO_L)),
            dist(nasion, p(SUBNASALE)),
            dist(p(ALARE_R), p(ALARE_L)),
            dist(p(LABIALE_SUP), p(LABIALE_INF)),
            dist(p(CHEILION_R), p(CHEILION_L)),
            dist(p(LABIALE_SUP), p(STOMION_1)),
            dist(p(STOMION_2), p(LABIALE_INF)),
            dist(p(LABIALE_INF), p(GNATHION)),
            dist(p(SUBNASALE), p(LABIALE_SUP)),
            dist(p(SUBNASALE), p(GNATHION)),
        ],
    };
    let mut values = [f64::NAN; 12];
    for (v, index) in values.iter_mut().zip(FacialIndex::ALL) {
        let (num, den) = index.ratio();
        let den = d.get(den);
        if den > 1e-12 {
            *v = 100.0 * d.get(num) / den;
        }
    }
    FacialIndices { values }
}

/// [`facial_indices_partial`] of a head shape's frontal landmark projection.
pub fn shape_indices_partial(shape: &DVector, map: &LandmarkMap) -> FacialIndices {
    facial_indices_partial(&crate::measure::mesh::frontal_landmarks(shape, map))
}

/// The facial indices of one tracked frame (visible points only).
///
/// # Errors
/// As [`facial_indices`]; occluded points count as missing.
pub fn frame_indices(frame: &FrameLandmarks) -> Result<FacialIndices, MeasureError> {
    facial_indices(&crate::measure::mouth::visible_points(frame))
}

/// The facial indices of a head shape (flat model-space `x0 y0 z0 …`, typically its
/// neutral pose or the model mean) on the frontal projection of its mapped landmark
/// vertices: the head side of the speaker–head match.
///
/// # Errors
/// As [`facial_indices`]; an unmapped landmark counts as missing.
pub fn shape_indices(shape: &DVector, map: &LandmarkMap) -> Result<FacialIndices, MeasureError> {
    facial_indices(&crate::measure::mesh::frontal_landmarks(shape, map))
}
