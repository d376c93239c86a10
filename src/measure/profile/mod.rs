//! Lip protrusion P from side-view frames: silhouette segmentation (Otsu), the lip profile,
//! the upper lip's foremost point, its distance to a reference line, nose-length normalisation.
//!
//! Start at [`measure_frame`] (one frame) or [`extract_protrusion`] (a clip); [`propose_setup`]
//! finds a crop, reference line and nose length from one frame so no clicking is needed.
//!
//! Coordinates are image pixels, x right, y down, pixel centres on integers (pixel `i` covers
//! `[i − 0.5, i + 0.5)`). Internally a crop is read in *forward* coordinates: column `u` grows
//! in the direction the face looks (the crop is mirrored when the face looks left), so one code
//! path serves both facings. The same extraction runs on rendered side views of a fitted head
//! ([`measure_render`]), so video and head are measured the same way.
//!
//! One step per file, in the order a frame goes through them:
//!
//! | file | step |
//! |---|---|
//! | `setup` | what is set once per clip (crop, line, facing, nose length, anchor) |
//! | `denoise` | salt-and-pepper removal |
//! | `threshold` | Otsu's threshold, refined toward the background |
//! | `components` | connected components, the face component, holes filled |
//! | `silhouette` | segmentation and the sub-pixel forward edge per row |
//! | `registration` | head motion: the anchor profile and ICP to it |
//! | `curve` | profile curves: despike, smooth, peaks, parabola apex |
//! | `lip` | the upper lip's foremost point and P (px) in one frame |
//! | `nose` | the nose length P is divided by |
//! | `point` | P per frame and per clip, normalised; rendered heads |
//! | `track` | automatic points and the user's corrections |
//! | `propose` | a whole setup proposed from one frame |

mod components;
mod curve;
mod denoise;
mod error;
mod lip;
mod nose;
mod point;
mod propose;
mod registration;
mod setup;
mod silhouette;
#[cfg(test)]
mod synthetic;
mod threshold;
mod track;

pub use components::connected_components;
pub use curve::{Peak, find_peaks};
pub use error::ProfileError;
pub use lip::{LipProfile, measure_lip_profile};
pub use nose::{NosePoints, find_nose_on_profile, resolve_nose_length};
pub use point::{
    ProfilePoint, extract_protrusion, extract_protrusion_with, measure_frame, measure_render,
};
pub use propose::propose_setup;
pub use registration::{MIN_REGISTRATION_ROWS, capture_anchor, register_to_anchor};
pub use setup::{Anchor, Facing, NoseLength, ProfileSetup, Rect, ReferenceLine, Rigid2, Threshold};
pub use threshold::{histogram, otsu_threshold};
pub use track::ProfileTrack;
