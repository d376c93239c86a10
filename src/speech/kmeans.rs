//! k-means clustering (Lloyd's algorithm, k-means++ seeding: Arthur & Vassilvitskii 2007),
//! used to initialise the HMM's states and mixture components (Terissi et al. 2011, §4.1;
//! Rabiner 1989, §VI-A, segmental k-means).

use super::error::SpeechError;
use crate::math::DMatrix;
use rand::rngs::StdRng;
use rand::{Rng, SeedableRng};

/// Iteration cap; initialisation needs a sensible partition, not a converged one.
const MAX_ITERATIONS: usize = 50;

/// Labels 0 … k−1 for the rows of `data` (n × d), k-means++ seeded from `seed`. Every label is
/// used (an emptied cluster is re-seeded with the point furthest from its centre).
///
/// # Errors
/// `k` = 0 or fewer distinct rows than `k`.
pub fn cluster_rows(data: &DMatrix, k: usize, seed: u64) -> Result<Vec<usize>, SpeechError> {
    let n = data.nrows();
    if k == 0 {
        return Err(super::error::bad("cluster count", "0"));
    }
    if n < k {
        return Err(SpeechError::TooFew { what: "frames for k-means", need: k, got: n });
    }
    let mut rng = StdRng::seed_from_u64(seed);
    let dist2 = |i: usize, c: &DMatrix, j: usize| -> f64 {
        data.row(i).iter().zip(c.row(j).iter()).map(|(a, b)| (a - b) * (a - b)).sum()
    };
    let mut centres = DMatrix::zeros(k, data.ncols());
    centres.row_mut(0).copy_from(&data.row(rng.random_range(0..n)));
    let mut nearest: Vec<f64> = (0..n).map(|i| dist2(i, &centres, 0)).collect();
    for c in 1..k {
        let total: f64 = nearest.iter().sum();
        if total <= 0.0 {
            return Err(SpeechError::TooFew {
                what: "distinct frames for k-means",
                need: k,
                got: c,
            });
        }
        let mut r = rng.random_range(0.0..total);
        let mut pick = n - 1;
        for (i, d) in nearest.iter().enumerate() {
            if r < *d {
                pick = i;
                break;
            }
            r -= d;
        }
        centres.row_mut(c).copy_from(&data.row(pick));
        for (i, d) in nearest.iter_mut().enumerate() {
            *d = d.min(dist2(i, &centres, c));
        }
    }
    let mut labels = vec![0; n];
    for _ in 0..MAX_ITERATIONS {
        let mut changed = false;
        for (i, l) in labels.iter_mut().enumerate() {
            let best = (0..k)
                .map(|c| (c, dist2(i, &centres, c)))
                .min_by(|a, b| a.1.total_cmp(&b.1))
                .map_or(0, |(c, _)| c);
            changed |= best != *l;
            *l = best;
        }
        let mut sums = DMatrix::zeros(k, data.ncols());
        let mut counts = vec![0usize; k];
        for (i, &l) in labels.iter().enumerate() {
            let mut row = sums.row_mut(l);
            row += data.row(i);
            counts[l] += 1;
        }
        for (c, &count) in counts.iter().enumerate() {
            if count == 0 {
                let far = (0..n)
                    .max_by(|&a, &b| {
                        dist2(a, &centres, labels[a]).total_cmp(&dist2(b, &centres, labels[b]))
                    })
                    .unwrap_or(0);
                centres.row_mut(c).copy_from(&data.row(far));
                labels[far] = c;
                changed = true;
            } else {
                centres.row_mut(c).copy_from(&(sums.row(c) / count as f64));
            }
        }
        if !changed {
            break;
        }
    }
    Ok(labels)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn separates_two_well_apart_blobs() {
        let mut v = Vec::new();
        for i in 0..20 {
            let off = if i < 10 { 0.0 } else { 10.0 };
            v.extend([off + (i % 3) as f64 * 0.1, off - (i % 4) as f64 * 0.1]);
        }
        let data = DMatrix::from_row_slice(20, 2, &v);
        let l = cluster_rows(&data, 2, 7).unwrap();
        assert!(l[..10].iter().all(|&x| x == l[0]));
        assert!(l[10..].iter().all(|&x| x == l[10]));
        assert_ne!(l[0], l[10]);
    }

    #[test]
    fn too_few_points_is_an_error() {
        assert!(cluster_rows(&DMatrix::zeros(2, 3), 3, 1).is_err());
        assert!(cluster_rows(&DMatrix::zeros(5, 3), 2, 1).is_err());
    }
}
