//! The analysis screen: the error tables (sortable; Enter opens a row's frame or sentence)
//! over the W/H/P trajectories of video, fitted head and speech-driven head. `state`,
//! `update`, `view` as every screen.

pub mod state;
pub mod update;
pub mod view;

pub use state::{
    AnalysisData, AnalysisRow, AnalysisScreen, AnalysisTable, AnalysisView, SpeechSeries,
    Trajectory,
};
