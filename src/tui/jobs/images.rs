//! The image checks of a whole clip (`landmarks::flags::image_flags`) over the frames the
//! decoding thread also reads, for the flags the TUI shows before every frame is decoded.

use crate::landmarks::Track;
use crate::landmarks::flags::{FlagThresholds, image_flags};
use crate::tui::action::Action;
use crate::tui::app::FrameProvider;
use std::sync::Arc;

/// Checks every frame of `track` whose mouth is open enough, decoding it from `provider`
/// (frames that do not decode give no flag), and replies `ImagesChecked`.
pub fn check_images_for_tui(
    provider: Arc<dyn FrameProvider>,
    track: Track,
    thresholds: FlagThresholds,
) -> impl FnOnce() -> Action + Send + 'static {
    move || Action::ImagesChecked {
        flags: image_flags(&track, |f| provider.load(f).ok(), &thresholds),
    }
}
