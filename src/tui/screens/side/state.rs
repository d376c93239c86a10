//! The side screen's state: the clip's side view (its setup, profile points with the user's
//! corrections, decoded side frames), or where its measurement stands.

use crate::math::Point2;
use crate::measure::profile::{ProfileSetup, ProfileTrack};
use crate::tui::app::FrameImage;
use std::collections::BTreeMap;
use std::sync::Arc;

/// The clip's side view for protrusion: the once-per-clip setup, the automatic profile
/// points with the user's corrections, and the decoded side frames.
#[derive(Clone, Debug, PartialEq)]
pub struct SideView {
    pub setup: ProfileSetup,
    pub track: ProfileTrack,
    pub fps: f64,
    pub offset_s: f64,
    pub n_frames: usize,
    pub images: BTreeMap<usize, Arc<FrameImage>>,
    pub image_errors: BTreeMap<usize, String>,
}

impl SideView {
    /// Side frames kept decoded (a few around the current one).
    pub const CACHE: usize = 8;

    /// The side frame shown with front frame `frame` (nearest in time, after the offset).
    pub fn frame_for(&self, frame: usize, front_fps: f64) -> Option<usize> {
        let k = ((frame as f64 / front_fps - self.offset_s) * self.fps).round();
        (k >= 0.0 && (k as usize) < self.n_frames).then_some(k as usize)
    }

    /// P per front frame (normalised when a nose length is known), corrections applied.
    pub fn p_series(&self, n_front: usize, front_fps: f64) -> Vec<Option<f64>> {
        crate::workflow::resample_to_front(front_fps, self.fps, self.offset_s, n_front, |k| {
            self.track.effective(k, &self.setup).and_then(|p| p.p_norm.or(p.p_px))
        })
    }

    /// Sets or clears (None) the user's point of side frame `k`.
    pub fn set_correction(&mut self, k: usize, point: Option<Point2>) {
        match point {
            Some(p) => self.track.correct(k, p),
            None => {
                self.track.clear_correction(k);
            }
        }
    }
}

/// Where the side view stands: not in the clip, being measured, ready, or failed.
#[derive(Clone, Debug, Default, PartialEq)]
pub enum SideState {
    #[default]
    None,
    Measuring,
    Ready(Box<SideView>),
    Failed(String),
}

impl SideState {
    pub fn view(&self) -> Option<&SideView> {
        match self {
            Self::Ready(v) => Some(v),
            _ => None,
        }
    }

    pub fn view_mut(&mut self) -> Option<&mut SideView> {
        match self {
            Self::Ready(v) => Some(v),
            _ => None,
        }
    }
}
