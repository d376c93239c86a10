//! Training the AV-HMM on many sequences by Baum–Welch (Rabiner 1989, §VI-B, eq. 109–111 for
//! several observation sequences; eq. 52–54 for Gaussian mixtures), as Terissi et al. 2011,
//! §4.1 do, from a k-means initialisation.
//!
//! Initialisation: the frames of all sequences (each dimension scaled to unit variance, so
//! the 77 audio dimensions and 4 visual ones count by their spread, not their units) are
//! clustered into N states by k-means, each state's frames into M components; transitions and
//! initial probabilities are the cluster-label counts, with one added so no transition starts
//! impossible (an ergodic model).
//!
//! Covariance floor: each re-estimated covariance gets `floor · diag(σ²)` added, σ² the
//! variances of the whole training set. Full 81 × 81 covariances from a few hundred frames
//! per component are otherwise near-singular and fit the training sentences' noise; the
//! floor is a ridge in units of each feature's own spread. With floor 0 every iteration
//! provably does not lower the likelihood (EM); with a floor the increase holds for the
//! likelihood regularised by the equivalent inverse-Wishart prior, and in practice for the
//! plain one too.

use super::error::{SpeechError, bad};
use super::forward_backward::{Posteriors, forward_backward};
use super::gaussian::Gaussian;
use super::hmm::{Component, Hmm};
use super::kmeans::cluster_rows;
use crate::math::{DMatrix, DVector};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// Training parameters.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainOptions {
    /// N, ergodic states.
    pub n_states: usize,
    /// M, Gaussians per state.
    pub n_mixtures: usize,
    /// Iteration cap.
    pub max_iterations: usize,
    /// Stop when an iteration raises the log-likelihood by less than this per frame (nats).
    pub tolerance: f64,
    /// Covariance floor as a fraction of each feature's variance (module doc).
    pub covariance_floor: f64,
    /// Seed of the k-means initialisation.
    pub seed: u64,
}

impl Default for TrainOptions {
    /// N 16, M 4 (inside the paper's ranges [8, 40] × [2, 7]; trained on 130 demo sentences
    /// and scored on the tuning seeds 101–103, docs/speech.md: M 4 raised ACC by 0.013–0.017
    /// over M 2, N 24 or M 8 by no more, N 32 × M 4 less); 40 iterations at most; stop below
    /// 0.03 nats per frame (on 120 Festival sentences the gain falls to that by iteration
    /// 12; the 10 more iterations to 10⁻³ add < 0.3 nats per frame and double the training
    /// time); floor 0.1 (0.05 and 0.2 moved held-out ACC by under 0.01 either way: lower
    /// floors fit the training set better and the test set no better).
    fn default() -> Self {
        Self {
            n_states: 16,
            n_mixtures: 4,
            max_iterations: 40,
            tolerance: 0.03,
            covariance_floor: 0.1,
            seed: 1,
        }
    }
}

/// How training went.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct TrainReport {
    /// Log-likelihood per frame of the training data under each successive model, the
    /// initial one first; the returned model is the last.
    pub log_likelihood_per_frame: Vec<f64>,
    /// The change fell below the tolerance before the iteration cap.
    pub converged: bool,
}

/// Trains an HMM on `sequences` (each T_s × d, rows are frames). `progress` is called after
/// each E-step with the iteration number (0 for the initial model) and the log-likelihood per
/// frame.
///
/// # Errors
/// No sequences, sequences of different widths, bad options, fewer frames than states ×
/// mixtures, a constant feature, or a numerically degenerate model.
pub fn train_hmm(
    sequences: &[DMatrix],
    opts: &TrainOptions,
    progress: &mut dyn FnMut(usize, f64),
) -> Result<(Hmm, TrainReport), SpeechError> {
    let prepared = Prepared::new(sequences, opts)?;
    let hmm = initialise(sequences, &prepared.data, &prepared.variance, &prepared.floor, opts)?;
    prepared.run(hmm, opts, progress)
}

/// Continues Baum–Welch from `start` on `sequences` (e.g. a model trained on part of them,
/// given the rest), as [`train_hmm`] does after its initialisation.
///
/// # Errors
/// As [`train_hmm`], and a `start` of another dimension or size than `opts` asks for.
pub fn improve_hmm(
    start: Hmm,
    sequences: &[DMatrix],
    opts: &TrainOptions,
    progress: &mut dyn FnMut(usize, f64),
) -> Result<(Hmm, TrainReport), SpeechError> {
    let prepared = Prepared::new(sequences, opts)?;
    if start.dim() != prepared.data.ncols()
        || start.n_states() != opts.n_states
        || start.n_mixtures() != opts.n_mixtures
    {
        return Err(bad(
            "starting model",
            format!(
                "{} states × {} mixtures of dimension {}, for {} × {} of dimension {}",
                start.n_states(),
                start.n_mixtures(),
                start.dim(),
                opts.n_states,
                opts.n_mixtures,
                prepared.data.ncols()
            ),
        ));
    }
    prepared.run(start, opts, progress)
}

/// The training data stacked, with what the iterations share.
struct Prepared {
    data: DMatrix,
    bounds: Vec<(usize, usize)>,
    variance: DVector,
    floor: DMatrix,
}

impl Prepared {
    fn new(sequences: &[DMatrix], opts: &TrainOptions) -> Result<Self, SpeechError> {
        if opts.n_states == 0 || opts.n_mixtures == 0 {
            return Err(bad(
                "model size",
                format!("{} states × {} mixtures", opts.n_states, opts.n_mixtures),
            ));
        }
        if !(opts.covariance_floor >= 0.0 && opts.covariance_floor.is_finite()) {
            return Err(bad("covariance floor", opts.covariance_floor.to_string()));
        }
        let data = concatenate(sequences)?;
        let variance = column_variances(&data);
        if let Some(k) = variance.iter().position(|v| v.is_nan() || *v <= 1e-12) {
            return Err(SpeechError::Degenerate(format!(
                "feature {k} (constant over the training data)"
            )));
        }
        let floor = DMatrix::from_diagonal(&(variance.clone() * opts.covariance_floor));
        Ok(Self { bounds: sequence_bounds(sequences), data, variance, floor })
    }

    /// Baum–Welch from `hmm` until the gain per frame falls below the tolerance or the
    /// iteration cap.
    fn run(
        &self,
        mut hmm: Hmm,
        opts: &TrainOptions,
        progress: &mut dyn FnMut(usize, f64),
    ) -> Result<(Hmm, TrainReport), SpeechError> {
        let n_frames = self.data.nrows();
        let mut history = Vec::new();
        let mut converged = false;
        for iteration in 0..=opts.max_iterations {
            let comp_log = hmm.component_log_densities(&self.data)?;
            let posts: Vec<Posteriors> = self
                .bounds
                .par_iter()
                .map(|&(s, len)| {
                    forward_backward(
                        &hmm.initial,
                        &hmm.transitions,
                        &comp_log.rows(s, len).into_owned(),
                        opts.n_mixtures,
                    )
                })
                .collect::<Result<_, _>>()?;
            let ll = posts.iter().map(|p| p.log_likelihood).sum::<f64>() / n_frames as f64;
            if !ll.is_finite() {
                return Err(SpeechError::Degenerate(format!(
                    "training (the log-likelihood became {ll} at iteration {iteration})"
                )));
            }
            progress(iteration, ll);
            if let Some(prev) = history.last()
                && ll - prev < opts.tolerance
            {
                history.push(ll);
                converged = true;
                break;
            }
            history.push(ll);
            if iteration == opts.max_iterations {
                break;
            }
            hmm = reestimate(&hmm, &self.data, &self.bounds, &posts, &self.floor)?;
        }
        Ok((hmm, TrainReport { log_likelihood_per_frame: history, converged }))
    }
}

/// All sequences' frames stacked.
fn concatenate(sequences: &[DMatrix]) -> Result<DMatrix, SpeechError> {
    let first = sequences.first().ok_or(SpeechError::Empty("training sequences"))?;
    let d = first.ncols();
    let total: usize = sequences.iter().map(DMatrix::nrows).sum();
    let mut data = DMatrix::zeros(total, d);
    let mut r = 0;
    for s in sequences {
        if s.ncols() != d {
            return Err(SpeechError::DimensionMismatch {
                what: "sequence width",
                expected: d,
                got: s.ncols(),
            });
        }
        if s.nrows() == 0 {
            return Err(SpeechError::Empty("frames in a training sequence"));
        }
        data.rows_mut(r, s.nrows()).copy_from(s);
        r += s.nrows();
    }
    Ok(data)
}

fn sequence_bounds(sequences: &[DMatrix]) -> Vec<(usize, usize)> {
    let mut start = 0;
    sequences
        .iter()
        .map(|s| {
            let b = (start, s.nrows());
            start += s.nrows();
            b
        })
        .collect()
}

fn column_variances(data: &DMatrix) -> DVector {
    let n = data.nrows() as f64;
    DVector::from_iterator(
        data.ncols(),
        data.column_iter().map(|c| {
            let m = c.mean();
            c.iter().map(|v| (v - m).powi(2)).sum::<f64>() / n
        }),
    )
}

/// Posterior weight below which a frame is left out of a component's re-estimation.
const NEGLIGIBLE_WEIGHT: f64 = 1e-12;

/// Weighted mean and covariance (plus floor) of the rows of `data`, weights `w`.
fn weighted_gaussian(
    data: &DMatrix,
    w: &[f64],
    floor: &DMatrix,
) -> Result<(f64, Gaussian), SpeechError> {
    let total: f64 = w.iter().sum();
    if total.is_nan() || total <= 1e-10 {
        return Err(SpeechError::Degenerate("mixture component (no frames)".into()));
    }
    // Frames the component does not explain carry posteriors of e⁻³⁰ and less in 81
    // dimensions; leaving out those under NEGLIGIBLE_WEIGHT changes the sums by less than
    // T · 10⁻¹² frames and shrinks the products below to the component's own frames.
    let kept: Vec<usize> = (0..w.len()).filter(|&t| w[t] > NEGLIGIBLE_WEIGHT).collect();
    let own = data.select_rows(&kept);
    let w_kept = DVector::from_iterator(kept.len(), kept.iter().map(|&t| w[t]));
    let total_kept = w_kept.sum();
    let mean = own.tr_mul(&w_kept) / total_kept;
    // Σ = Σ_t w_t (o_t − μ)(o_t − μ)ᵀ / Σ_t w_t as one blocked product Xᵀ X with X's rows
    // √w_t (o_t − μ)ᵀ, built column by column (column-major storage). `tr_mul` would take
    // d² unblocked dot products over the frames, which is memory-bound.
    let sqrt_w = w_kept.map(f64::sqrt);
    let mut scaled = own;
    for (mut col, m) in scaled.column_iter_mut().zip(mean.iter()) {
        col.add_scalar_mut(-m);
        col.component_mul_assign(&sqrt_w);
    }
    let cov = scaled.transpose() * &scaled / total_kept + floor;
    let cov = (&cov + cov.transpose()) * 0.5;
    Ok((total, Gaussian::new(mean, cov)?))
}

fn initialise(
    sequences: &[DMatrix],
    data: &DMatrix,
    variance: &DVector,
    floor: &DMatrix,
    opts: &TrainOptions,
) -> Result<Hmm, SpeechError> {
    let (n, m) = (opts.n_states, opts.n_mixtures);
    let mut standardised = data.clone();
    for (k, mut col) in standardised.column_iter_mut().enumerate() {
        col /= variance[k].sqrt();
    }
    let labels = cluster_rows(&standardised, n, opts.seed)?;
    let mut states = Vec::with_capacity(n);
    for j in 0..n {
        let rows: Vec<usize> = (0..labels.len()).filter(|&i| labels[i] == j).collect();
        if rows.len() < m {
            return Err(SpeechError::TooFew {
                what: "frames in a state for its mixtures",
                need: m,
                got: rows.len(),
            });
        }
        let sub = standardised.select_rows(&rows);
        let sub_labels = if m == 1 {
            vec![0; rows.len()]
        } else {
            cluster_rows(&sub, m, opts.seed + 1 + j as u64)?
        };
        let own = data.select_rows(&rows);
        let mut comps = Vec::with_capacity(m);
        for k in 0..m {
            let w: Vec<f64> = sub_labels.iter().map(|&l| if l == k { 1.0 } else { 0.0 }).collect();
            let (count, gaussian) = weighted_gaussian(&own, &w, floor)?;
            comps.push(Component { weight: count / rows.len() as f64, gaussian });
        }
        states.push(comps);
    }
    let mut initial = vec![1.0; n];
    let mut transitions = DMatrix::from_element(n, n, 1.0);
    let mut start = 0;
    for s in sequences {
        initial[labels[start]] += 1.0;
        for t in start + 1..start + s.nrows() {
            transitions[(labels[t - 1], labels[t])] += 1.0;
        }
        start += s.nrows();
    }
    normalise(&mut initial);
    for mut row in transitions.row_iter_mut() {
        let s = row.sum();
        row /= s;
    }
    Ok(Hmm { initial, transitions, states })
}

fn normalise(v: &mut [f64]) {
    let s: f64 = v.iter().sum();
    v.iter_mut().for_each(|x| *x /= s);
}

/// The M-step: π, A, c, μ, Σ from the posteriors of every sequence.
fn reestimate(
    hmm: &Hmm,
    data: &DMatrix,
    bounds: &[(usize, usize)],
    posts: &[Posteriors],
    floor: &DMatrix,
) -> Result<Hmm, SpeechError> {
    let (n, m) = (hmm.n_states(), hmm.n_mixtures());
    let mut initial = vec![0.0; n];
    let mut xi = DMatrix::zeros(n, n);
    let mut gamma = DMatrix::zeros(data.nrows(), n * m);
    for (p, &(s, len)) in posts.iter().zip(bounds) {
        for (j, init) in initial.iter_mut().enumerate() {
            *init += p.states[(0, j)];
        }
        xi += &p.transitions;
        gamma.rows_mut(s, len).copy_from(&p.components);
    }
    normalise(&mut initial);
    let mut transitions = hmm.transitions.clone();
    for i in 0..n {
        let s = xi.row(i).sum();
        // A state never left (a sequence ending in it only) keeps its old row.
        if s > 1e-10 {
            transitions.set_row(i, &(xi.row(i) / s));
        }
    }
    let old: Vec<&Component> = hmm.components().collect();
    let fitted: Vec<(f64, Gaussian)> = (0..n * m)
        .into_par_iter()
        .map(|c| {
            let w: Vec<f64> = gamma.column(c).iter().copied().collect();
            // A component that lost all its frames keeps its Gaussian at zero weight.
            weighted_gaussian(data, &w, floor).or_else(|_| Ok((0.0, old[c].gaussian.clone())))
        })
        .collect::<Result<_, SpeechError>>()?;
    let mut states = Vec::with_capacity(n);
    for j in 0..n {
        let occupancy: f64 = (0..m).map(|k| fitted[j * m + k].0).sum();
        let comps = (0..m)
            .map(|k| {
                let (w, g) = &fitted[j * m + k];
                let weight = if occupancy > 0.0 { w / occupancy } else { hmm.states[j][k].weight };
                Component { weight, gaussian: g.clone() }
            })
            .collect();
        states.push(comps);
    }
    Ok(Hmm { initial, transitions, states })
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::rngs::StdRng;
    use rand::{Rng, SeedableRng};
    use rand_distr::{Distribution, Normal};

    /// Sequences from a known 3-state, 2-dimensional HMM with well-separated means.
    fn sample_sequences(seed: u64) -> Vec<DMatrix> {
        let mut rng = StdRng::seed_from_u64(seed);
        let means = [[0.0, 0.0], [4.0, 1.0], [1.0, 5.0]];
        let noise = Normal::new(0.0, 1.0).unwrap();
        (0..12)
            .map(|_| {
                let mut s = rng.random_range(0..3);
                let rows: Vec<f64> = (0..40)
                    .flat_map(|_| {
                        if rng.random::<f64>() < 0.2 {
                            s = (s + 1) % 3;
                        }
                        let x = means[s][0] + noise.sample(&mut rng);
                        let y = means[s][1] + 0.5 * x + noise.sample(&mut rng);
                        [x, y]
                    })
                    .collect();
                DMatrix::from_row_slice(40, 2, &rows)
            })
            .collect()
    }

    #[test]
    fn log_likelihood_never_decreases() {
        let seqs = sample_sequences(3);
        let opts = TrainOptions {
            n_states: 3,
            n_mixtures: 2,
            max_iterations: 25,
            tolerance: 0.0,
            covariance_floor: 0.0,
            seed: 5,
        };
        let mut seen = Vec::new();
        let (hmm, report) = train_hmm(&seqs, &opts, &mut |i, ll| seen.push((i, ll))).unwrap();
        assert_eq!(seen.len(), report.log_likelihood_per_frame.len());
        for w in report.log_likelihood_per_frame.windows(2) {
            assert!(w[1] >= w[0] - 1e-9, "{:?}", report.log_likelihood_per_frame);
        }
        assert!(report.log_likelihood_per_frame.len() > 3);
        // The learnt means include one near each true state mean.
        for want in [[0.0, 0.0], [4.0, 3.0], [1.0, 5.5]] {
            let best = hmm
                .components()
                .filter(|c| c.weight > 0.2)
                .map(|c| {
                    ((c.gaussian.mean[0] - want[0]).powi(2)
                        + (c.gaussian.mean[1] - want[1]).powi(2))
                    .sqrt()
                })
                .fold(f64::INFINITY, f64::min);
            assert!(best < 1.0, "no component near {want:?}: {best}");
        }
    }

    #[test]
    fn converges_and_stops_with_a_tolerance() {
        let seqs = sample_sequences(4);
        let opts = TrainOptions {
            n_states: 3,
            n_mixtures: 1,
            max_iterations: 200,
            tolerance: 1e-6,
            covariance_floor: 0.01,
            seed: 2,
        };
        let (_, report) = train_hmm(&seqs, &opts, &mut |_, _| {}).unwrap();
        assert!(report.converged);
        assert!(report.log_likelihood_per_frame.len() < 200);
    }

    #[test]
    fn degenerate_training_data_is_refused() {
        let mut none = |_, _| {};
        assert!(train_hmm(&[], &TrainOptions::default(), &mut none).is_err());
        let constant = vec![DMatrix::from_element(50, 2, 1.0)];
        assert!(matches!(
            train_hmm(&constant, &TrainOptions::default(), &mut none),
            Err(SpeechError::Degenerate(_))
        ));
        let few = vec![DMatrix::from_fn(5, 2, |i, j| (i * 2 + j) as f64)];
        assert!(train_hmm(&few, &TrainOptions::default(), &mut none).is_err());
    }
}
