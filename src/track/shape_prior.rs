//! The predictor's own shape prior, for re-aligning a face from a few points a person placed:
//! how a residual at those points goes with residuals at the others.
//!
//! Each leaf of a stage's regression trees is a shape increment, the (shrunk) mean of the
//! residuals `target − current` of the training faces that reached it, in the box-normalised
//! frame (Kazemi & Sullivan 2014, §2.3.2 and eq. 7 with learning rate ν). Over a stage's
//! leaves (500 trees × 16 for dlib's 68-point model) these increments are samples of the
//! residuals that stage was trained to remove, so their second moment
//! `Σ_t = (1/L) Σ_l v_l v_lᵀ` is a covariance of those residuals: the lower-lip midline
//! wrong by 1 means its neighbours wrong by ≈ 1 and the chin by ≈ 0.8 (on dlib's model).
//! The directions that only move, turn or scale the face (the similarity at the mean shape)
//! are projected out, `P Σ_t P`, as an active shape model takes its covariance after
//! Procrustes alignment (Cootes et al., "Active Shape Models", 1995): the face's place is set
//! by all its points and its box, so a correction of a few points is read as a change of the
//! face's shape. This is a departure from dlib, which has no prior; `docs/tracking.md` says
//! why and what it was chosen on.
//!
//! A residual known at the held points h carries to the others by the conditional mean of a
//! zero-mean Gaussian, `E[d_o | d_h] = Σ_oh (Σ_hh + ε I)⁻¹ d_h` (Bishop, *Pattern Recognition
//! and Machine Learning*, 2006, eq. 2.81), with a small ridge ε (a thousandth of the mean
//! variance, [`HELD_RIDGE`]) that keeps `Σ_hh` invertible when many points are held. [`HeldCarry`] holds
//! these gains for one set of held points: the last stage's for the residual a finished
//! cascade leaves (where a tracked frame is wrong), and each stage's own for what that stage's
//! trees get wrong at the held points. `cascade::run_cascade` applies them; `realign` is the
//! use. Start at [`ShapePrior::of_predictor`], then [`HeldCarry::new`].

use super::predictor_file::ShapePredictor;
use nalgebra::{DMatrix, DVector, Vector2};

/// The ridge added to `Σ_hh`, as a fraction of the mean variance of `Σ` (its trace over its
/// size): the user's placement taken as exact up to an independent error of that variance.
/// It keeps the solve well-posed when held points are many or move together, and it is not
/// negligible there: a lip's outer and inner midline points are so alike in the prior that a
/// difference between their corrections lies where `Σ_hh` has almost no variance; the ridge
/// changes the carry of the two moved together by up to 5 % over the stages, of one moved
/// alone by up to 60 % (`docs/tracking.md`; 0.03 and 0.1 carried less, measured there).
pub const HELD_RIDGE: f64 = 1e-3;

/// Per stage, the second moment of the stage's leaf increments (`2·parts` square, x and y
/// of each point interleaved as in the predictor's shapes).
#[derive(Clone, Debug, PartialEq)]
pub struct ShapePrior {
    stages: Vec<DMatrix<f64>>,
}

impl ShapePrior {
    /// The prior of `predictor`: one covariance per stage from its leaves, the similarity
    /// directions at the mean shape projected out (a correction is read as a change of the
    /// face's shape, not of where it is). About 2·10⁹ multiply-adds for dlib's 68-point model
    /// (15 stages × 8,000 leaves × 136²; ≈ 0.2 s of CPU), so it is made when a re-alignment
    /// first needs it, not on reading.
    pub fn of_predictor(predictor: &ShapePredictor) -> Self {
        let len = 2 * predictor.num_parts();
        let shape_only = residual_projector(&predictor.mean_shape);
        let stages = predictor
            .stages
            .iter()
            .map(|stage| {
                let leaves = stage.trees.all_leaves();
                let count = leaves.len().checked_div(len).unwrap_or(0);
                if count == 0 {
                    return DMatrix::zeros(len, len);
                }
                let v = DMatrix::<f32>::from_column_slice(len, count, &leaves[..count * len]);
                let second = (&v * v.transpose()).map(f64::from) / count as f64;
                &shape_only * second * &shape_only
            })
            .collect();
        Self { stages }
    }

    /// Number of stages.
    pub fn len(&self) -> usize {
        self.stages.len()
    }

    pub fn is_empty(&self) -> bool {
        self.stages.is_empty()
    }
}

/// The conditional-mean gains of a [`ShapePrior`] for one set of held points: a residual
/// `r` (held position − current, box-normalised, x and y per held point in the order held)
/// moves the whole shape by `K·r`.
#[derive(Clone, Debug, PartialEq)]
pub struct HeldCarry {
    held: Vec<usize>,
    /// For the residual of the start shape (the last stage's covariance).
    start: DMatrix<f64>,
    /// For what stage t's trees move the held points away from where they are held.
    stages: Vec<DMatrix<f64>>,
}

impl HeldCarry {
    /// The gains for holding the points `held` (indices, in the order their positions will be
    /// given). `None` when nothing is held, an index is past the shape, a point is held twice,
    /// the prior has no stage, or a stage's `Σ_hh` cannot be inverted even with the ridge.
    pub fn new(prior: &ShapePrior, held: &[usize]) -> Option<Self> {
        let len = prior.stages.first()?.nrows();
        let mut seen = vec![false; len / 2];
        for &i in held {
            if i >= len / 2 || std::mem::replace(&mut seen[i], true) {
                return None;
            }
        }
        if held.is_empty() {
            return None;
        }
        let stages =
            prior.stages.iter().map(|s| conditional_gain(s, held)).collect::<Option<Vec<_>>>()?;
        let start = stages.last()?.clone();
        Some(Self { held: held.to_vec(), start, stages })
    }

    /// The held points' indices, in order.
    pub fn held(&self) -> &[usize] {
        &self.held
    }

    /// Number of stages it has gains for.
    pub fn num_stages(&self) -> usize {
        self.stages.len()
    }

    /// Moves `shape` (flat x, y pairs, box-normalised) by the conditional mean of its
    /// residual given the residual at the held points (`targets`, one per held point, in
    /// order), then puts the held points on their targets. `stage` is the stage whose trees
    /// just ran (`None`: the start shape, before any); past the last stage, the last.
    pub fn carry(&self, stage: Option<usize>, shape: &mut [f32], targets: &[Vector2<f32>]) {
        let gain = match stage {
            None => &self.start,
            Some(t) => &self.stages[t.min(self.stages.len() - 1)],
        };
        let residual = DVector::from_iterator(
            2 * self.held.len(),
            self.held.iter().zip(targets).flat_map(|(&i, p)| {
                [f64::from(p.x - shape[2 * i]), f64::from(p.y - shape[2 * i + 1])]
            }),
        );
        let moved = gain * residual;
        for (v, d) in shape.iter_mut().zip(moved.iter()) {
            *v += *d as f32;
        }
        for (&i, p) in self.held.iter().zip(targets) {
            shape[2 * i] = p.x;
            shape[2 * i + 1] = p.y;
        }
    }
}

/// The orthogonal projector onto shape changes that are not a similarity of `mean` (flat x, y
/// pairs): `I − Q (QᵀQ)⁻¹ Qᵀ`, Q's columns the four similarity directions at the mean shape
/// (translation in x and in y, scaling about the centroid, rotation about it). It is the
/// identity when the mean has no spread (Q is then rank-deficient).
fn residual_projector(mean: &[Vector2<f32>]) -> DMatrix<f64> {
    let len = 2 * mean.len();
    let identity = DMatrix::identity(len, len);
    if mean.is_empty() {
        return identity;
    }
    let m: Vec<Vector2<f64>> = mean.iter().map(|p| p.cast()).collect();
    let c = m.iter().sum::<Vector2<f64>>() / m.len() as f64;
    let q = DMatrix::from_fn(len, 4, |r, k| {
        let d = m[r / 2] - c;
        match (k, r % 2) {
            (0, 0) | (1, 1) => 1.0,
            (0, _) | (1, _) => 0.0,
            (2, 0) => d.x,
            (2, _) => d.y,
            (_, 0) => -d.y,
            (_, _) => d.x,
        }
    });
    match (q.transpose() * &q).cholesky() {
        Some(qtq) => identity - &q * qtq.inverse() * q.transpose(),
        None => identity,
    }
}

/// `Σ_:h (Σ_hh + ε I)⁻¹` for the held points' rows and columns (x and y of each).
fn conditional_gain(sigma: &DMatrix<f64>, held: &[usize]) -> Option<DMatrix<f64>> {
    let len = sigma.nrows();
    let h: Vec<usize> = held.iter().flat_map(|&i| [2 * i, 2 * i + 1]).collect();
    let ridge = HELD_RIDGE * sigma.trace() / len.max(1) as f64;
    let mut hh = DMatrix::from_fn(h.len(), h.len(), |a, b| sigma[(h[a], h[b])]);
    for a in 0..h.len() {
        hh[(a, a)] += ridge;
    }
    let chol = hh.cholesky()?;
    // K = Σ_:h Σ_hh⁻¹, i.e. Kᵀ = Σ_hh⁻¹ Σ_h: (Σ_hh symmetric).
    let rows_h = DMatrix::from_fn(h.len(), len, |a, r| sigma[(h[a], r)]);
    let k = chol.solve(&rows_h).transpose();
    k.iter().all(|v| v.is_finite()).then_some(k)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::track::predictor_file::{Forest, Split, Stage, Tree};

    /// A four-point predictor (a square) whose stages' leaves are ± the given increments.
    fn square_with_leaves(increments: &[[f32; 8]]) -> ShapePredictor {
        let leaves: Vec<f32> =
            increments.iter().flat_map(|v| [*v, v.map(|x| -x)]).flatten().collect();
        let depth_splits = leaves.len() / 8 - 1;
        let tree =
            Tree { splits: vec![Split { a: 0, b: 0, threshold: 0.0 }; depth_splits], leaves };
        let stage = Stage {
            anchors: vec![0],
            offsets: vec![Vector2::zeros()],
            trees: [tree].into_iter().collect::<Forest>(),
        };
        ShapePredictor {
            mean_shape: [(0.3, 0.3), (0.7, 0.3), (0.3, 0.7), (0.7, 0.7)]
                .map(|(x, y)| Vector2::new(x, y))
                .to_vec(),
            stages: vec![stage.clone(), stage],
        }
    }

    /// Two ways the square changes shape (neither moves, turns or scales it): B moves
    /// points 0 and 3 right and 1 and 2 left, C moves 0 and 3 down and 1 and 2 up.
    const B: [f32; 8] = [0.1, 0.0, -0.1, 0.0, -0.1, 0.0, 0.1, 0.0];
    const C: [f32; 8] = [0.0, 0.2, 0.0, -0.2, 0.0, -0.2, 0.0, 0.2];

    #[test]
    fn a_held_points_residual_moves_the_points_that_go_with_it() {
        let prior = ShapePrior::of_predictor(&square_with_leaves(&[B, C]));
        assert_eq!(prior.len(), 2);
        let carry = HeldCarry::new(&prior, &[0]).unwrap();
        let mut shape = [0.3f32, 0.3, 0.7, 0.3, 0.3, 0.7, 0.7, 0.7];
        let target = [Vector2::new(0.31f32, 0.32)];
        carry.carry(None, &mut shape, &target);
        assert_eq!((shape[0], shape[1]), (0.31, 0.32), "the held point is on its target");
        // Point 3 always moved as point 0 did, points 1 and 2 the other way (less the
        // ridge's 0.25 %).
        let moved = |i: usize, from: [f32; 2]| [shape[2 * i] - from[0], shape[2 * i + 1] - from[1]];
        for (i, from, sign) in [(1, [0.7, 0.3], -1.0), (2, [0.3, 0.7], -1.0), (3, [0.7, 0.7], 1.0)]
        {
            let [dx, dy] = moved(i, from);
            assert!(
                (dx - sign * 0.01).abs() < 1e-4 && (dy - sign * 0.02).abs() < 1e-4,
                "{shape:?}"
            );
        }
    }

    #[test]
    fn where_the_face_is_does_not_carry() {
        // Leaves that mostly move the whole square (dlib's early stages place the face in
        // its box), and a little of C: a held point moved sideways says nothing about the
        // others' shape, so nothing follows it in x.
        let tx = [0.1f32, 0.0, 0.1, 0.0, 0.1, 0.0, 0.1, 0.0];
        let ty = [0.0f32, 0.1, 0.0, 0.1, 0.0, 0.1, 0.0, 0.1];
        let prior = ShapePrior::of_predictor(&square_with_leaves(&[tx, ty, C, [0.0; 8]]));
        let carry = HeldCarry::new(&prior, &[0]).unwrap();
        let mut shape = [0.3f32, 0.3, 0.7, 0.3, 0.3, 0.7, 0.7, 0.7];
        carry.carry(Some(1), &mut shape, &[Vector2::new(0.33f32, 0.3)]);
        let still = [0.7f32, 0.3, 0.3, 0.7, 0.7, 0.7];
        assert!(shape[2..].iter().zip(still).all(|(a, b)| (a - b).abs() < 1e-6), "{shape:?}");
    }

    #[test]
    fn no_gains_for_nothing_held_a_point_twice_or_past_the_shape() {
        let prior = ShapePrior::of_predictor(&square_with_leaves(&[B, C]));
        assert!(HeldCarry::new(&prior, &[]).is_none());
        assert!(HeldCarry::new(&prior, &[1, 1]).is_none());
        assert!(HeldCarry::new(&prior, &[4]).is_none());
        let all = HeldCarry::new(&prior, &[0, 1, 2, 3]).unwrap();
        assert_eq!((all.held(), all.num_stages()), (&[0, 1, 2, 3][..], 2));
        let none = ShapePredictor { stages: vec![], ..square_with_leaves(&[B]) };
        let empty = ShapePrior::of_predictor(&none);
        assert!(empty.is_empty() && HeldCarry::new(&empty, &[0]).is_none());
    }
}
