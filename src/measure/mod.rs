//! Mouth measures (W, H, P) from 2D landmarks and from fitted meshes, their per-frame
//! `Trajectory` container, and the 12 facial indices used to match a speaker to a head.
//!
//! Start with [`mouth::measure_frame`] (video landmarks), [`mesh::measure_shape`] (a fitted
//! model-space shape) and [`indices::facial_indices`]. Every trajectory in lipmap is a
//! [`Trajectory`]: one `Vec<Option<f64>>` per measure, indexed by 0-based frame number, with
//! `None` where a frame has no value (untracked, occluded, failed fit); evaluation skips those.

pub mod indices;
pub mod lip_reach;
pub mod mesh;
pub mod mouth;
pub mod pose;
pub mod profile;

use serde::{Deserialize, Serialize};
use std::fmt;

pub use indices::{
    BoundsTable, FacialIndex, FacialIndices, IndexBounds, IndexClass, MatchVerdict, MatchWarning,
    choose_neutral_frame, facial_indices, match_speaker_head, shape_indices,
};
pub use mesh::{MeshMeasureOptions, ReferencePlane, UpperLip, measure_shape};
pub use mouth::{measure_frame, measure_points, min_max_normalise, reference_length};
pub use pose::PoseComparison;

/// One per-frame value series; `None` marks a frame without a value.
pub type Series = Vec<Option<f64>>;

/// The three mouth measures, used to pick a series or a column.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
pub enum Measure {
    /// Mouth width: inner lip corners |p60 − p64| over the reference length.
    W,
    /// Mouth height: inner lip midpoints |p62 − p66| over the reference length.
    H,
    /// Upper-lip protrusion along the face's forward axis over |nasion − nose tip|.
    P,
}

impl Measure {
    /// W, H and P in table order.
    pub const ALL: [Measure; 3] = [Measure::W, Measure::H, Measure::P];

    /// The one-letter column name (`"W"`, `"H"`, `"P"`).
    pub fn as_str(self) -> &'static str {
        match self {
            Measure::W => "W",
            Measure::H => "H",
            Measure::P => "P",
        }
    }
}

impl fmt::Display for Measure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// W, H and (when the source can give it) P of one frame, all normalised by their
/// reference lengths (dimensionless).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct MouthMeasures {
    pub w: f64,
    pub h: f64,
    /// Protrusion; `None` for 2D landmarks, which cannot see it.
    pub p: Option<f64>,
}

/// Why a measure could not be taken. Trajectory builders turn these into `None` frames.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum MeasureError {
    /// A landmark the measure needs is not visible (2D) or not mapped to a vertex (mesh).
    #[error("landmark {} is missing (not visible or not mapped)", crate::landmarks::PointNo(*.0))]
    MissingLandmark(usize),
    /// A mapped vertex index lies outside the shape.
    #[error(
        "vertex {vertex} (landmark {}) is outside a shape of {n_vertices} vertices",
        crate::landmarks::PointNo(*.landmark)
    )]
    VertexOutOfRange { landmark: usize, vertex: usize, n_vertices: usize },
    /// The normalising length is zero or not finite, so the ratio is meaningless.
    #[error("reference length {0} is degenerate")]
    DegenerateReference(f64),
    /// A coordinate or result is NaN or infinite.
    #[error("non-finite coordinate or result")]
    NonFinite,
    /// No vertex was given for the upper lip.
    #[error("no upper-lip vertex available")]
    NoUpperLip,
    /// The shape vector's length is not a multiple of 3.
    #[error("shape length {0} is not a multiple of 3")]
    BadShapeLength(usize),
}

/// The W, H, P trajectories of one clip, indexed by 0-based frame number.
///
/// `p` is empty (or all `None`) when the source has no protrusion. All three series may have
/// different lengths; a frame past a series' end reads as `None`.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Trajectory {
    pub w: Series,
    pub h: Series,
    #[serde(default)]
    pub p: Series,
}

impl Trajectory {
    /// Builds a trajectory from per-frame measures (frame i = element i); `None` frames
    /// (and `p: None`) become `None` entries.
    pub fn from_frames(frames: &[Option<MouthMeasures>]) -> Self {
        let w = frames.iter().map(|m| m.map(|m| m.w)).collect();
        let h = frames.iter().map(|m| m.map(|m| m.h)).collect();
        let p: Series = frames.iter().map(|m| m.and_then(|m| m.p)).collect();
        let p = if p.iter().all(Option::is_none) { Vec::new() } else { p };
        Self { w, h, p }
    }

    /// The series of one measure.
    pub fn series(&self, m: Measure) -> &[Option<f64>] {
        match m {
            Measure::W => &self.w,
            Measure::H => &self.h,
            Measure::P => &self.p,
        }
    }

    /// Mutable access to one measure's series.
    pub fn series_mut(&mut self, m: Measure) -> &mut Series {
        match m {
            Measure::W => &mut self.w,
            Measure::H => &mut self.h,
            Measure::P => &mut self.p,
        }
    }

    /// The value of measure `m` at frame `frame`, `None` when absent or out of range.
    pub fn get(&self, m: Measure, frame: usize) -> Option<f64> {
        self.series(m).get(frame).copied().flatten()
    }

    /// Number of frames: the longest series' length.
    pub fn len(&self) -> usize {
        self.w.len().max(self.h.len()).max(self.p.len())
    }

    /// Whether no series has any frame.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// Whether the trajectory carries any protrusion value.
    pub fn has_p(&self) -> bool {
        self.p.iter().any(Option::is_some)
    }

    /// Each series min–max normalised to [0, 1] on its own (see [`min_max_normalise`]);
    /// a series that cannot be normalised (fewer than two values, or constant) becomes all
    /// `None`, so it drops out of the evaluation instead of giving fake zeros.
    pub fn min_max_normalised(&self) -> Self {
        let norm = |s: &Series| min_max_normalise(s).unwrap_or_else(|| vec![None; s.len()]);
        Self { w: norm(&self.w), h: norm(&self.h), p: norm(&self.p) }
    }
}
