//! iBUG-68 landmarks: point names and groups, the F1..F5 fitting sets, and the per-frame
//! `Track` of tracked points with visibility, confidence and source.

pub mod closure;
pub mod edit;
pub mod flags;
mod flags_lips;
mod flags_motion;
mod flags_procrustes;
pub mod ibug;
pub mod track;

pub use ibug::{LandmarkNames, LandmarkSet, N_LANDMARKS, landmark_name};
pub use track::{FrameLandmarks, LandmarkPoint, PointSource, Track};

/// The largest frame number lipmap accepts: 2²⁰ − 1, 9.7 hours at 30 fps or 17 minutes at
/// 1000 fps. Per-frame tables are indexed by frame number, so this bound (checked where
/// frame numbers enter: landmark readers, session files) is what keeps their memory tied to
/// real recordings rather than to a number written in a file.
pub const MAX_FRAME: usize = (1 << 20) - 1;
