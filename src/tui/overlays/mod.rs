//! The overlays over the screen, a stack whose top one sees a key first: the help (from the
//! keymap and the actions' help text), the prompts (a number the user types) and the face
//! box being drawn on the frames view (its handlers are the frames screen's). `update` has
//! the help's and prompts' handlers, `view` their drawing.

pub mod update;
pub mod view;

/// What a prompt asks for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum PromptKind {
    GotoPoint,
    GotoFrame,
    Propagate,
    GotoLabel,
}

impl PromptKind {
    pub fn question(self) -> &'static str {
        match self {
            Self::GotoPoint => "point number (1–68)",
            Self::GotoFrame => "frame number",
            Self::Propagate => "propagate to how many next frames (Enter = 10)",
            Self::GotoLabel => "landmark to label (1–68)",
        }
    }
}

/// Overlays stack over the view; the top one sees keys first.
#[derive(Clone, Debug, PartialEq)]
pub enum Overlay {
    Help {
        scroll: u16,
    },
    Prompt {
        kind: PromptKind,
        input: String,
    },
    /// A face box for the tracker, drawn over the frames view.
    FaceBox(crate::tui::screens::frames::FaceBoxDraft),
}
