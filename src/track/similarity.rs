//! The similarity normalisation of the cascade: the scaled rotation that maps the mean shape
//! onto the current shape, so feature pixels anchored on the mean shape follow the face as
//! it turns and scales (Kazemi & Sullivan 2014, §2.3.1), and the box ↔ normalised-frame
//! mapping of dlib's predictor.
//!
//! The least-squares similarity between two point sets is Umeyama's (1991, eqs. 34–43), as
//! dlib uses it. In 2D with a proper rotation it has a closed form: centred points x_i → y_i,
//! `c·R = [[a, −b], [b, a]]` with `a = Σ x_i·y_i / Σ|x_i|²` and `b = Σ x_i×y_i / Σ|x_i|²`,
//! which is Umeyama's solution without an SVD (both minimise the same quadratic over
//! proper scaled rotations).

use nalgebra::{Matrix2, Vector2};

/// An axis-aligned face box in image pixels (x right, y down): its top-left corner and its
/// extent. dlib's rectangles are integer and inclusive, and its predictor maps the
/// normalised (1,1) to `(right, bottom)`, so `width = right − left` (not `+ 1`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FaceBox {
    pub left: f64,
    pub top: f64,
    pub width: f64,
    pub height: f64,
}

impl FaceBox {
    /// A point of the box-normalised frame ((0,0) top-left, (1,1) bottom-right) in pixels.
    pub fn to_image(&self, p: Vector2<f32>) -> Vector2<f64> {
        Vector2::new(
            self.left + f64::from(p.x) * self.width,
            self.top + f64::from(p.y) * self.height,
        )
    }

    /// A pixel position in the box-normalised frame.
    pub fn to_normalised(&self, p: Vector2<f64>) -> Vector2<f32> {
        Vector2::new(
            ((p.x - self.left) / self.width) as f32,
            ((p.y - self.top) / self.height) as f32,
        )
    }

    /// Whether the box has a positive, finite size.
    pub fn is_valid(&self) -> bool {
        [self.left, self.top, self.width, self.height].iter().all(|v| v.is_finite())
            && self.width > 0.0
            && self.height > 0.0
    }
}

/// The scaled rotation `c·R` of the least-squares similarity from `from` onto `to` (the
/// translation is not needed by the cascade, which works on offsets). The identity when
/// `from` has no spread or the sets differ in length.
pub fn similarity_scaled_rotation(from: &[Vector2<f32>], to: &[Vector2<f32>]) -> Matrix2<f32> {
    let n = from.len();
    if n < 2 || to.len() != n {
        return Matrix2::identity();
    }
    let mean = |s: &[Vector2<f32>]| {
        s.iter().fold(Vector2::<f64>::zeros(), |acc, p| acc + p.cast::<f64>()) / n as f64
    };
    let (mf, mt) = (mean(from), mean(to));
    let (mut sxx, mut dot, mut cross) = (0.0f64, 0.0f64, 0.0f64);
    for (f, t) in from.iter().zip(to) {
        let x = f.cast::<f64>() - mf;
        let y = t.cast::<f64>() - mt;
        sxx += x.norm_squared();
        dot += x.dot(&y);
        cross += x.x * y.y - x.y * y.x;
    }
    if sxx <= 0.0 || !sxx.is_finite() {
        return Matrix2::identity();
    }
    let (a, b) = ((dot / sxx) as f32, (cross / sxx) as f32);
    Matrix2::new(a, -b, b, a)
}

/// The box that places `mean` (box-normalised) on `shape` (pixels) as the least-squares
/// similarity between them does, rotation left out: `shape ≈ s·R·m + t` gives a square box of
/// side `s` centred where the unit box's centre goes. This is the box a detector would have
/// had to draw for the cascade's start to sit on this face; leaving the roll to the
/// cascade's own warp keeps a rolled head's box from shrinking (a per-axis fit would take
/// the roll for a smaller face). `None` when `mean` has no spread or the sets differ.
pub fn box_from_shape(mean: &[Vector2<f32>], shape: &[Vector2<f64>]) -> Option<FaceBox> {
    let n = mean.len();
    if n < 2 || shape.len() != n {
        return None;
    }
    let m: Vec<Vector2<f64>> = mean.iter().map(|p| p.cast::<f64>()).collect();
    let (mm, ms) =
        (m.iter().sum::<Vector2<f64>>() / n as f64, shape.iter().sum::<Vector2<f64>>() / n as f64);
    let (mut sxx, mut dot, mut cross) = (0.0, 0.0, 0.0);
    for (a, b) in m.iter().zip(shape) {
        let (x, y) = (a - mm, b - ms);
        sxx += x.norm_squared();
        dot += x.dot(&y);
        cross += x.x * y.y - x.y * y.x;
    }
    if sxx <= 0.0 {
        return None;
    }
    let (a, b) = (dot / sxx, cross / sxx);
    let side = a.hypot(b);
    let sr = Matrix2::new(a, -b, b, a);
    let centre = sr * (Vector2::new(0.5, 0.5) - mm) + ms;
    let face = FaceBox {
        left: centre.x - side / 2.0,
        top: centre.y - side / 2.0,
        width: side,
        height: side,
    };
    face.is_valid().then_some(face)
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    proptest! {
        #[test]
        fn a_known_similarity_is_recovered(
            angle in -3.0f32..3.0, scale in 0.2f32..5.0, tx in -50f32..50.0, ty in -50f32..50.0,
            pts in proptest::collection::vec((-1.0f32..1.0, -1.0f32..1.0), 3..20),
        ) {
            let from: Vec<Vector2<f32>> = pts.iter().map(|&(x, y)| Vector2::new(x, y)).collect();
            let sr = Matrix2::new(angle.cos(), -angle.sin(), angle.sin(), angle.cos()) * scale;
            let to: Vec<Vector2<f32>> =
                from.iter().map(|p| sr * p + Vector2::new(tx, ty)).collect();
            let spread: f32 = from.iter().map(|p| (p - from[0]).norm()).sum();
            prop_assume!(spread > 0.5);
            let got = similarity_scaled_rotation(&from, &to);
            prop_assert!((got - sr).abs().max() < 1e-3 * scale.max(1.0), "{got} vs {sr}");
        }
    }

    #[test]
    fn degenerate_sets_give_the_identity() {
        let one = [Vector2::new(1.0f32, 2.0)];
        assert_eq!(similarity_scaled_rotation(&one, &one), Matrix2::identity());
        let same = [Vector2::new(1.0f32, 2.0); 4];
        assert_eq!(similarity_scaled_rotation(&same, &same), Matrix2::identity());
    }

    #[test]
    fn the_box_of_a_shape_placed_by_a_box_is_that_box() {
        let mean = [
            Vector2::new(0.1f32, 0.2),
            Vector2::new(0.9, 0.25),
            Vector2::new(0.5, 0.9),
            Vector2::new(0.3, 0.6),
        ];
        let b = FaceBox { left: 30.0, top: 12.0, width: 80.0, height: 80.0 };
        let shape: Vec<Vector2<f64>> = mean.iter().map(|&m| b.to_image(m)).collect();
        let got = box_from_shape(&mean, &shape).unwrap();
        for (g, w) in [(got.left, b.left), (got.top, b.top), (got.width, 80.0), (got.height, 80.0)]
        {
            assert!((g - w).abs() < 1e-4, "{got:?}");
        }
        // The same face rolled about the box centre keeps the box.
        let (sin, cos) = 0.4f64.sin_cos();
        let c = Vector2::new(70.0, 52.0);
        let rolled: Vec<Vector2<f64>> =
            shape.iter().map(|p| c + Matrix2::new(cos, -sin, sin, cos) * (p - c)).collect();
        let got = box_from_shape(&mean, &rolled).unwrap();
        assert!((got.width - 80.0).abs() < 1e-6 && (got.left - 30.0).abs() < 1e-6, "{got:?}");
        let p = b.to_normalised(Vector2::new(70.0, 52.5));
        assert!((b.to_image(p) - Vector2::new(70.0, 52.5)).norm() < 1e-4);
        assert!(box_from_shape(&mean, &shape[..2]).is_none());
    }
}
