//! A `Track`: the 68 landmark points of each frame of a clip, in image pixels (y down,
//! 0-based), with visibility, tracker confidence and where each point came from.

use super::ibug::N_LANDMARKS;
use crate::math::Point2;
use serde::{Deserialize, Serialize};

/// Where a point's position came from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum PointSource {
    #[default]
    Tracked,
    Corrected,
    Interpolated,
}

impl PointSource {
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Tracked => "tracked",
            Self::Corrected => "corrected",
            Self::Interpolated => "interpolated",
        }
    }

    pub fn parse(s: &str) -> Option<Self> {
        match s.trim() {
            "tracked" | "" => Some(Self::Tracked),
            "corrected" => Some(Self::Corrected),
            "interpolated" => Some(Self::Interpolated),
            _ => None,
        }
    }
}

/// One landmark in one frame. The position is always finite; a point the tracker did not
/// see keeps its last known (or zero) position with `visible = false`.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct LandmarkPoint {
    pub x: f64,
    pub y: f64,
    pub visible: bool,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub confidence: Option<f32>,
    #[serde(default)]
    pub source: PointSource,
}

impl LandmarkPoint {
    pub fn tracked(x: f64, y: f64) -> Self {
        Self { x, y, visible: true, confidence: None, source: PointSource::Tracked }
    }

    pub fn missing() -> Self {
        Self { x: 0.0, y: 0.0, visible: false, confidence: None, source: PointSource::Tracked }
    }

    pub fn pos(&self) -> Point2 {
        Point2::new(self.x, self.y)
    }
}

/// All 68 points of one frame, plus what the tracker said of the frame as a whole.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct FrameLandmarks {
    /// 0-based frame number in the clip.
    pub frame: usize,
    /// Seconds from the start of the clip, when the source gives it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub timestamp: Option<f64>,
    /// Tracker's confidence for the whole frame (OpenFace `confidence`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub confidence: Option<f32>,
    /// Tracker's success flag (OpenFace `success`); `true` when the source has none.
    #[serde(default = "default_true")]
    pub success: bool,
    /// lipmap's own tracker only: the mean distance between its result on this frame and
    /// the cascade re-run from that result's box, in outer eye-corner distances (its
    /// self-check, `docs/tracking.md`); `None` for other trackers' landmarks.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub rerun_disagreement: Option<f32>,
    /// Exactly `N_LANDMARKS` points, index = 0-based iBUG id.
    pub points: Vec<LandmarkPoint>,
    /// The inner lips meet on this frame, and the inner-lip gap is known to this standard
    /// deviation (px), more precisely than each point's position: the fit then weighs the
    /// gap by it (`landmarks::closure` sets it on the clip's sealed frames; `fit::shape`'s
    /// lip-contact entries read it). Never stored: it is derived from the clip each time.
    #[serde(skip)]
    pub lip_contact_px: Option<f64>,
}

fn default_true() -> bool {
    true
}

impl FrameLandmarks {
    pub fn new(frame: usize, points: Vec<LandmarkPoint>) -> Self {
        debug_assert_eq!(points.len(), N_LANDMARKS);
        Self {
            frame,
            timestamp: None,
            confidence: None,
            success: true,
            rerun_disagreement: None,
            points,
            lip_contact_px: None,
        }
    }

    /// Visible points as (index, position) pairs.
    pub fn visible_points(&self) -> impl Iterator<Item = (usize, Point2)> + '_ {
        self.points.iter().enumerate().filter(|(_, p)| p.visible).map(|(i, p)| (i, p.pos()))
    }
}

/// The landmarks of a clip, frames ascending by `frame` number (gaps allowed).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Track {
    pub frames: Vec<FrameLandmarks>,
}

impl Track {
    pub fn new(mut frames: Vec<FrameLandmarks>) -> Self {
        frames.sort_by_key(|f| f.frame);
        Self { frames }
    }

    pub fn len(&self) -> usize {
        self.frames.len()
    }

    pub fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    /// The landmarks of frame number `frame`, if tracked.
    pub fn get(&self, frame: usize) -> Option<&FrameLandmarks> {
        self.frames.binary_search_by_key(&frame, |f| f.frame).ok().map(|i| &self.frames[i])
    }

    pub fn get_mut(&mut self, frame: usize) -> Option<&mut FrameLandmarks> {
        match self.frames.binary_search_by_key(&frame, |f| f.frame) {
            Ok(i) => Some(&mut self.frames[i]),
            Err(_) => None,
        }
    }
}
