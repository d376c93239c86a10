//! `Action`: every user intent the TUI knows (a *command*, bindable in a keymap file) and every
//! reply from a job, the terminal or a prompt (a *reply*, never bound or serialized), declared
//! once in the `actions!` table below.
//!
//! One entry gives the variant and its fields, the screen and function that handle it (its
//! route) and, for a command, the line the help overlay shows. From the table come the enum
//! (its variant name is the name keymap files use), `Action::name`, `Action::describe`,
//! `Action::is_bindable`, `Action::COMMANDS` and the dispatch `update::update` calls.
//!
//! A handler takes the `App` and the variant's fields in order (`Nudge { dx: i32, dy: i32 }`
//! calls `frames::nudge(app, dx, dy)`) and returns `()` or `Option<Action>`, a follow-up
//! `update` applies next. Adding an action: see the `tui` module docs.

use super::screens::analysis::{AnalysisData, AnalysisTable};
use super::screens::head::{HeadFrame, PreparedHead};
use super::screens::side::SideView;
use crate::fit::FrameFit;
use crate::landmarks::FrameLandmarks;
use crate::tui::app::{App, FrameImage};
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// The modules whose functions the table names: each screen's `update.rs` (and `heads` for
/// the transferred heads the head screen shows), `overlays` for help and prompts, `global`
/// for what works on every screen, and `shown` for what goes to whichever screen is shown.
mod routes {
    pub(super) use crate::tui::global;
    pub(super) use crate::tui::overlays::update as overlays;
    pub(super) use crate::tui::screens as shown;
    pub(super) use crate::tui::screens::analysis::update as analysis;
    pub(super) use crate::tui::screens::fit::update as fit;
    pub(super) use crate::tui::screens::frames::tracking;
    pub(super) use crate::tui::screens::frames::update as frames;
    pub(super) use crate::tui::screens::head::transferred as heads;
    pub(super) use crate::tui::screens::head::update as head;
    pub(super) use crate::tui::screens::side::update as side;
}

/// What a handler may give back to `update`: nothing, or a follow-up action.
pub trait FollowUp {
    fn follow_up(self) -> Option<Action>;
}

impl FollowUp for () {
    fn follow_up(self) -> Option<Action> {
        None
    }
}

impl FollowUp for Option<Action> {
    fn follow_up(self) -> Option<Action> {
        self
    }
}

/// Declares the `Action` enum and what is derived from it; see the module docs.
macro_rules! actions {
    (
        commands {
            $( $(#[$cmeta:meta])*
               $command:ident $({ $($cfield:ident : $ctype:ty),* $(,)? })?
               => $croute:ident :: $chandler:ident, $help:expr; )*
        }
        replies {
            $( $(#[$rmeta:meta])*
               $reply:ident
               $({ $($rfield:ident : $rtype:ty),* $(,)? })?
               $(( $rarg:ident : $rargtype:ty ))?
               => $rroute:ident :: $rhandler:ident; )*
        }
    ) => {
        /// A user intent (bindable) or a reply (not bindable, never serialized).
        #[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
        pub enum Action {
            $( $(#[$cmeta])* $command $({ $($cfield: $ctype),* })?, )*
            $( $(#[$rmeta])* #[serde(skip)] $reply $({ $($rfield: $rtype),* })? $(($rargtype))?, )*
        }

        impl Action {
            /// The names keymap files bind, in the table's order.
            pub const COMMANDS: &'static [&'static str] = &[$(stringify!($command)),*];

            /// The variant's name: for a command, the name keymap files bind it by.
            pub fn name(&self) -> &'static str {
                match self {
                    $( Self::$command { .. } => stringify!($command), )*
                    $( Self::$reply { .. } => stringify!($reply), )*
                }
            }

            /// Whether this is a user intent (bindable to a key), not a reply.
            pub fn is_bindable(&self) -> bool {
                match self {
                    $( Self::$command { .. } => true, )*
                    $( Self::$reply { .. } => false, )*
                }
            }

            /// One line for the help overlay and the status hints; empty for a reply.
            #[allow(unused_variables)]
            pub fn describe(&self) -> String {
                match self {
                    $( Self::$command $({ $($cfield),* })? => ($help).to_string(), )*
                    $( Self::$reply { .. } => String::new(), )*
                }
            }

            /// Calls the action's handler; returns the follow-up it asks for.
            pub(super) fn dispatch(self, app: &mut App) -> Option<Action> {
                match self {
                    $( Self::$command $({ $($cfield),* })? =>
                        FollowUp::follow_up(routes::$croute::$chandler(app $($(, $cfield)*)?)), )*
                    $( Self::$reply $({ $($rfield),* })? $(($rarg))? =>
                        FollowUp::follow_up(routes::$rroute::$rhandler(
                            app $($(, $rfield)*)? $(, $rarg)?
                        )), )*
                }
            }
        }
    };
}

actions! {
    commands {
        // ---- everywhere ----
        Quit => global::quit, "save and quit";
        ToggleHelp => overlays::toggle_help, "show or hide this help";
        Save => global::save, "save the session now";
        Undo => global::undo, "undo the last edit";
        Redo => global::redo, "redo the undone edit";
        RunFit => fit::run_fit, "fit the clip (only frames edited since the last fit)";
        ShowFrames => global::show_frames, "frames view: correct landmarks";
        ShowHead => global::show_head, "head view: mesh, landmark labelling";
        ShowFit => global::show_fit, "fit view: fitted vs tracked landmarks";
        ShowAnalysis => global::show_analysis, "analysis view: error tables, trajectories";
        ShowSide => global::show_side, "side view: the lip profile and its protrusion point";
        /// Save and open the session's next / previous clip.
        NextClip => global::next_clip, "save and open the next clip";
        PrevClip => global::prev_clip, "save and open the previous clip";
        NextFrame => global::next_frame, "next frame";
        PrevFrame => global::prev_frame, "previous frame";
        FirstFrame => global::first_frame, "first frame";
        LastFrame => global::last_frame, "last frame";
        NextFlagged => global::next_flagged, "next flagged frame";
        PrevFlagged => global::prev_flagged, "previous flagged frame";
        NextUnreviewed => global::next_unreviewed, "next frame not yet reviewed";
        /// Play the clip at its frame rate, or stop.
        TogglePlay => global::toggle_play, "play the clip / stop";
        /// Ask for a frame number and jump there.
        GotoFramePrompt => overlays::goto_frame_prompt, "go to frame number…";
        /// Zoom the shown screen's image (frames, fit) or head in, out, or back.
        ZoomIn => shown::zoom_in, "zoom in";
        ZoomOut => shown::zoom_out, "zoom out";
        ZoomReset => shown::zoom_reset, "fit the image to the view";
        /// Pan the view by `dx, dy` tenths of the visible width/height.
        Pan { dx: i32, dy: i32 } => frames::pan, with_arrow("pan the view", *dx, *dy);
        /// Centre the view on the selected point.
        CenterOnPoint => frames::center_on_point, "centre the view on the selected point";
        /// Close the top overlay or cancel the pending prompt.
        Cancel => overlays::cancel, "cancel / close overlay";
        /// Hide the views' side panel for a wider image or head, or show it again.
        ToggleSidePanel => global::toggle_side_panel, "hide or show the side panel";

        // ---- frames and fit views: correcting landmarks ----
        /// Move the selected point (or the selected scope) by `dx, dy` steps; a step is one
        /// image pixel, or one display pixel where that is finer (sub-pixel when zoomed in).
        Nudge { dx: i32, dy: i32 } => frames::nudge, with_arrow(
            if is_big_step(*dx, *dy) {
                "move point 10 image pixels (finer zoomed in)"
            } else {
                "move point 1 image pixel (finer zoomed in)"
            },
            *dx,
            *dy,
        );
        NextPoint => frames::next_point, "select next point";
        PrevPoint => frames::prev_point, "select previous point";
        /// Ask for a point number (1–68, as people number them) and select it.
        GotoPointPrompt => overlays::goto_point_prompt, "select point by number (1–68)…";
        /// Cycle what moves together: point → its group → mouth → all points.
        CycleScope => frames::cycle_scope, "what moves: point / group / mouth / all";
        ToggleVisible => frames::toggle_visible, "toggle visible / occluded";
        CopyPointFromPrev => frames::copy_point_from_prev,
            "copy selected points from previous frame";
        CopyFrameFromPrev => frames::copy_frame_from_prev, "copy all points from previous frame";
        /// Ask for N and propagate the selected points' correction to the next N frames.
        PropagatePrompt => overlays::propagate_prompt, "propagate correction to next N frames…";
        /// Interpolate the selected points between hand-corrected keyframes over the clip.
        InterpolateSelected => frames::interpolate_selected,
            "interpolate selected between keyframes";
        InterpolateAll => frames::interpolate_all, "interpolate all points between keyframes";
        RevertPoint => frames::revert_point, "revert selected points to tracker values";
        ToggleReviewed => frames::toggle_reviewed, "mark frame reviewed / not reviewed";

        // ---- frames view: lipmap's tracker ----
        /// Re-run the tracker's cascade on the frame from its current points with the
        /// corrected ones held, so the others follow them (one undo step).
        RealignFrame => tracking::realign_frame, "re-align the other points to the corrected ones";
        /// Draw a face box for the tracker on this frame (where it found no face, or the wrong
        /// one); confirming tracks this frame from it and the following frames from this one.
        DrawFaceBox => tracking::draw_face_box, "draw a face box to track from…";
        /// Move the face box being drawn by `dx, dy` twentieths of its side.
        MoveFaceBox { dx: i32, dy: i32 } => tracking::move_face_box,
            with_arrow("move the face box", *dx, *dy);
        /// Grow the face box by `percent` of its side (shrink when negative).
        ResizeFaceBox { percent: i32 } => tracking::resize_face_box,
            if *percent >= 0 { "grow the face box" } else { "shrink the face box" };
        /// Track from the face box: this frame, then the following ones.
        ConfirmFaceBox => tracking::confirm_face_box, "track from the face box";

        // ---- head view: mesh and labelling ----
        /// Rotate the head by `yaw, pitch` degrees.
        Rotate { yaw: i32, pitch: i32 } => head::rotate,
            with_arrow("rotate the head", *yaw, *pitch);
        ResetView => head::reset_view, "reset rotation and zoom";
        /// Move the 2D labelling cursor by `dx, dy` hundredths of the head's radius (÷ zoom).
        MoveCursor { dx: i32, dy: i32 } => head::move_cursor,
            with_arrow("move the 3D cursor", *dx, *dy);
        NextLabel => head::next_label, "label the next landmark";
        PrevLabel => head::prev_label, "label the previous landmark";
        /// Ask for the landmark number to label.
        GotoLabelPrompt => overlays::goto_label_prompt, "label landmark number (1–68)…";
        /// Assign the vertex under the 3D cursor to the landmark being labelled.
        ConfirmLabel => head::confirm_label, "assign the vertex under the cursor";
        /// Remove the landmark's vertex from the map.
        ClearLabel => head::clear_label, "remove this landmark's vertex";
        /// Put the 3D cursor on the vertex suggested for this landmark from the other labels
        /// (as `lipmap map suggest`: on the head's own face, else the clip's frame); Enter
        /// then assigns it.
        SuggestLabel => head::suggest_label, "suggest a vertex for this landmark";
        /// Assign every unmapped landmark its suggested vertex (one undo step), as `lipmap
        /// map suggest` would.
        SuggestAllLabels => head::suggest_all_labels,
            "label all unmapped landmarks from suggestions";
        /// Switch the head view between shaded and wireframe.
        ToggleWireframe => head::toggle_wireframe, "shaded or wireframe head";
        SaveMap => head::save_map, "save the landmark map (eos format)";
        /// Replace the labels with the session's map file (undoable).
        LoadMap => head::load_map, "load the session's map file over the labels";
        /// Show the next head: the model (labelling) → each transferred head → the model.
        CycleHead => heads::cycle_head, "show the model / each transferred head";
        /// Save, then label the other mesh's map: the model's (what `fit` uses) or the
        /// head's (what transfer and indices use), when the head is another mesh.
        SwitchLabelledMesh => head::switch_labelled_mesh,
            "label the other mesh: the model's map / the head's map";

        // ---- side view: the upper lip's foremost point ----
        /// Move the side frame's upper-lip point by `dx, dy` steps as `Nudge` does (a
        /// correction).
        NudgeLipPoint { dx: i32, dy: i32 } => side::nudge_lip_point, with_arrow(
            if is_big_step(*dx, *dy) {
                "move the lip point 10 image pixels (finer zoomed in)"
            } else {
                "move the lip point 1 image pixel (finer zoomed in)"
            },
            *dx,
            *dy,
        );
        /// Drop the side frame's correction: the automatic point again.
        RevertLipPoint => side::revert_lip_point, "back to the automatic lip point";

        // ---- analysis view ----
        RowDown => analysis::row_down, "next row";
        RowUp => analysis::row_up, "previous row";
        NextTable => analysis::next_table, "next table";
        SortNextColumn => analysis::sort_next_column, "sort by the next column";
        SortReverse => analysis::sort_reverse, "reverse the sort order";
        /// Jump to the frame of the selected row in the frames view.
        OpenRow => analysis::open_row, "open the row's frame in the frames view";
        /// Draw the speech-driven head's series in the charts, or hide it.
        ToggleSpeech => analysis::toggle_speech,
            "show / hide the speech-driven head in the charts";
        /// Cross-validate quality prediction (SAQP) over the session's clips and list the
        /// held-out sentences.
        AssessQuality => analysis::assess_quality,
            "cross-validate quality prediction (SAQP) over the session's sentences";

        // ---- help overlay ----
        ScrollDown => overlays::scroll_down, "scroll down";
        ScrollUp => overlays::scroll_up, "scroll up";
    }
    replies {
        // ---- prompts and what they ask for ----
        PromptChar(c: char) => overlays::prompt_char;
        PromptBackspace => overlays::prompt_backspace;
        PromptSubmit => overlays::prompt_submit;
        /// Go to frame number `frame` (a prompt's or a table row's answer).
        GoToFrame { frame: usize } => global::go_to_frame;
        /// Select point `index` (the point prompt's answer).
        SelectPoint { index: usize } => frames::select_point;
        /// Propagate the selected points' correction to the next `frames` frames.
        Propagate { frames: usize } => frames::propagate;
        /// Make `landmark` the one being labelled (the label prompt's answer).
        LabelLandmark { landmark: usize } => head::set_label_target;
        /// Save, then open the session's clip number `clip`.
        SwitchClip { clip: usize } => global::switch_clip;

        // ---- the terminal and the run loop ----
        MouseDown { col: u16, row: u16 } => frames::mouse_down;
        MouseDrag { col: u16, row: u16 } => frames::mouse_drag;
        MouseUp => frames::mouse_up;
        Resize { width: u16, height: u16 } => global::resize;
        /// The run loop opened the clip in a terminal of this size: ask for what the first
        /// screen needs (its frames, the analysis).
        Opened { width: u16, height: u16 } => global::opened;
        /// How the user looked at the previous clip of the session, kept for this one.
        Carry { from: Box<crate::tui::global::Carried> } => global::carry;
        /// The user has not edited for a while (`run::AUTOSAVE_IDLE`): a moment to autosave.
        Idle => global::idle;
        /// Playback's clock: the next frame is due.
        PlayTick => global::play_tick;
        Status(text: String) => global::status;

        // ---- jobs ----
        FrameLoaded { frame: usize, image: Arc<FrameImage> } => frames::frame_loaded;
        FrameFailed { frame: usize, error: String } => frames::frame_failed;
        FitProgress { generation: u64, done: usize, total: usize } => fit::fit_progress;
        FitDone { generation: u64, fits: Vec<FrameFit> } => fit::fit_done;
        FitFailed { generation: u64, error: String } => fit::fit_failed;
        /// The fits of a `FitDone` were written to the session's fit cache.
        FitsStored => fit::fits_stored;
        FitsNotStored { error: String } => fit::fits_not_stored;
        AnalysisReady { generation: u64, data: AnalysisData } => analysis::analysis_ready;
        /// The speech-driven head's series, driven on a job from the clip's audio.
        SpeechReady { series: Vec<(String, Vec<(f64, f64)>)> } => analysis::speech_ready;
        /// Why the clip has no speech-driven head.
        SpeechAbsent { why: String } => analysis::speech_absent;
        /// The quality cross-validation's tables, computed on a job.
        QualityReady { tables: Vec<AnalysisTable>, summary: String } => analysis::quality_ready;
        /// Why there is no quality cross-validation.
        QualityFailed { error: String } => analysis::quality_failed;
        /// The side view's setup and profile points, measured on a job.
        SideReady { side: Box<SideView> } => side::side_ready;
        SideFailed { error: String } => side::side_failed;
        SideFrameLoaded { frame: usize, image: Arc<FrameImage> } => side::side_frame_loaded;
        SideFrameFailed { frame: usize, error: String } => side::side_frame_failed;
        /// The image evidence of the whole clip (frame, face size, lip-edge offset), measured
        /// on a job over the frames at start.
        ImagesChecked { offsets: Vec<(usize, f64, crate::landmarks::flags::LipEdgeOffset)> }
            => frames::images_checked;
        /// Map suggestions made on a job (`landmark`: the one `o` asked for), or why none.
        MapSuggested {
            landmark: Option<usize>,
            suggested: Result<Box<crate::workflow::map::SuggestedMap>, String>,
        } => head::map_suggested;
        /// A map read from `path` by `LoadMap`.
        MapLoaded { map: crate::model::LandmarkMap, path: String } => head::map_loaded;
        /// Transferred head `index` set up on a job, or why not.
        HeadPrepared { index: usize, head: Result<Arc<PreparedHead>, String> }
            => heads::head_prepared;
        /// A frame of a transferred head, computed on a job.
        HeadFrameReady(frame: HeadFrame) => heads::head_frame_ready;
        Saved { generation: u64 } => global::saved;
        SaveFailed { error: String } => global::save_failed;
        /// A frame re-aligned by the tracker's job: its landmarks when asked, and after.
        Realigned { before: Box<FrameLandmarks>, after: Box<FrameLandmarks> }
            => tracking::realigned;
        /// Frames tracked from a face box by the tracker's job, the box's frame first.
        TrackedFromBox { frames: Vec<FrameLandmarks> } => tracking::tracked_from_box;
        /// Why the tracker's job could not answer (its files, the frame).
        TrackerFailed { error: String } => tracking::tracker_failed;
    }
}

/// Whether a move of `dx, dy` steps is a big one (the shifted keys' ten).
fn is_big_step(dx: i32, dy: i32) -> bool {
    dx.abs() > 1 || dy.abs() > 1
}

/// `text` and the arrow of the direction `dx, dy`.
fn with_arrow(text: &str, dx: i32, dy: i32) -> String {
    let arrow = match (dx.signum(), dy.signum()) {
        (1, _) => "→",
        (-1, _) => "←",
        (_, 1) => "↓",
        (_, -1) => "↑",
        _ => "",
    };
    format!("{text} {arrow}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_command_is_bindable_by_its_name_and_no_reply_is() {
        for name in Action::COMMANDS {
            // Commands with fields are bound as inline tables; their names are still theirs.
            let unit: Result<Action, _> = toml::Value::String(name.to_string()).try_into();
            if let Ok(a) = unit {
                assert_eq!(a.name(), *name);
                assert!(a.is_bindable() && !a.describe().is_empty(), "{name}");
            }
        }
        let reply = Action::PromptSubmit;
        assert!(!reply.is_bindable() && reply.describe().is_empty());
        assert!(!Action::COMMANDS.contains(&reply.name()));
        let nudge: Action = toml::from_str::<toml::Table>("a = { Nudge = { dx = 0, dy = 10 } }")
            .unwrap()["a"]
            .clone()
            .try_into()
            .unwrap();
        assert_eq!(nudge, Action::Nudge { dx: 0, dy: 10 });
        assert_eq!(nudge.describe(), "move point 10 image pixels (finer zoomed in) ↓");
    }
}
