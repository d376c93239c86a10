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

/// `v` as a message shows it: plain for everyday magnitudes, in exponent form for huge or
/// tiny ones, whose plain form (`1e300` as 301 digits) would swamp a one-line error.
pub fn short_number(v: Real) -> String {
    if v.is_finite() && v != 0.0 && !(1e-5..1e7).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

#[cfg(test)]
mod tests {
    use super::short_number;

    #[test]
    fn huge_and_tiny_numbers_are_shown_short() {
        assert_eq!(short_number(0.5), "0.5");
        assert_eq!(short_number(25.0), "25");
        assert_eq!(short_number(0.0), "0");
        assert_eq!(short_number(1e300), "1e300");
        assert_eq!(short_number(-1e-300), "-1e-300");
        assert_eq!(short_number(f64::NAN), "NaN");
    }
}
