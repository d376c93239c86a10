//! Meshes, 3D morphable models (mean, orthonormal basis, eigenvalues, expression
//! blendshapes) and the landmark map from iBUG points to mesh vertices.

pub mod blendshapes;
pub mod face_locate;
pub mod landmark_map;
pub mod map_check;
pub mod mesh;
pub mod morphable;
pub mod pca;

pub use landmark_map::LandmarkMap;
pub use map_check::{MapCheck, MapProblem, check_map};
pub use mesh::Mesh;
pub use morphable::{Expressions, ModelError, MorphableModel, PcaModel};
