//! `update(&mut App, Action)`: the only place the TUI's state changes. It routes each action
//! to the file that owns it: one per view (`frames`, `head`, `fit`, `analysis`, `side`),
//! `global` for what works everywhere (saving, quitting, views, frame navigation, prompts),
//! `replies` for what workers and the run loop send back. Edits go through
//! `landmarks::edit` and land on an unlimited undo stack (`edits`); slow work is queued as
//! `Effect`s for the run loop to carry out.
//!
//! Also here: turning key and mouse events into actions (`input`), because which table a key
//! is looked up in depends on the `App`.

mod analysis;
mod edits;
mod fit;
mod frames;
mod global;
mod head;
mod input;
mod replies;
mod side;
mod transferred;

pub use global::request_images;
pub use input::{key_to_action, mode_chain, mouse_to_action};

use super::action::Action;
use super::app::{App, View};

/// Default number of frames `PropagatePrompt` covers when the user just presses Enter.
pub const DEFAULT_PROPAGATE: usize = 10;
/// Zoom limits; 64× makes one image pixel 64 display pixels, enough for sub-pixel work.
pub const MAX_ZOOM: f64 = 64.0;

/// Applies one action; may return a follow-up action to apply next.
pub fn update(app: &mut App, action: Action) -> Option<Action> {
    use Action as A;
    // A message answers the key that caused it; the next key clears it.
    // (`Save` may come from autosave, which must not wipe the message of the edit it saves.)
    if action.is_bindable() && !matches!(action, A::Cancel | A::Save) {
        app.status.clear();
    }
    match action {
        A::ZoomIn | A::ZoomOut | A::ZoomReset if app.view == View::Head => {
            head::update(app, action);
        }
        A::ZoomIn
        | A::ZoomOut
        | A::ZoomReset
        | A::Pan { .. }
        | A::CenterOnPoint
        | A::Nudge { .. }
        | A::NextPoint
        | A::PrevPoint
        | A::CycleScope
        | A::ToggleVisible
        | A::CopyPointFromPrev
        | A::CopyFrameFromPrev
        | A::InterpolateSelected
        | A::InterpolateAll
        | A::RevertPoint
        | A::ToggleReviewed
        | A::MouseDown { .. }
        | A::MouseDrag { .. }
        | A::MouseUp => frames::update(app, action),
        A::Rotate { .. }
        | A::ResetView
        | A::MoveCursor { .. }
        | A::NextLabel
        | A::PrevLabel
        | A::ConfirmLabel
        | A::ClearLabel
        | A::SuggestLabel
        | A::SuggestAllLabels
        | A::ToggleWireframe
        | A::LoadMap
        | A::SaveMap => head::update(app, action),
        A::RunFit => fit::run_fit(app),
        A::RowDown
        | A::RowUp
        | A::NextTable
        | A::SortNextColumn
        | A::SortReverse
        | A::OpenRow
        | A::ToggleSpeech
        | A::SpeechReady { .. }
        | A::SpeechAbsent { .. }
        | A::AssessQuality
        | A::QualityReady { .. }
        | A::QualityFailed { .. } => analysis::update(app, action),
        A::CycleHead | A::HeadPrepared { .. } | A::HeadFrameReady(_) => {
            transferred::update(app, action)
        }
        A::NudgeLipPoint { .. } | A::RevertLipPoint => side::update(app, action),
        A::FrameLoaded { .. }
        | A::FrameFailed { .. }
        | A::FitProgress { .. }
        | A::FitDone { .. }
        | A::FitFailed { .. }
        | A::FitsStored
        | A::FitsNotStored { .. }
        | A::AnalysisReady { .. }
        | A::SideReady { .. }
        | A::SideFailed { .. }
        | A::SideFrameLoaded { .. }
        | A::SideFrameFailed { .. }
        | A::MapLoaded { .. }
        | A::Saved { .. }
        | A::SaveFailed { .. }
        | A::Status(_) => replies::update(app, action),
        A::Quit
        | A::ToggleHelp
        | A::Cancel
        | A::ScrollDown
        | A::ScrollUp
        | A::Save
        | A::Undo
        | A::Redo
        | A::ShowFrames
        | A::ShowHead
        | A::ShowFit
        | A::ShowAnalysis
        | A::ShowSide
        | A::NextClip
        | A::PrevClip
        | A::NextFrame
        | A::PrevFrame
        | A::FirstFrame
        | A::LastFrame
        | A::NextFlagged
        | A::PrevFlagged
        | A::NextUnreviewed
        | A::TogglePlay
        | A::PlayTick
        | A::GotoFramePrompt
        | A::GotoPointPrompt
        | A::PropagatePrompt
        | A::GotoLabelPrompt
        | A::PromptChar(_)
        | A::PromptBackspace
        | A::PromptSubmit
        | A::Resize { .. }
        | A::Idle => global::update(app, action),
    }
    None
}
