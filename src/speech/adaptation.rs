//! A speaker's visual parameters from the model's: what is left of another face after the
//! geometric normalisation ([`super::speaker`]), taken out with the speaker's own statistics.
//!
//! The visual parameters are PCA components of mouth motion, ordered by their variance: on the
//! demo the first two (jaw, spread/round) vary 15 times more than the last two. Carried from
//! another face, each speaker's motion keeps a small error of the local maps and of the fits
//! on that face — a few per cent of the jaw's motion lands on the small components, where it
//! is as large as what they carry (on a demo speaker of other proportions, 4 % of the first
//! component in the third: its correlation with the truth fell from 0.8 to 0.5).
//!
//! The correction: the speaker's parameters `f` are taken to be the reference speaker's `f°`
//! under a linear map about the rest pose (no motion stays no motion),
//! `f − r = A (f° − r)`, with `A` lower triangular: each component made of itself and the
//! larger ones before it, the direction in which leakage matters. The statistics fix it: the
//! speaker's covariance `C` must be `A C° Aᵀ`, `C°` the training speakers', so
//! `A = L L°⁻¹` with `L`, `L°` their Cholesky factors (the unique lower-triangular map with a
//! positive diagonal that carries `C°` onto `C`). For the training speaker `A` is the identity
//! up to sampling noise.
//!
//! `C` comes from the speaker's fitted video (the visual truth of clips), never from audio,
//! and is shrunk towards `C°` by a prior worth [`PRIOR_FRAMES_S`] of speech, so a speaker seen
//! for a few seconds is barely moved. Scoring a clip uses the speaker's other clips only
//! ([`leave_one_out`]), so no clip's own truth shapes its estimate.

use super::error::{SpeechError, bad};
use crate::math::{DMatrix, DVector};

/// Seconds of speech the reference covariance is worth against a speaker's own (the prior's
/// weight in [`SpeakerAdaptation::new`]): a speaker's few sentences are a weak guide to a
/// small component's covariance, a few dozen a good one.
pub const PRIOR_FRAMES_S: f64 = 10.0;

/// Sums over frames of visual parameters and their outer products, to be combined and taken
/// apart clip by clip.
#[derive(Clone, Debug, PartialEq)]
pub struct VisualMoments {
    frames: f64,
    sum: DVector,
    outer: DMatrix,
}

impl VisualMoments {
    /// No frames, `k` parameters.
    pub fn zeros(k: usize) -> Self {
        Self { frames: 0.0, sum: DVector::zeros(k), outer: DMatrix::zeros(k, k) }
    }

    /// The moments of `features` (T × K).
    pub fn of(features: &DMatrix) -> Self {
        let sum = features.row_sum().transpose();
        Self { frames: features.nrows() as f64, sum, outer: features.tr_mul(features) }
    }

    /// Frames counted.
    pub fn frames(&self) -> f64 {
        self.frames
    }

    /// These frames and `other`'s.
    pub fn plus(&self, other: &Self) -> Self {
        Self {
            frames: self.frames + other.frames,
            sum: &self.sum + &other.sum,
            outer: &self.outer + &other.outer,
        }
    }

    /// These frames without `other`'s (a part of them).
    pub fn minus(&self, other: &Self) -> Self {
        Self {
            frames: self.frames - other.frames,
            sum: &self.sum - &other.sum,
            outer: &self.outer - &other.outer,
        }
    }

    /// The covariance (K × K) of the frames; `None` with fewer than 2.
    pub fn covariance(&self) -> Option<DMatrix> {
        if self.frames < 2.0 {
            return None;
        }
        let mean = &self.sum / self.frames;
        Some(&self.outer / self.frames - &mean * mean.transpose())
    }
}

/// The map from the reference speaker's visual parameters to one speaker's (module doc).
#[derive(Clone, Debug, PartialEq)]
pub struct SpeakerAdaptation {
    /// `A`, K × K lower triangular.
    map: DMatrix,
}

impl SpeakerAdaptation {
    /// No change, for `k` parameters.
    pub fn identity(k: usize) -> Self {
        Self { map: DMatrix::identity(k, k) }
    }

    /// The map for a speaker whose frames have `speaker`'s moments, the training speakers'
    /// covariance being `reference`; the speaker's covariance shrunk towards it by
    /// `prior_frames` frames.
    ///
    /// # Errors
    /// Sizes that differ; a reference that is not positive definite; a shrunk covariance that
    /// is not (the speaker's moments were not a covariance).
    pub fn new(
        reference: &DMatrix,
        speaker: &VisualMoments,
        prior_frames: f64,
    ) -> Result<Self, SpeechError> {
        let k = reference.nrows();
        if reference.ncols() != k || speaker.sum.len() != k {
            return Err(SpeechError::DimensionMismatch {
                what: "visual parameters of the speaker's statistics",
                expected: k,
                got: speaker.sum.len(),
            });
        }
        if !(prior_frames.is_finite() && prior_frames > 0.0) {
            return Err(bad("prior frames", prior_frames.to_string()));
        }
        let l_ref = reference
            .clone()
            .cholesky()
            .ok_or_else(|| SpeechError::Degenerate("reference visual covariance".into()))?
            .unpack();
        let shrunk = match speaker.covariance() {
            Some(c) => {
                (c * speaker.frames + reference * prior_frames) / (speaker.frames + prior_frames)
            }
            None => return Ok(Self::identity(k)),
        };
        let l = shrunk
            .cholesky()
            .ok_or_else(|| SpeechError::Degenerate("speaker's visual covariance".into()))?
            .unpack();
        let inverse = l_ref
            .solve_lower_triangular(&DMatrix::identity(k, k))
            .ok_or_else(|| SpeechError::Degenerate("reference visual covariance".into()))?;
        Ok(Self { map: l * inverse })
    }

    /// The matrix `A`.
    pub fn matrix(&self) -> &DMatrix {
        &self.map
    }

    /// `estimate` (T × K, the reference speaker's parameters) as this speaker's:
    /// `rest + A (f − rest)` per frame.
    ///
    /// # Errors
    /// An estimate or rest pose of another width.
    pub fn apply(&self, estimate: &DMatrix, rest: &[f64]) -> Result<DMatrix, SpeechError> {
        let k = self.map.nrows();
        if estimate.ncols() != k || rest.len() != k {
            return Err(SpeechError::DimensionMismatch {
                what: "visual parameters to adapt",
                expected: k,
                got: estimate.ncols(),
            });
        }
        let rest = DVector::from_column_slice(rest);
        let mut out = estimate.clone();
        for mut row in out.row_iter_mut() {
            let moved = &self.map * (row.transpose() - &rest) + &rest;
            row.copy_from(&moved.transpose());
        }
        Ok(out)
    }
}

/// For each clip of one speaker, the adaptation from the visual truth of the speaker's other
/// clips (`truths`, one T × K matrix per clip), with the prior worth `prior_frames` frames.
///
/// # Errors
/// As [`SpeakerAdaptation::new`].
pub fn leave_one_out(
    reference: &DMatrix,
    truths: &[DMatrix],
    prior_frames: f64,
) -> Result<Vec<SpeakerAdaptation>, SpeechError> {
    let k = reference.nrows();
    let each: Vec<VisualMoments> = truths.iter().map(VisualMoments::of).collect();
    let all = each.iter().fold(VisualMoments::zeros(k), |a, m| a.plus(m));
    each.iter().map(|m| SpeakerAdaptation::new(reference, &all.minus(m), prior_frames)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Frames of K = 3 uncorrelated parameters of standard deviations 10, 1, 0.5 (a fixed
    /// pseudo-random stream).
    fn reference_frames(n: usize) -> DMatrix {
        let mut state = 42u64;
        let mut draw = || {
            // Sum of 12 uniforms minus 6: near enough normal for a covariance test.
            (0..12)
                .map(|_| {
                    state = state.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1);
                    (state >> 11) as f64 / (1u64 << 53) as f64
                })
                .sum::<f64>()
                - 6.0
        };
        DMatrix::from_fn(n, 3, |_, k| [10.0, 1.0, 0.5][k] * draw())
    }

    #[test]
    fn leakage_from_a_large_component_into_a_small_one_is_undone() {
        let rest = [2.0, -1.0, 0.5];
        let reference = reference_frames(20_000);
        let c_ref = VisualMoments::of(&reference).covariance().unwrap();
        // The speaker: 5 % of the first component leaks into the third, the second is 20 %
        // larger, all about the rest pose.
        let leak = DMatrix::from_row_slice(3, 3, &[1.0, 0.0, 0.0, 0.0, 1.2, 0.0, 0.05, 0.0, 1.0]);
        let r = DVector::from_column_slice(&rest);
        let apply = |m: &DMatrix, a: &DMatrix| {
            let mut out = m.clone();
            for mut row in out.row_iter_mut() {
                let v = a * (row.transpose() - &r) + &r;
                row.copy_from(&v.transpose());
            }
            out
        };
        let speaker = apply(&reference_frames(20_000), &leak);
        let a = SpeakerAdaptation::new(&c_ref, &VisualMoments::of(&speaker), 1.0).unwrap();
        assert!((a.matrix() - &leak).abs().max() < 0.03, "{}", a.matrix());
        // A reference estimate carried over matches the speaker's frames.
        let estimate = reference.rows(0, 100).into_owned();
        let adapted = a.apply(&estimate, &rest).unwrap();
        let want = apply(&estimate, &leak);
        assert!((adapted - want).abs().max() < 0.03 * 10.0);
        // The reference speaker maps onto itself; no frames leave the estimate alone.
        let same = SpeakerAdaptation::new(&c_ref, &VisualMoments::of(&reference), 1.0).unwrap();
        assert!((same.matrix() - DMatrix::identity(3, 3)).abs().max() < 1e-9);
        let none = SpeakerAdaptation::new(&c_ref, &VisualMoments::zeros(3), 1.0).unwrap();
        assert_eq!(none, SpeakerAdaptation::identity(3));
    }

    #[test]
    fn the_prior_holds_a_speaker_seen_briefly_near_the_reference() {
        let reference = reference_frames(5_000);
        let c_ref = VisualMoments::of(&reference).covariance().unwrap();
        let doubled = reference.rows(0, 50).map(|v| 2.0 * v);
        let brief = SpeakerAdaptation::new(&c_ref, &VisualMoments::of(&doubled), 500.0).unwrap();
        let long = SpeakerAdaptation::new(&c_ref, &VisualMoments::of(&doubled), 5.0).unwrap();
        assert!(brief.matrix()[(0, 0)] < 1.2, "{}", brief.matrix());
        assert!(long.matrix()[(0, 0)] > 1.6, "{}", long.matrix());
    }

    #[test]
    fn leave_one_out_uses_the_other_clips_only() {
        let frames = reference_frames(3_000);
        let c_ref = VisualMoments::of(&frames).covariance().unwrap();
        let clips: Vec<DMatrix> =
            (0..3).map(|i| frames.rows(1_000 * i, 1_000).into_owned()).collect();
        let maps = leave_one_out(&c_ref, &clips, 10.0).unwrap();
        let others = stack(&[clips[1].clone(), clips[2].clone()]);
        let direct = SpeakerAdaptation::new(&c_ref, &VisualMoments::of(&others), 10.0).unwrap();
        assert!((maps[0].matrix() - direct.matrix()).abs().max() < 1e-9);
        assert!(
            SpeakerAdaptation::new(&DMatrix::zeros(3, 3), &VisualMoments::of(&frames), 1.0)
                .is_err()
        );
        assert!(maps[0].apply(&DMatrix::zeros(2, 2), &[0.0; 3]).is_err());
    }

    fn stack(blocks: &[DMatrix]) -> DMatrix {
        crate::speech::stack_rows(blocks)
    }
}
