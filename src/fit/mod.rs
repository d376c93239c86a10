//! Landmark-based 3DMM fitting after Huber et al. (eos): linear affine camera -> scaled
//! orthographic pose, regularised linear shape/expression fit, iterated; per frame or per clip.
//!
//! Start with [`fit_clip`] (a clip or a batch of frames) or [`fit_frame`]; build a
//! [`Fitter`] to reuse the per-model precomputation. `docs/fitting.md` gives the method,
//! the defaults and how they were chosen.

mod alternating;
pub mod assignment;
pub mod camera;
pub mod clip;
mod flags;
pub mod gaps;
pub mod jaw_contour;
mod joint;
pub mod map_suggest;
pub mod own_face;
pub mod pipeline;
pub mod result;
pub mod shape;
mod shapes;
pub mod suggest;
pub mod thin_plate;

pub use camera::OrthoPose;
pub use gaps::{Filled, GapError, MAX_FILLED_S, fill_gaps};
pub use pipeline::{Fitter, fit_clip, fit_frame, fitted_shape, pose_of, project};
pub use result::{FitSettings, FrameFit, Solver};
pub use shapes::for_each_block_of_fitted_shapes;
