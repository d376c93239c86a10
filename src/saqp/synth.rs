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
use super::coverage::ContextIndex;
use super::prepared::{Prepared, PreparedSentence};
use super::sampling::{interpolate_keys, midpoint, sample_at, smooth_gaussian};
use super::satf::{SatfParams, fit_trajectory, sequence_stats};
use crate::math::{DVector, Point3};
use serde::{Deserialize, Serialize};

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
/// Recorded occurrences of a phone averaged into its unit. One recording replays its own
/// tracking noise, which no phone sequence predicts; the mean of the three best matches
/// keeps the context's coarticulation and divides that noise's variance by three (on the
/// demo seeds 1–8 the concatenative error's held-out RMSE ratio fell from 0.76 to 0.70;
/// docs/saqp.md).
pub const CONCAT_UNITS: usize = 3;

/// A recorded occurrence the concatenative synthesizer may use for a target phone, and how
/// well it fits there.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct UnitMatch {
    /// Training sentence and phone index of the occurrence.
    pub sentence: usize,
    pub phone: usize,
    /// The occurrence is the target's phone itself (not another of its viseme class).
    pub same_phone: bool,
    /// Agreement of the neighbours ([`ContextIndex::agreement`]).
    pub context: f64,
    /// |ln| of the occurrence's duration over the target's.
    pub timing: f64,
}

impl UnitMatch {
    /// What unit selection maximises: context first, duration on a near tie.
    fn score(&self) -> f64 {
        4.0 * self.context - self.timing
    }
}

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
    /// The prepared sentences of the set, in the index's order.
    members: Vec<usize>,
    index: ContextIndex<'a>,
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
        let index = ContextIndex::new(
            &prepared.phones,
            members.iter().map(|&s| &prepared.sentences[s].ids[..]).collect(),
        );
        Self { prepared, stats, members: members.to_vec(), index }
    }

    /// The set's sentences indexed by their phones.
    pub fn index(&self) -> &ContextIndex<'a> {
        &self.index
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

    /// The `k` best training occurrences for phone `i` of `target`, best first: of the
    /// phone's occurrences (or its viseme class's, [`ContextIndex::candidates`]) those whose
    /// context agrees most, closest in duration on a near tie. Ties left are broken by corpus
    /// order, so the choice does not depend on hashing.
    pub fn best_units(&self, target: &PreparedSentence, i: usize, k: usize) -> Vec<UnitMatch> {
        let phones = &self.prepared.phones;
        let dur = |p: &crate::alignment::Phone| (p.end - p.start).max(1e-3);
        let want = dur(&target.phones[i]);
        let mut scored: Vec<UnitMatch> = self
            .index
            .candidates(phones, target.ids[i])
            .iter()
            .map(|&(s, j)| {
                let c = &self.prepared.sentences[self.members[s]];
                UnitMatch {
                    sentence: self.members[s],
                    phone: j,
                    same_phone: c.ids[j] == target.ids[i],
                    context: self.index.agreement(phones, &target.ids, i, (s, j)),
                    timing: (dur(&c.phones[j]) / want).ln().abs(),
                }
            })
            .collect();
        scored.sort_by(|a, b| {
            b.score().total_cmp(&a.score()).then((a.sentence, a.phone).cmp(&(b.sentence, b.phone)))
        });
        scored.truncate(k);
        scored
    }

    fn concatenate(&self, target: &PreparedSentence) -> Result<Vec<DVector>, SaqpError> {
        sequence_stats(&target.name, &self.stats, &self.prepared.phones, &target.ids)?;
        let global = self
            .stats
            .monophone(&self.prepared.phones, u16::MAX)
            .map(|s| s.mean)
            .ok_or_else(|| SaqpError::AllPhonesUnseen(target.name.clone()))?;
        let segments: Vec<Vec<(usize, usize)>> = (0..target.ids.len())
            .map(|i| {
                let units = self.best_units(target, i, CONCAT_UNITS);
                units.iter().map(|u| (u.sentence, u.phone)).collect()
            })
            .collect();
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
