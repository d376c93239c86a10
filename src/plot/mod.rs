//! PNG charts drawn without system fonts: W/H/P trajectories of video vs 3D head over time,
//! with phoneme boundaries and labels. Pure pixel work; writing the file is the caller's.

pub mod font;
pub mod trajectory;

pub use trajectory::{Panel, Series, TrajectoryPlot, draw_trajectories};
