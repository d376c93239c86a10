//! Landmark-based 3DMM fitting after Huber et al. (eos): linear affine camera -> scaled
//! orthographic pose, regularised linear shape/expression fit, iterated; per frame or per clip.

pub mod result;

pub use result::{FitSettings, FrameFit};
