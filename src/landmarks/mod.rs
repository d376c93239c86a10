//! iBUG-68 landmarks: point names and groups, the F1..F5 fitting sets, and the per-frame
//! `Track` of tracked points with visibility, confidence and source.

pub mod closure;
pub mod edit;
pub mod flags;
mod flags_image;
mod flags_lips;
mod flags_motion;
mod flags_procrustes;
mod flags_tracker;
pub mod ibug;
pub mod track;

pub use ibug::{LandmarkNames, LandmarkSet, N_LANDMARKS, PointNo};
pub use track::{FrameLandmarks, LandmarkPoint, PointSource, Track};

/// The largest frame number lipmap accepts: 2²⁰ − 1, 9.7 hours at 30 fps or 17 minutes at
/// 1000 fps. Per-frame tables are indexed by frame number, so this bound (checked where
/// frame numbers enter: landmark readers, session files) is what keeps their memory tied to
/// real recordings rather than to a number written in a file.
pub const MAX_FRAME: usize = (1 << 20) - 1;

/// Largest landmark coordinate magnitude accepted, in pixels (about 30 times the largest
/// image side). A point may lie off the image, as when a face leaves the frame, but never
/// this far; past it the squared distances that fits and measures sum stop being finite.
pub const MAX_COORDINATE_PX: f64 = 1e6;

/// The first point of `frame` with a coordinate beyond [`MAX_COORDINATE_PX`] (or not
/// finite), as `point N (x, y)` for a message (N 1-based, as people number the points).
pub fn point_out_of_bounds(frame: &FrameLandmarks) -> Option<String> {
    let ok = |v: f64| v.is_finite() && v.abs() <= MAX_COORDINATE_PX;
    frame.points.iter().enumerate().find(|(_, p)| !(ok(p.x) && ok(p.y))).map(|(i, p)| {
        format!(
            "point {} ({}, {}) is not within ±{MAX_COORDINATE_PX:e} px",
            PointNo(i),
            crate::math::short_number(p.x),
            crate::math::short_number(p.y)
        )
    })
}
