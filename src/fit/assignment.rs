//! Minimum-cost one-to-one assignment of rows to columns (the Hungarian method), used to give
//! each suggested landmark its own vertex.
//!
//! The shortest-augmenting-path form with row and column potentials (Kuhn 1955, Munkres 1957;
//! as in Jonker & Volgenant 1987): one row is added at a time and the cheapest alternating
//! path to a free column is found with Dijkstra over reduced costs, `O(n² m)` for `n` rows
//! and `m ≥ n` columns.

use crate::math::Real;

/// Assigns every row of the `rows × cols` cost matrix `cost` (row-major) a distinct column
/// so the summed cost is least. Returns each row's column. `None` when there are more rows
/// than columns, the matrix has the wrong size, or a cost is not finite.
pub fn assign_min_cost(cost: &[Real], rows: usize, cols: usize) -> Option<Vec<usize>> {
    if rows > cols || cost.len() != rows * cols || cost.iter().any(|c| !c.is_finite()) {
        return None;
    }
    if rows == 0 {
        return Some(Vec::new());
    }
    // 1-based with column 0 as the virtual start: u, v are the potentials, owner[j] the row
    // holding column j (0: free).
    let c = |i: usize, j: usize| cost[(i - 1) * cols + (j - 1)];
    let mut u = vec![0.0; rows + 1];
    let mut v = vec![0.0; cols + 1];
    let mut owner = vec![0usize; cols + 1];
    let mut way = vec![0usize; cols + 1];
    for i in 1..=rows {
        owner[0] = i;
        let mut j0 = 0;
        let mut min_to = vec![Real::INFINITY; cols + 1];
        let mut used = vec![false; cols + 1];
        loop {
            used[j0] = true;
            let i0 = owner[j0];
            let (mut delta, mut j1) = (Real::INFINITY, 0);
            for j in 1..=cols {
                if used[j] {
                    continue;
                }
                let reduced = c(i0, j) - u[i0] - v[j];
                if reduced < min_to[j] {
                    min_to[j] = reduced;
                    way[j] = j0;
                }
                if min_to[j] < delta {
                    delta = min_to[j];
                    j1 = j;
                }
            }
            for j in 0..=cols {
                if used[j] {
                    u[owner[j]] += delta;
                    v[j] -= delta;
                } else {
                    min_to[j] -= delta;
                }
            }
            j0 = j1;
            if owner[j0] == 0 {
                break;
            }
        }
        // Flip the alternating path back to the start.
        loop {
            let j1 = way[j0];
            owner[j0] = owner[j1];
            j0 = j1;
            if j0 == 0 {
                break;
            }
        }
    }
    let mut of_row = vec![0; rows];
    for j in 1..=cols {
        if owner[j] != 0 {
            of_row[owner[j] - 1] = j - 1;
        }
    }
    Some(of_row)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every injective assignment's cost, by brute force.
    fn best_by_enumeration(cost: &[Real], rows: usize, cols: usize) -> Real {
        fn go(r: usize, rows: usize, cols: usize, cost: &[Real], used: &mut Vec<bool>) -> Real {
            if r == rows {
                return 0.0;
            }
            let mut best = Real::INFINITY;
            for j in 0..cols {
                if !used[j] {
                    used[j] = true;
                    best = best.min(cost[r * cols + j] + go(r + 1, rows, cols, cost, used));
                    used[j] = false;
                }
            }
            best
        }
        go(0, rows, cols, cost, &mut vec![false; cols])
    }

    #[test]
    fn matches_enumeration_on_small_matrices() {
        // A deterministic pseudo-random sequence (LCG) of costs in [0, 10).
        let mut s: u64 = 7;
        let mut next = || {
            s = s.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (s >> 33) as Real / (1u64 << 31) as Real * 10.0
        };
        for (rows, cols) in [(1, 1), (3, 3), (4, 6), (5, 5), (5, 7)] {
            let cost: Vec<Real> = (0..rows * cols).map(|_| next()).collect();
            let a = assign_min_cost(&cost, rows, cols).unwrap();
            let mut seen = a.clone();
            seen.sort_unstable();
            seen.dedup();
            assert_eq!(seen.len(), rows, "columns are distinct");
            let total: Real = a.iter().enumerate().map(|(r, &j)| cost[r * cols + j]).sum();
            assert!((total - best_by_enumeration(&cost, rows, cols)).abs() < 1e-9);
        }
    }

    #[test]
    fn the_greedy_choice_is_not_taken_when_it_costs_more() {
        // Row 0 greedily takes column 0 (cost 1), forcing row 1 onto cost 10; the optimum
        // swaps them (2 + 2).
        let cost = [1.0, 2.0, 2.0, 10.0];
        assert_eq!(assign_min_cost(&cost, 2, 2), Some(vec![1, 0]));
    }

    #[test]
    fn bad_shapes_are_refused() {
        assert_eq!(assign_min_cost(&[1.0, 2.0], 2, 1), None);
        assert_eq!(assign_min_cost(&[1.0], 1, 2), None);
        assert_eq!(assign_min_cost(&[Real::NAN], 1, 1), None);
        assert_eq!(assign_min_cost(&[], 0, 3), Some(vec![]));
    }
}
