//! The image evidence of a whole clip (`landmarks::flags::lip_edge_offsets`) over the frames
//! the decoding thread also reads, for the flags the TUI shows before every frame is decoded.

use crate::landmarks::Track;
use crate::landmarks::flags::{FlagThresholds, lip_edge_offsets};
use crate::tui::action::Action;
use crate::tui::app::FrameProvider;
use std::sync::Arc;

/// Measures every frame of `track` (the lower lip's lower edge on all, its upper edge where
/// the mouth is open enough), decoding it from `provider` (frames that do not decode give
/// nothing), and replies `ImagesChecked`.
pub fn check_images_for_tui(
    provider: Arc<dyn FrameProvider>,
    track: Track,
    thresholds: FlagThresholds,
) -> impl FnOnce() -> Action + Send + 'static {
    move || Action::ImagesChecked {
        offsets: lip_edge_offsets(&track, |f| provider.load(f).ok(), &thresholds),
    }
}
