//! Why a side-view frame could not be measured.

use super::Rect;
use crate::math::Real;

/// Why a frame could not be measured.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ProfileError {
    #[error("the crop {0:?} lies outside the {1}×{2} frame")]
    CropOutside(Rect, u32, u32),
    #[error("the crop is one gray level: no silhouette to threshold")]
    Uniform,
    #[error("the reference line is degenerate or within 30° of horizontal")]
    BadReferenceLine,
    #[error("no face silhouette of at least {0} px in the crop")]
    NoSilhouette(usize),
    #[error("no upper lip: the profile has no bump standing out by {0} px")]
    NoUpperLip(Real),
    #[error("the upper lip touches the crop's front edge: widen the crop forward")]
    LipAtCropEdge,
    #[error("the nose tip or root was not found above the crop")]
    NoseNotFound,
    #[error("the nose length is not positive")]
    BadNoseLength,
    #[error("the upper-face profile could not be registered to the anchor frame's: {0}")]
    Registration(&'static str),
}
