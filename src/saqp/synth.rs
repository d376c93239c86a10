//! The synthesizers SAQP learns the quality of (Ma & Deng trained one predictor per
//! algorithm, §5.3). Each synthesizes a held-out sentence's motion, in region coefficients
//! per frame, from a training set of other sentences only:
//!
//! - **keyframe**: every phone's monophone mean (back-off: viseme class, global) placed at
//!   its midpoint, linear in between;
//! - **trajectory**: the SATF optimum y (eq. 4) at the midpoints, Ezzat et al.'s MMM
//!   trajectory synthesis;
//! - **concatenative**: per phone the training segments of the best context match (the
//!   neighbours two phones either way, the nearer weighing double; the phone's viseme class
//!   when the phone itself is unseen; closest duration breaks ties), each time-warped
//!   linearly onto the target interval and the best three averaged, cross-faded over 40 ms
//!   at the joins and smoothed by a narrow Gaussian, after eFASE. The segments are recorded
//!   motion, so each carries its own frame-to-frame tracking noise; no synthesizer would
//!   want to replay that, and left in it dominates this synthesizer's error with noise no
//!   phone sequence predicts. Averaging [`CONCAT_UNITS`] occurrences and the smoothing
//!   (whose width, [`SynthParams::smoothing`], the cross-validation chooses by the
//!   synthesizer's own error) both keep it out;
//! - **external**: the user's own per-frame positions for a corpus sentence.

use super::SaqpError;
use super::context::{ContextOptions, ContextStats};
use super::corpus::Corpus;
use super::prepared::{Prepared, PreparedSentence};
use super::sampling::{interpolate_keys, midpoint, sample_at, smooth_gaussian};
use super::satf::{SatfParams, fit_trajectory, sequence_stats};
use crate::math::{DVector, Point3};
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// A synthesis algorithm.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize, Deserialize)]
pub enum SynthKind {
    Keyframe,
    Trajectory,
    Concatenative,
    /// Motion supplied by the user.
    External,
}

impl SynthKind {
    pub const BUILT_IN: [SynthKind; 3] =
        [SynthKind::Keyframe, SynthKind::Trajectory, SynthKind::Concatenative];

    pub fn name(self) -> &'static str {
        match self {
            SynthKind::Keyframe => "keyframe",
            SynthKind::Trajectory => "trajectory",
            SynthKind::Concatenative => "concat",
            SynthKind::External => "external",
        }
    }
}

/// Half-width of the cross-fade at concatenation joins, seconds.
const JOIN_HALF_WIDTH: f64 = 0.04;
/// How much a match of the phone `offset` places away counts in choosing a unit.
const CONTEXT_WEIGHTS: [(isize, f64); 4] = [(-2, 0.5), (-1, 1.0), (1, 1.0), (2, 0.5)];
/// Recorded occurrences of a phone averaged into its unit. One recording replays its own
/// tracking noise, which no phone sequence predicts; the mean of the three best matches
/// keeps the context's coarticulation and divides that noise's variance by three (on the
/// demo seeds 1–8 the concatenative error's held-out RMSE ratio fell from 0.76 to 0.70;
/// docs/saqp.md).
pub const CONCAT_UNITS: usize = 3;

/// The settings of the built-in synthesizers.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct SynthParams {
    /// λ and W's order of the trajectory synthesizer (and of E).
    pub satf: SatfParams,
    /// Standard deviation, seconds, of the Gaussian that smooths concatenated motion
    /// (0 = none).
    pub smoothing: f64,
}

/// A training set: sentences of a prepared corpus, their context statistics and an index of
/// phone occurrences for concatenation.
pub struct TrainingSet<'a> {
    pub prepared: &'a Prepared,
    pub stats: ContextStats,
    occurrences: HashMap<u16, Vec<(usize, usize)>>,
    by_viseme: HashMap<u16, Vec<(usize, usize)>>,
}

impl<'a> TrainingSet<'a> {
    pub fn new(prepared: &'a Prepared, members: &[usize], options: ContextOptions) -> Self {
        let k = prepared.basis.dims();
        let stats = ContextStats::build(
            k,
            &prepared.phones,
            members.iter().map(|&s| {
                let s = &prepared.sentences[s];
                (&s.ids[..], &s.samples[..])
            }),
            options,
        );
        let mut occurrences: HashMap<u16, Vec<(usize, usize)>> = HashMap::new();
        let mut by_viseme: HashMap<u16, Vec<(usize, usize)>> = HashMap::new();
        for &s in members {
            for (i, &id) in prepared.sentences[s].ids.iter().enumerate() {
                occurrences.entry(id).or_default().push((s, i));
                if let Some(v) = prepared.phones.viseme(id) {
                    by_viseme.entry(v).or_default().push((s, i));
                }
            }
        }
        Self { prepared, stats, occurrences, by_viseme }
    }

    /// Synthesizes `target`'s frames (region coefficients) with a built-in algorithm.
    ///
    /// # Errors
    /// `AllPhonesUnseen`, `TooFewPhones`, a singular SATF system; `External` is not built in.
    pub fn synthesize(
        &self,
        kind: SynthKind,
        target: &PreparedSentence,
        params: SynthParams,
    ) -> Result<Vec<DVector>, SaqpError> {
        let phones = &self.prepared.phones;
        let n = target.n_frames();
        let mids: Vec<f64> = target.phones.iter().map(midpoint).collect();
        match kind {
            SynthKind::Keyframe => {
                sequence_stats(&target.name, &self.stats, phones, &target.ids)?;
                let keys: Vec<DVector> = target
                    .ids
                    .iter()
                    .map(|&id| self.stats.monophone(phones, id).map(|s| s.mean))
                    .collect::<Option<_>>()
                    .ok_or_else(|| SaqpError::AllPhonesUnseen(target.name.clone()))?;
                Ok(interpolate_keys(&mids, &keys, target.fps, n))
            }
            SynthKind::Trajectory => {
                let fit = fit_trajectory(
                    &target.name,
                    &self.stats,
                    phones,
                    &target.ids,
                    &target.phones,
                    target.fps,
                    params.satf,
                )?;
                Ok(interpolate_keys(&mids, &fit.y, target.fps, n))
            }
            SynthKind::Concatenative => {
                let joined = self.concatenate(target)?;
                Ok(smooth_gaussian(&joined, params.smoothing * target.fps))
            }
            SynthKind::External => {
                Err(SaqpError::Option("external motion is not synthesized".into()))
            }
        }
    }

    /// The `k` best training occurrences for phone `i` of `target`, best first: the phone (or
    /// one of its viseme class) whose neighbours two phones either way match the target's
    /// most (the nearer ones weigh double), closest in duration on a tie. Ties left are
    /// broken by corpus order, so the choice does not depend on hashing.
    fn best_segments(&self, target: &PreparedSentence, i: usize, k: usize) -> Vec<(usize, usize)> {
        let phones = &self.prepared.phones;
        let ids = &target.ids;
        let id = ids[i];
        let Some(cands) = self
            .occurrences
            .get(&id)
            .or_else(|| phones.viseme(id).and_then(|v| self.by_viseme.get(&v)))
        else {
            return Vec::new();
        };
        let dur = |p: &crate::alignment::Phone| (p.end - p.start).max(1e-3);
        let want = dur(&target.phones[i]);
        let same = |a: Option<&u16>, b: Option<&u16>| match (a, b) {
            (Some(a), Some(b)) if a == b => 1.0,
            (Some(&a), Some(&b))
                if phones.viseme(a).is_some() && phones.viseme(a) == phones.viseme(b) =>
            {
                0.4
            }
            (None, None) => 1.0,
            _ => 0.0,
        };
        let mut scored: Vec<((usize, usize), f64)> = cands
            .iter()
            .map(|&(s, j)| {
                let c = &self.prepared.sentences[s];
                let context: f64 = CONTEXT_WEIGHTS
                    .iter()
                    .map(|&(o, w)| w * same(neighbour(ids, i, o), neighbour(&c.ids, j, o)))
                    .sum();
                let timing = (dur(&c.phones[j]) / want).ln().abs();
                ((s, j), 4.0 * context - timing)
            })
            .collect();
        scored.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        scored.into_iter().take(k).map(|x| x.0).collect()
    }

    fn concatenate(&self, target: &PreparedSentence) -> Result<Vec<DVector>, SaqpError> {
        sequence_stats(&target.name, &self.stats, &self.prepared.phones, &target.ids)?;
        let global = self
            .stats
            .monophone(&self.prepared.phones, u16::MAX)
            .map(|s| s.mean)
            .ok_or_else(|| SaqpError::AllPhonesUnseen(target.name.clone()))?;
        let segments: Vec<Vec<(usize, usize)>> =
            (0..target.ids.len()).map(|i| self.best_segments(target, i, CONCAT_UNITS)).collect();
        let value = |i: usize, t: f64| -> DVector {
            if segments[i].is_empty() {
                return global.clone();
            }
            let tp = &target.phones[i];
            let span = tp.end - tp.start;
            let u = if span > 0.0 { (t - tp.start) / span } else { 0.5 };
            let mut sum = DVector::zeros(global.len());
            for &(s, j) in &segments[i] {
                let c = &self.prepared.sentences[s];
                let cp = &c.phones[j];
                sum += sample_at(&c.coefficients, (cp.start + u * (cp.end - cp.start)) * c.fps);
            }
            sum / segments[i].len() as f64
        };
        let last = target.phones.len() - 1;
        let mut i = 0;
        Ok((0..target.n_frames())
            .map(|f| {
                let t = f as f64 / target.fps;
                while i < last && target.phones[i].end <= t {
                    i += 1;
                }
                let p = &target.phones[i];
                let h = JOIN_HALF_WIDTH;
                let wp =
                    if i > 0 && t - p.start < h { 0.5 * (1.0 - (t - p.start) / h) } else { 0.0 };
                let wn =
                    if i < last && p.end - t < h { 0.5 * (1.0 - (p.end - t) / h) } else { 0.0 };
                let mut v = value(i, t) * (1.0 - wp - wn);
                if wp > 0.0 {
                    v += value(i - 1, t) * wp;
                }
                if wn > 0.0 {
                    v += value(i + 1, t) * wn;
                }
                v
            })
            .collect())
    }
}

/// A user's synthesized motion for one corpus sentence: per frame the pose-free positions
/// (model space) of `vertices`, which must include every marker (the landmark vertices and
/// the spread face vertices of [`super::MarkerSet`]; whole meshes include them all).
#[derive(Clone, Debug, PartialEq)]
pub struct External {
    /// Model vertex ids; `frames[f][k]` is the position of `vertices[k]`.
    pub vertices: Vec<usize>,
    pub frames: Vec<Vec<Point3>>,
}

impl External {
    /// Motion given as whole meshes: every frame holds every vertex in order.
    pub fn whole_meshes(frames: Vec<Vec<Point3>>) -> Self {
        let n = frames.first().map_or(0, Vec::len);
        Self { vertices: (0..n).collect(), frames }
    }

    /// The marker displacements (from sentence `index`'s neutral shape) of this motion.
    ///
    /// # Errors
    /// `FrameCount` when the frame count differs from the sentence's, `PointCount` when a
    /// frame's point count differs from the vertex list's, `VertexOutOfRange` for a vertex the
    /// model lacks and `MissingVertex` for a marker vertex the motion does not give.
    pub fn marker_motion(
        &self,
        corpus: &Corpus,
        prepared: &Prepared,
        index: usize,
    ) -> Result<Vec<DVector>, SaqpError> {
        let s = &corpus.sentences[index];
        if self.frames.len() != s.frames.len() {
            return Err(SaqpError::FrameCount {
                sentence: s.name.clone(),
                got: self.frames.len(),
                expected: s.frames.len(),
            });
        }
        let n_vertices = corpus.shapes.num_vertices();
        if let Some(&vertex) = self.vertices.iter().find(|&&v| v >= n_vertices) {
            return Err(SaqpError::VertexOutOfRange {
                sentence: s.name.clone(),
                vertex,
                vertices: n_vertices,
            });
        }
        let mut slot = vec![None; n_vertices];
        for (k, &v) in self.vertices.iter().enumerate() {
            slot[v] = Some(k);
        }
        let markers = &prepared.markers;
        let picks: Vec<usize> = markers
            .vertices
            .iter()
            .map(|&v| {
                slot[v].ok_or(SaqpError::MissingVertex { sentence: s.name.clone(), vertex: v })
            })
            .collect::<Result<_, _>>()?;
        let neutral = corpus.shapes.shape(&s.neutral);
        self.frames
            .iter()
            .enumerate()
            .map(|(f, pts)| {
                if pts.len() != self.vertices.len() {
                    return Err(SaqpError::PointCount {
                        sentence: s.name.clone(),
                        frame: f,
                        got: pts.len(),
                        expected: self.vertices.len(),
                    });
                }
                let mut d = DVector::zeros(3 * markers.len());
                for (m, (&v, &k)) in markers.vertices.iter().zip(&picks).enumerate() {
                    for a in 0..3 {
                        d[3 * m + a] = pts[k][a] - neutral[3 * v + a];
                    }
                }
                Ok(d)
            })
            .collect()
    }
}

/// The phone `offset` places from position `j`, if the sentence has one there.
fn neighbour(v: &[u16], j: usize, offset: isize) -> Option<&u16> {
    j.checked_add_signed(offset).and_then(|k| v.get(k))
}
