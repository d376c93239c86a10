//! Symmetric positive definite band systems by banded Cholesky (Golub & Van Loan,
//! "Matrix Computations", 4th ed., Alg. 4.3.5 and 4.3.2/4.3.3): O(n·p²) for half-bandwidth p,
//! where a dense solve is O(n³). Eq. 4's matrix is block-diagonal by coefficient and each
//! block is banded (p = the order of W), so this solves it exactly.

use super::SaqpError;

/// A symmetric band matrix: `band[i][d] = A(i, i − d)` for `d ∈ 0..=p` (the lower band).
#[derive(Clone, Debug, PartialEq)]
pub struct BandMatrix {
    n: usize,
    p: usize,
    band: Vec<f64>,
}

impl BandMatrix {
    pub fn zeros(n: usize, p: usize) -> Self {
        Self { n, p, band: vec![0.0; n * (p + 1)] }
    }

    pub fn size(&self) -> usize {
        self.n
    }

    pub fn bandwidth(&self) -> usize {
        self.p
    }

    /// A(i, j) for |i − j| ≤ p, else 0.
    pub fn get(&self, i: usize, j: usize) -> f64 {
        let (i, j) = if i >= j { (i, j) } else { (j, i) };
        if i - j > self.p { 0.0 } else { self.band[i * (self.p + 1) + (i - j)] }
    }

    /// Adds `x` to A(i, j) (and so to A(j, i)). |i − j| must be ≤ p.
    pub fn add(&mut self, i: usize, j: usize, x: f64) {
        let (i, j) = if i >= j { (i, j) } else { (j, i) };
        debug_assert!(i - j <= self.p);
        self.band[i * (self.p + 1) + (i - j)] += x;
    }

    /// y = A·x.
    pub fn mul(&self, x: &[f64]) -> Vec<f64> {
        (0..self.n)
            .map(|i| {
                let lo = i.saturating_sub(self.p);
                let hi = (i + self.p).min(self.n - 1);
                (lo..=hi).map(|j| self.get(i, j) * x[j]).sum()
            })
            .collect()
    }

    /// The Cholesky factor `A = L·Lᵀ`, L lower with the same bandwidth.
    ///
    /// # Errors
    /// `NotPositiveDefinite(i)` at the first pivot that is not positive.
    pub fn cholesky(&self) -> Result<BandCholesky, SaqpError> {
        let (n, p) = (self.n, self.p);
        let w = p + 1;
        let mut l = vec![0.0; n * w];
        let at = |i: usize, j: usize| i * w + (i - j);
        for j in 0..n {
            let lo = j.saturating_sub(p);
            let mut s = self.band[at(j, j)];
            for k in lo..j {
                s -= l[at(j, k)] * l[at(j, k)];
            }
            if !(s.is_finite() && s > 0.0) {
                return Err(SaqpError::NotPositiveDefinite(j));
            }
            let d = s.sqrt();
            l[at(j, j)] = d;
            for i in j + 1..=(j + p).min(n - 1) {
                let mut s = self.band[at(i, j)];
                for k in i.saturating_sub(p)..j {
                    s -= l[at(i, k)] * l[at(j, k)];
                }
                l[at(i, j)] = s / d;
            }
        }
        Ok(BandCholesky { n, p, l })
    }
}

/// `L` of a banded Cholesky factorisation.
#[derive(Clone, Debug, PartialEq)]
pub struct BandCholesky {
    n: usize,
    p: usize,
    l: Vec<f64>,
}

impl BandCholesky {
    /// Solves `A·x = b` by forward and back substitution.
    // Index loops keep the subscripts of the band formulas (k runs over the band of row i).
    #[allow(clippy::needless_range_loop)]
    pub fn solve(&self, b: &[f64]) -> Vec<f64> {
        let (n, p, w) = (self.n, self.p, self.p + 1);
        let at = |i: usize, j: usize| i * w + (i - j);
        let mut y = b.to_vec();
        for i in 0..n {
            let mut s = y[i];
            for k in i.saturating_sub(p)..i {
                s -= self.l[at(i, k)] * y[k];
            }
            y[i] = s / self.l[at(i, i)];
        }
        for i in (0..n).rev() {
            let mut s = y[i];
            for k in i + 1..=(i + p).min(n - 1) {
                s -= self.l[at(k, i)] * y[k];
            }
            y[i] = s / self.l[at(i, i)];
        }
        y
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::{DMatrix, DVector};
    use rand::rngs::StdRng;
    use rand::{Rng, SeedableRng};

    #[test]
    fn banded_equals_dense_to_1e_10() {
        let mut rng = StdRng::seed_from_u64(7);
        for (n, p) in [(1, 0), (5, 1), (40, 2), (60, 3), (7, 6)] {
            let mut a = BandMatrix::zeros(n, p);
            for i in 0..n {
                for j in i.saturating_sub(p)..i {
                    a.add(i, j, rng.random_range(-1.0..1.0));
                }
            }
            // Diagonal dominance makes it positive definite.
            for i in 0..n {
                a.add(i, i, 2.0 * p as f64 + 1.0 + rng.random_range(0.0..1.0));
            }
            let b: Vec<f64> = (0..n).map(|_| rng.random_range(-5.0..5.0)).collect();
            let x = a.cholesky().unwrap().solve(&b);
            let dense = DMatrix::from_fn(n, n, |i, j| a.get(i, j));
            let xd = dense.lu().solve(&DVector::from_vec(b.clone())).unwrap();
            for i in 0..n {
                assert!((x[i] - xd[i]).abs() < 1e-10, "n={n} p={p} i={i}");
            }
            let r = a.mul(&x);
            assert!(r.iter().zip(&b).all(|(u, v)| (u - v).abs() < 1e-10));
        }
    }

    #[test]
    fn indefinite_is_an_error() {
        let mut a = BandMatrix::zeros(2, 1);
        a.add(0, 0, 1.0);
        a.add(1, 0, 2.0);
        a.add(1, 1, 1.0);
        assert_eq!(a.cholesky(), Err(SaqpError::NotPositiveDefinite(1)));
    }
}
