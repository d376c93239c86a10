//! Which comparison of video and head W/H a table makes when the head turns.
//!
//! The video's W and H are distances in the image; the fitted head's are taken on its mesh.
//! Facing the camera both see the same mouth, but a head turned 60° shows a mouth half as
//! wide in the image while its mesh is unchanged, and the two no longer measure one thing.
//! There are two honest comparisons: the head's landmark vertices as the frame's fitted
//! camera sees them ([`PoseComparison::ImagePlane`], measured exactly like the video's), or
//! the head's own frontal mouth against only those frames where the face is near frontal
//! ([`PoseComparison::Frontal`], turned frames left out and counted).
//!
//! The default is frontal with a 15° limit: the thesis's GRID recordings come from a
//! head-mounted front camera, so its video always faces the speaker and its comparison is the
//! frontal one; 15° foreshortens a width by at most 1 − cos 15° ≈ 3.4 %, below a tracker's
//! jitter on a mouth a few dozen pixels wide.

use serde::{Deserialize, Serialize};
use std::fmt;

/// How video and head mouth measures are put side by side under head pose.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PoseComparison {
    /// The head's landmark vertices rotated by the frame's fitted pose, measured on their
    /// image-plane projection: foreshortened exactly as the video is.
    ImagePlane,
    /// The head's frontal (model-space) measures against the video, on frames whose fitted
    /// |yaw| and |pitch| are at most `limit_deg`; the other frames are left out of both.
    Frontal { limit_deg: f64 },
}

impl PoseComparison {
    /// The frontal limit used unless the user sets one (module docs say why).
    pub const DEFAULT_LIMIT_DEG: f64 = 15.0;

    /// Frontal with the default limit.
    pub fn frontal() -> Self {
        Self::Frontal { limit_deg: Self::DEFAULT_LIMIT_DEG }
    }

    /// Whether a frame fitted at `yaw_deg`, `pitch_deg` takes part in the comparison.
    pub fn admits(self, yaw_deg: f64, pitch_deg: f64) -> bool {
        match self {
            Self::ImagePlane => true,
            Self::Frontal { limit_deg } => {
                yaw_deg.abs() <= limit_deg && pitch_deg.abs() <= limit_deg
            }
        }
    }

    /// The short name put after every W/H column (`image plane`, `frontal ≤15°`).
    pub fn short_label(self) -> String {
        match self {
            Self::ImagePlane => "image plane".into(),
            Self::Frontal { limit_deg } => format!("frontal ≤{limit_deg}°"),
        }
    }
}

impl Default for PoseComparison {
    fn default() -> Self {
        Self::frontal()
    }
}

impl fmt::Display for PoseComparison {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::ImagePlane => {
                f.write_str("image plane: head projected with each frame's fitted camera")
            }
            Self::Frontal { limit_deg } => write!(
                f,
                "frontal: 3D head vs video, frames with |yaw| or |pitch| > {limit_deg}° left out"
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frontal_admits_only_frames_within_the_limit_on_both_angles() {
        let c = PoseComparison::frontal();
        assert!(c.admits(14.9, -15.0));
        assert!(!c.admits(15.1, 0.0));
        assert!(!c.admits(0.0, -20.0));
        assert!(PoseComparison::ImagePlane.admits(80.0, 80.0));
        assert_eq!(c.short_label(), "frontal ≤15°");
    }
}
