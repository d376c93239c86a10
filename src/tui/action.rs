//! `Action`: every user intent the TUI knows, as one serde enum (bindable in a keymap file),
//! plus the internal replies from workers and the terminal (not bindable, never serialized).
//!
//! Keys become actions in `keymap`; only `update::update` turns actions into state changes.
//! `Action::describe` gives the one-line text the help overlay and hints show.

use super::app::{AnalysisData, FrameImage, HeadFrame, PreparedHead};
use crate::fit::FrameFit;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// A user intent or a reply from a worker.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub enum Action {
    // ---- everywhere ----
    Quit,
    ToggleHelp,
    Save,
    Undo,
    Redo,
    RunFit,
    ShowFrames,
    ShowHead,
    ShowFit,
    ShowAnalysis,
    ShowSide,
    /// Save and open the session's next / previous clip.
    NextClip,
    PrevClip,
    NextFrame,
    PrevFrame,
    FirstFrame,
    LastFrame,
    NextFlagged,
    PrevFlagged,
    NextUnreviewed,
    /// Play the clip at its frame rate, or stop.
    TogglePlay,
    /// Ask for a frame number and jump there.
    GotoFramePrompt,
    ZoomIn,
    ZoomOut,
    ZoomReset,
    /// Pan the view by `dx, dy` tenths of the visible width/height.
    Pan {
        dx: i32,
        dy: i32,
    },
    /// Centre the view on the selected point.
    CenterOnPoint,
    /// Close the top overlay or cancel the pending prompt.
    Cancel,

    // ---- frames and fit views: correcting landmarks ----
    /// Move the selected point (or the selected scope) by `dx, dy` steps; a step is one image
    /// pixel at zoom 1 and shrinks with zoom (sub-pixel moves when zoomed).
    Nudge {
        dx: i32,
        dy: i32,
    },
    NextPoint,
    PrevPoint,
    /// Ask for a point number (0-based iBUG) and select it.
    GotoPointPrompt,
    /// Cycle what moves together: point → its group → mouth → all points.
    CycleScope,
    ToggleVisible,
    CopyPointFromPrev,
    CopyFrameFromPrev,
    /// Ask for N and propagate the selected points' correction to the next N frames.
    PropagatePrompt,
    /// Interpolate the selected points between hand-corrected keyframes over the clip.
    InterpolateSelected,
    InterpolateAll,
    RevertPoint,
    ToggleReviewed,

    // ---- head view: mesh and labelling ----
    /// Rotate the head by `yaw, pitch` degrees.
    Rotate {
        yaw: i32,
        pitch: i32,
    },
    ResetView,
    /// Move the 2D labelling cursor by `dx, dy` hundredths of the head's radius (÷ zoom).
    MoveCursor {
        dx: i32,
        dy: i32,
    },
    NextLabel,
    PrevLabel,
    /// Ask for the landmark number to label.
    GotoLabelPrompt,
    /// Assign the vertex under the 3D cursor to the landmark being labelled.
    ConfirmLabel,
    /// Remove the landmark's vertex from the map.
    ClearLabel,
    /// Put the 3D cursor on the vertex the current frame suggests for this landmark (its
    /// fitted pose, or a pose from the labels so far); Enter then assigns it.
    SuggestLabel,
    /// Assign every unmapped landmark its suggested vertex (one undo step).
    SuggestAllLabels,
    /// Switch the head view between shaded and wireframe.
    ToggleWireframe,
    SaveMap,
    /// Replace the labels with the session's map file (undoable).
    LoadMap,
    /// Show the next head: the model (labelling) → each transferred head → the model.
    CycleHead,

    // ---- side view: the upper lip's foremost point ----
    /// Move the side frame's upper-lip point by `dx, dy` display pixels (a correction).
    NudgeLipPoint {
        dx: i32,
        dy: i32,
    },
    /// Drop the side frame's correction: the automatic point again.
    RevertLipPoint,

    // ---- analysis view ----
    RowDown,
    RowUp,
    NextTable,
    SortNextColumn,
    SortReverse,
    /// Jump to the frame of the selected row in the frames view.
    OpenRow,
    /// Draw the speech-driven head's series in the charts, or hide it.
    ToggleSpeech,
    /// Cross-validate quality prediction (SAQP) over the session's clips and list the
    /// held-out sentences.
    AssessQuality,

    // ---- help overlay ----
    ScrollDown,
    ScrollUp,

    // ---- internal: prompts, mouse, terminal and worker replies (not bindable) ----
    #[serde(skip)]
    PromptChar(char),
    #[serde(skip)]
    PromptBackspace,
    #[serde(skip)]
    PromptSubmit,
    #[serde(skip)]
    MouseDown {
        col: u16,
        row: u16,
    },
    #[serde(skip)]
    MouseDrag {
        col: u16,
        row: u16,
    },
    #[serde(skip)]
    MouseUp,
    #[serde(skip)]
    Resize {
        width: u16,
        height: u16,
    },
    #[serde(skip)]
    FrameLoaded {
        frame: usize,
        image: Arc<FrameImage>,
    },
    #[serde(skip)]
    FrameFailed {
        frame: usize,
        error: String,
    },
    #[serde(skip)]
    FitProgress {
        generation: u64,
        done: usize,
        total: usize,
    },
    #[serde(skip)]
    FitDone {
        generation: u64,
        fits: Vec<FrameFit>,
    },
    #[serde(skip)]
    FitFailed {
        generation: u64,
        error: String,
    },
    #[serde(skip)]
    AnalysisReady {
        generation: u64,
        data: AnalysisData,
    },
    /// The side view's setup and profile points, measured on a worker.
    #[serde(skip)]
    SideReady {
        side: Box<super::app::SideView>,
    },
    #[serde(skip)]
    SideFailed {
        error: String,
    },
    #[serde(skip)]
    SideFrameLoaded {
        frame: usize,
        image: Arc<FrameImage>,
    },
    #[serde(skip)]
    SideFrameFailed {
        frame: usize,
        error: String,
    },
    /// A map read from `path` by `LoadMap`.
    #[serde(skip)]
    MapLoaded {
        map: crate::model::LandmarkMap,
        path: String,
    },
    /// The fits of a `FitDone` were written to the session's fit cache.
    #[serde(skip)]
    FitsStored,
    #[serde(skip)]
    FitsNotStored {
        error: String,
    },
    /// The user has not edited for a while (`run::AUTOSAVE_IDLE`): a moment to autosave.
    #[serde(skip)]
    Idle,
    #[serde(skip)]
    Saved {
        generation: u64,
    },
    #[serde(skip)]
    SaveFailed {
        error: String,
    },
    #[serde(skip)]
    Status(String),
    /// Playback's clock: the next frame is due.
    #[serde(skip)]
    PlayTick,
    /// The speech-driven head's series, driven on a worker from the clip's audio.
    #[serde(skip)]
    SpeechReady {
        series: Vec<(String, Vec<(f64, f64)>)>,
    },
    /// Why the clip has no speech-driven head.
    #[serde(skip)]
    SpeechAbsent {
        why: String,
    },
    /// The quality cross-validation's tables, computed on a worker.
    #[serde(skip)]
    QualityReady {
        tables: Vec<crate::tui::app::AnalysisTable>,
        summary: String,
    },
    /// Why there is no quality cross-validation.
    #[serde(skip)]
    QualityFailed {
        error: String,
    },
    /// Transferred head `index` set up on a worker, or why not.
    #[serde(skip)]
    HeadPrepared {
        index: usize,
        head: Result<Arc<PreparedHead>, String>,
    },
    /// A frame of a transferred head, computed on a worker.
    #[serde(skip)]
    HeadFrameReady(HeadFrame),
}

impl Action {
    /// Whether this is a user intent (bindable to a key), not an internal reply.
    pub fn is_bindable(&self) -> bool {
        self.describe() != "internal"
    }

    /// One line for the help overlay and the status hints.
    pub fn describe(&self) -> String {
        let s = match self {
            Self::Quit => "save and quit",
            Self::ToggleHelp => "show or hide this help",
            Self::Save => "save the session now",
            Self::Undo => "undo the last edit",
            Self::Redo => "redo the undone edit",
            Self::RunFit => "fit the clip (only frames edited since the last fit)",
            Self::ShowFrames => "frames view: correct landmarks",
            Self::ShowHead => "head view: mesh, landmark labelling",
            Self::ShowFit => "fit view: fitted vs tracked landmarks",
            Self::ShowAnalysis => "analysis view: error tables, trajectories",
            Self::ShowSide => "side view: the lip profile and its protrusion point",
            Self::NextClip => "save and open the next clip",
            Self::PrevClip => "save and open the previous clip",
            Self::NextFrame => "next frame",
            Self::PrevFrame => "previous frame",
            Self::FirstFrame => "first frame",
            Self::LastFrame => "last frame",
            Self::NextFlagged => "next flagged frame",
            Self::PrevFlagged => "previous flagged frame",
            Self::NextUnreviewed => "next frame not yet reviewed",
            Self::TogglePlay => "play the clip / stop",
            Self::GotoFramePrompt => "go to frame number…",
            Self::ZoomIn => "zoom in",
            Self::ZoomOut => "zoom out",
            Self::ZoomReset => "fit the image to the view",
            Self::Pan { .. } => "pan the view",
            Self::CenterOnPoint => "centre the view on the selected point",
            Self::Cancel => "cancel / close overlay",
            Self::Nudge { dx, dy } if dx.abs() > 1 || dy.abs() > 1 => "move point 10 screen pixels",
            Self::Nudge { .. } => "move point 1 screen pixel (sub-pixel when zoomed)",
            Self::NextPoint => "select next point",
            Self::PrevPoint => "select previous point",
            Self::GotoPointPrompt => "select point by number (0-67)…",
            Self::CycleScope => "what moves: point / group / mouth / all",
            Self::ToggleVisible => "toggle visible / occluded",
            Self::CopyPointFromPrev => "copy selected points from previous frame",
            Self::CopyFrameFromPrev => "copy all points from previous frame",
            Self::PropagatePrompt => "propagate correction to next N frames…",
            Self::InterpolateSelected => "interpolate selected between keyframes",
            Self::InterpolateAll => "interpolate all points between keyframes",
            Self::RevertPoint => "revert selected points to tracker values",
            Self::ToggleReviewed => "mark frame reviewed / not reviewed",
            Self::Rotate { .. } => "rotate the head",
            Self::ResetView => "reset rotation and zoom",
            Self::MoveCursor { .. } => "move the 3D cursor",
            Self::NextLabel => "label the next landmark",
            Self::PrevLabel => "label the previous landmark",
            Self::GotoLabelPrompt => "label landmark number…",
            Self::ConfirmLabel => "assign the vertex under the cursor",
            Self::ClearLabel => "remove this landmark's vertex",
            Self::SuggestLabel => "suggest a vertex from the current frame",
            Self::SuggestAllLabels => "label all unmapped landmarks from suggestions",
            Self::SaveMap => "save the landmark map (eos format)",
            Self::ToggleWireframe => "shaded or wireframe head",
            Self::LoadMap => "load the session's map file over the labels",
            Self::CycleHead => "show the model / each transferred head",
            Self::NudgeLipPoint { dx, dy } if dx.abs() > 1 || dy.abs() > 1 => {
                "move the lip point 10 screen pixels"
            }
            Self::NudgeLipPoint { .. } => "move the lip point 1 screen pixel",
            Self::RevertLipPoint => "back to the automatic lip point",
            Self::RowDown => "next row",
            Self::RowUp => "previous row",
            Self::NextTable => "next table",
            Self::SortNextColumn => "sort by the next column",
            Self::SortReverse => "reverse the sort order",
            Self::OpenRow => "open the row's frame in the frames view",
            Self::ToggleSpeech => "show / hide the speech-driven head in the charts",
            Self::AssessQuality => {
                "cross-validate quality prediction (SAQP) over the session's sentences"
            }
            Self::ScrollDown => "scroll down",
            Self::ScrollUp => "scroll up",
            Self::PromptChar(_)
            | Self::PromptBackspace
            | Self::PromptSubmit
            | Self::MouseDown { .. }
            | Self::MouseDrag { .. }
            | Self::MouseUp
            | Self::Resize { .. }
            | Self::FrameLoaded { .. }
            | Self::FrameFailed { .. }
            | Self::FitProgress { .. }
            | Self::FitDone { .. }
            | Self::FitFailed { .. }
            | Self::AnalysisReady { .. }
            | Self::MapLoaded { .. }
            | Self::SideReady { .. }
            | Self::SideFailed { .. }
            | Self::SideFrameLoaded { .. }
            | Self::SideFrameFailed { .. }
            | Self::FitsStored
            | Self::FitsNotStored { .. }
            | Self::Idle
            | Self::Saved { .. }
            | Self::SaveFailed { .. }
            | Self::Status(_)
            | Self::PlayTick
            | Self::SpeechReady { .. }
            | Self::SpeechAbsent { .. }
            | Self::QualityReady { .. }
            | Self::QualityFailed { .. }
            | Self::HeadPrepared { .. }
            | Self::HeadFrameReady(_) => "internal",
        };
        match self {
            Self::Pan { dx, dy } => format!("{s} {}", arrow(*dx, *dy)),
            Self::Nudge { dx, dy } | Self::NudgeLipPoint { dx, dy } => {
                format!("{s} {}", arrow(*dx, *dy))
            }
            Self::Rotate { yaw, pitch } => format!("{s} {}", arrow(*yaw, *pitch)),
            Self::MoveCursor { dx, dy } => format!("{s} {}", arrow(*dx, *dy)),
            _ => s.to_string(),
        }
    }
}

fn arrow(dx: i32, dy: i32) -> &'static str {
    match (dx.signum(), dy.signum()) {
        (1, _) => "→",
        (-1, _) => "←",
        (_, 1) => "↓",
        (_, -1) => "↑",
        _ => "",
    }
}
