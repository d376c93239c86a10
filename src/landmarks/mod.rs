//! iBUG-68 landmarks: point names and groups, the F1..F5 fitting sets, and the per-frame
//! `Track` of tracked points with visibility, confidence and source.

pub mod edit;
pub mod flags;
mod flags_lips;
mod flags_motion;
mod flags_procrustes;
pub mod ibug;
pub mod track;

pub use ibug::{LandmarkSet, N_LANDMARKS, landmark_name};
pub use track::{FrameLandmarks, LandmarkPoint, PointSource, Track};
