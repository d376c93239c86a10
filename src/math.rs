//! Scalar and point aliases shared by the whole crate.
//! Everything numeric is f64 on nalgebra types; files may store f32, converted at the boundary.

pub type Real = f64;
pub type Point2 = nalgebra::Point2<Real>;
pub type Point3 = nalgebra::Point3<Real>;
pub type Vector2 = nalgebra::Vector2<Real>;
pub type Vector3 = nalgebra::Vector3<Real>;
pub type Matrix3 = nalgebra::Matrix3<Real>;
pub type DVector = nalgebra::DVector<Real>;
pub type DMatrix = nalgebra::DMatrix<Real>;
