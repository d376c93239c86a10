//! A 2D thin-plate spline through a few point pairs (Bookstein 1989, "Principal warps", IEEE
//! PAMI 11(6), eq. 1–3): the smoothest plane warp that takes each source point exactly to its
//! target.
//!
//! Map suggestion uses it to carry a speaker's tracked landmarks onto the head's own
//! proportions: the hand labels say where on the head's image a few landmarks are, and the
//! spline moves every other tracked point by the same local stretch (a wider mouth, closer
//! eyes), so the assignment matches like with like. Start with [`ThinPlate::fit`].

use crate::math::{DMatrix, DVector, Point2, Real, Vector2};

/// Fewest pairs that fix the spline's affine part.
pub const MIN_PAIRS: usize = 3;

/// `f(p) = a₀ + A·p + Σᵢ wᵢ·U(|p − cᵢ|)` with `U(r) = r²·ln r²` (Bookstein's `U`).
#[derive(Clone, Debug, PartialEq)]
pub struct ThinPlate {
    centres: Vec<Point2>,
    /// `wᵢ` per centre (x and y parts).
    weights: Vec<Vector2>,
    /// `a₀`, then the columns of `A`.
    affine: [Vector2; 3],
}

/// Bookstein's radial basis `U(r) = r² ln r²`, taken as 0 at r = 0 (its limit).
fn radial(r2: Real) -> Real {
    if r2 > 0.0 { r2 * r2.ln() } else { 0.0 }
}

impl ThinPlate {
    /// The spline taking each `from[i]` to `to[i]` (Bookstein eq. 2: `[K P; Pᵀ 0]·[w; a] =
    /// [v; 0]`, solved once for x and once for y).
    ///
    /// `None` with fewer than [`MIN_PAIRS`] pairs, different lengths, a repeated or collinear
    /// source (the system is then singular) or a non-finite coordinate.
    pub fn fit(from: &[Point2], to: &[Point2]) -> Option<Self> {
        let n = from.len();
        if n < MIN_PAIRS || to.len() != n {
            return None;
        }
        if from.iter().chain(to).any(|p| !(p.x.is_finite() && p.y.is_finite())) {
            return None;
        }
        let mut l = DMatrix::zeros(n + 3, n + 3);
        for i in 0..n {
            for j in 0..n {
                l[(i, j)] = radial((from[i] - from[j]).norm_squared());
            }
            for (k, p) in [1.0, from[i].x, from[i].y].into_iter().enumerate() {
                l[(i, n + k)] = p;
                l[(n + k, i)] = p;
            }
        }
        let lu = l.lu();
        let solve = |coord: fn(&Point2) -> Real| {
            let mut v = DVector::zeros(n + 3);
            for (i, p) in to.iter().enumerate() {
                v[i] = coord(p);
            }
            lu.solve(&v).filter(|s| s.iter().all(|x| x.is_finite()))
        };
        let (sx, sy) = (solve(|p| p.x)?, solve(|p| p.y)?);
        // A near-singular system (collinear sources) solves to huge weights: refuse it rather
        // than warp the whole face.
        let scale = to.iter().map(|p| p.coords.norm()).fold(1.0, Real::max);
        if sx.iter().chain(sy.iter()).any(|x| x.abs() > 1e9 * scale) {
            return None;
        }
        Some(Self {
            centres: from.to_vec(),
            weights: (0..n).map(|i| Vector2::new(sx[i], sy[i])).collect(),
            affine: [0, 1, 2].map(|k| Vector2::new(sx[n + k], sy[n + k])),
        })
    }

    /// Where the spline takes `p`.
    pub fn apply(&self, p: &Point2) -> Point2 {
        let [a0, ax, ay] = self.affine;
        let bent: Vector2 = self
            .centres
            .iter()
            .zip(&self.weights)
            .map(|(c, w)| w * radial((p - c).norm_squared()))
            .sum();
        Point2::from(a0 + ax * p.x + ay * p.y + bent)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn interpolates_its_pairs_and_reproduces_an_affine_map() {
        let from = [
            Point2::new(0.0, 0.0),
            Point2::new(10.0, 0.0),
            Point2::new(0.0, 10.0),
            Point2::new(10.0, 12.0),
            Point2::new(4.0, 5.0),
        ];
        // An affine map is reproduced exactly everywhere (the weights vanish).
        let affine = |p: &Point2| Point2::new(2.0 + 1.5 * p.x - 0.3 * p.y, -1.0 + 0.2 * p.x + p.y);
        let to: Vec<Point2> = from.iter().map(affine).collect();
        let tps = ThinPlate::fit(&from, &to).unwrap();
        for q in [Point2::new(3.0, 7.0), Point2::new(-5.0, 20.0)] {
            assert!((tps.apply(&q) - affine(&q)).norm() < 1e-9);
        }
        // A bent target is met exactly at the pairs, and smoothly between them.
        let mut bent = to.clone();
        bent[4] += Vector2::new(1.0, -0.5);
        let tps = ThinPlate::fit(&from, &bent).unwrap();
        for (p, q) in from.iter().zip(&bent) {
            assert!((tps.apply(p) - q).norm() < 1e-9);
        }
        let near = tps.apply(&Point2::new(4.5, 5.0)) - affine(&Point2::new(4.5, 5.0));
        assert!(near.norm() > 0.5 && near.norm() < 1.2, "{near}");
    }

    #[test]
    fn too_few_collinear_or_repeated_sources_are_refused() {
        let p = |x: Real, y: Real| Point2::new(x, y);
        assert_eq!(ThinPlate::fit(&[p(0.0, 0.0), p(1.0, 0.0)], &[p(0.0, 0.0), p(1.0, 0.0)]), None);
        let line = [p(0.0, 0.0), p(1.0, 1.0), p(2.0, 2.0)];
        assert_eq!(ThinPlate::fit(&line, &line), None);
        let twice = [p(0.0, 0.0), p(0.0, 0.0), p(1.0, 0.0), p(0.0, 1.0)];
        assert_eq!(ThinPlate::fit(&twice, &twice), None);
        let nan = [p(0.0, 0.0), p(Real::NAN, 0.0), p(0.0, 1.0)];
        assert_eq!(ThinPlate::fit(&nan, &nan), None);
    }
}
