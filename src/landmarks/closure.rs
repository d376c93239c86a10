//! Sealed lips on a tracker that never closes them. A tracker such as dlib leaves a small
//! gap between sealed inner lips, so a fit to its points keeps the fitted lips apart and
//! closures (/p b m/) never reach H = 0. Here the clip's own distribution of the tracked
//! inner-lip gap is split in two clusters, the lower one is taken as the tracker's "sealed"
//! mode, and on frames inside it the inner lips are moved together (each upper/lower pair
//! to its midpoint) before fitting and measuring: the video then reads H = 0 and the fit is
//! asked to close the head's lips, so whether it can is measured rather than assumed.
//! Why this and not a closure term in the fit or a snap of the measures: `docs/closure.md`.
//! Start at [`seal_inner_lips`].

use super::ibug::point::{LEFT_ENDOCANTHION, NOSE_TIP, RIGHT_ENDOCANTHION};
use super::{FrameLandmarks, Track};
use serde::{Deserialize, Serialize};

/// How sealed lips are treated (a fit setting: it changes the landmarks a fit sees).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Closure {
    /// The inner lips as tracked.
    Off,
    /// The inner lips meet on frames whose tracked gap lies in the clip's sealed mode.
    #[default]
    Seal,
}

impl Closure {
    pub fn is_default(&self) -> bool {
        *self == Self::default()
    }

    pub fn as_str(self) -> &'static str {
        match self {
            Self::Off => "off",
            Self::Seal => "seal",
        }
    }
}

/// Why no sealed mode can be estimated.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ClosureError {
    #[error("{0} frames with an inner-lip gap; at least {MIN_FRAMES} are needed")]
    TooFewFrames(usize),
    #[error("the inner-lip gap does not vary over the clip")]
    NoSpread,
    /// The lowest gaps are not a cluster of their own: the tracker closes the lips itself,
    /// or the lips never close; either way there is nothing to correct.
    #[error("no sealed mode: the lowest gaps are not a separate cluster (separation {0:.1})")]
    NoSealedMode(f64),
}

/// Fewest measured frames a sealed mode is estimated from.
pub const MIN_FRAMES: usize = 10;

/// Robust sigmas above the sealed mode's median that still count as sealed.
pub const SEALED_SIGMAS: f64 = 1.0;

/// Least distance from the sealed mode's median to the split, in the mode's robust sigmas,
/// for the lower cluster to count as a mode of its own. Carphone's sealed mode is 6.4 σ
/// from its split; a short sentence from a tracker that does close the lips has lower
/// clusters that run into its half-open frames (≈ 1 σ).
pub const MIN_SEPARATION: f64 = 3.0;

/// Inner-lip pairs (upper, lower), 0-based iBUG ids, that meet when the lips seal; the
/// corners 60 and 64 are shared by both lips and stay where they are.
pub const INNER_LIP_PAIRS: [(usize, usize); 3] = [(61, 67), (62, 66), (63, 65)];

/// The clip's sealed mode of the tracked inner-lip gap (in units of the reference length).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ClosedLips {
    /// Median gap of the lower cluster.
    pub mode: f64,
    /// Its robust spread, 1.4826·MAD.
    pub spread: f64,
    /// Otsu's split between the two clusters.
    pub split: f64,
    /// Gaps at or below this are sealed: `min(split, mode + SEALED_SIGMAS·spread)`.
    pub threshold: f64,
    /// How many frames were sealed.
    pub sealed: usize,
}

/// The inner-lip gap |p62 − p66| over the reference length |mid(p39, p42) − p30|, the
/// video's H of `measure::mouth` (`None` when one of those points is not visible or the
/// reference is degenerate). Divided by a length articulation does not change so that a
/// head moving towards the camera does not shift frames between the clusters.
pub fn inner_lip_gap(frame: &FrameLandmarks) -> Option<f64> {
    let (upper, lower) = INNER_LIP_PAIRS[1];
    let p = |i: usize| frame.points.get(i).filter(|p| p.visible).map(|p| p.pos());
    let gap = (p(upper)? - p(lower)?).norm() / reference_length(frame)?;
    gap.is_finite().then_some(gap)
}

/// The reference length |mid(p39, p42) − p30| (px) the gap is divided by; `None` when a
/// point is hidden or the length degenerate.
fn reference_length(frame: &FrameLandmarks) -> Option<f64> {
    let p = |i: usize| frame.points.get(i).filter(|p| p.visible).map(|p| p.pos());
    let r =
        (nalgebra::center(&p(RIGHT_ENDOCANTHION)?, &p(LEFT_ENDOCANTHION)?) - p(NOSE_TIP)?).norm();
    (r > 1e-9 && r.is_finite()).then_some(r)
}

fn median(v: &[f64]) -> f64 {
    let n = v.len();
    if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) }
}

/// The sealed mode of `gaps` (one per frame; `None` and non-finite values skipped). The two
/// clusters come from Otsu's threshold (Otsu 1979, "A threshold selection method from
/// gray-level histograms", eq. 18: the split maximising the between-class variance
/// ω₀ω₁(μ₀ − μ₁)²), here over the sorted values rather than a histogram. The threshold is
/// capped at the lower cluster's median + `SEALED_SIGMAS` robust sigmas, so that a clip that
/// is mostly half-open does not count its half-open frames as sealed.
///
/// # Errors
/// Fewer than [`MIN_FRAMES`] values; all values equal; a lower cluster closer than
/// [`MIN_SEPARATION`] robust sigmas to the split.
pub fn estimate_closed_lips(gaps: &[Option<f64>]) -> Result<ClosedLips, ClosureError> {
    let mut v: Vec<f64> = gaps.iter().flatten().copied().filter(|g| g.is_finite()).collect();
    if v.len() < MIN_FRAMES {
        return Err(ClosureError::TooFewFrames(v.len()));
    }
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len() as f64;
    if v[v.len() - 1] - v[0] <= 1e-12 {
        return Err(ClosureError::NoSpread);
    }
    let total: f64 = v.iter().sum();
    let (mut best, mut best_k, mut below) = (f64::NEG_INFINITY, 1, 0.0);
    for k in 1..v.len() {
        below += v[k - 1];
        if v[k] == v[k - 1] {
            continue;
        }
        let (w0, w1) = (k as f64 / n, 1.0 - k as f64 / n);
        let (m0, m1) = (below / k as f64, (total - below) / (n - k as f64));
        let between = w0 * w1 * (m0 - m1).powi(2);
        if between > best {
            (best, best_k) = (between, k);
        }
    }
    let low = &v[..best_k];
    let mode = median(low);
    let mut dev: Vec<f64> = low.iter().map(|g| (g - mode).abs()).collect();
    dev.sort_by(|a, b| a.total_cmp(b));
    let spread = 1.4826 * median(&dev);
    let split = 0.5 * (v[best_k - 1] + v[best_k]);
    if spread > 0.0 && (split - mode) < MIN_SEPARATION * spread {
        return Err(ClosureError::NoSealedMode((split - mode) / spread));
    }
    let threshold = split.min(mode + SEALED_SIGMAS * spread);
    let sealed = v.iter().filter(|&&g| g <= threshold).count();
    Ok(ClosedLips { mode, spread, split, threshold, sealed })
}

/// Moves each inner-lip pair of `frame` to its midpoint (pairs with a hidden point are left).
pub fn close_inner_lips(frame: &mut FrameLandmarks) {
    for (upper, lower) in INNER_LIP_PAIRS {
        let (Some(&a), Some(&b)) = (frame.points.get(upper), frame.points.get(lower)) else {
            continue;
        };
        if !(a.visible && b.visible) {
            continue;
        }
        let mid = nalgebra::center(&a.pos(), &b.pos());
        for i in [upper, lower] {
            frame.points[i].x = mid.x;
            frame.points[i].y = mid.y;
        }
    }
}

/// Applies `closure` to `track`: under [`Closure::Seal`] the frames in the clip's sealed mode
/// get their inner lips closed and are marked as meeting (`lip_contact_px`: the sealed mode's
/// spread in pixels, how precisely the tracker places the gap where the lips touch, which
/// the fit weighs the closed gap by). Returns the estimate used (`None` under
/// [`Closure::Off`]).
///
/// # Errors
/// As [`estimate_closed_lips`]; the track is then left as it was.
pub fn seal_inner_lips(
    track: &mut Track,
    closure: Closure,
) -> Result<Option<ClosedLips>, ClosureError> {
    if closure == Closure::Off {
        return Ok(None);
    }
    let gaps: Vec<Option<f64>> = track.frames.iter().map(inner_lip_gap).collect();
    let closed = estimate_closed_lips(&gaps)?;
    for (frame, gap) in track.frames.iter_mut().zip(&gaps) {
        if gap.is_some_and(|g| g <= closed.threshold) {
            close_inner_lips(frame);
            frame.lip_contact_px = reference_length(frame).map(|r| closed.spread * r);
        }
    }
    Ok(Some(closed))
}

/// Share of the clip's widest tracked inner-lip gap at or below which the video's inner lips
/// count as meeting when the tracker closes them itself (no separate sealed mode): a gap a
/// twentieth of the widest opening is closed in the measure's own terms.
pub const MEET_SHARE: f64 = 0.05;

/// Which of a clip's inner-lip gaps (one per frame, in any unit: the video's H, pixels) are
/// lips that meet: at or below [`MEET_SHARE`] of the clip's widest. All `false` when no
/// frame has a gap or the widest is 0.
pub fn meeting(gaps: &[Option<f64>]) -> Vec<bool> {
    let widest = gaps.iter().flatten().copied().filter(|g| g.is_finite()).fold(0.0, f64::max);
    gaps.iter().map(|g| widest > 0.0 && g.is_some_and(|g| g <= MEET_SHARE * widest)).collect()
}

/// Frames of `track` whose inner lips meet ([`meeting`] of their [`inner_lip_gap`]s; after
/// [`seal_inner_lips`] the sealed frames' gap is 0).
pub fn lips_meet(track: &Track) -> Vec<bool> {
    meeting(&track.frames.iter().map(inner_lip_gap).collect::<Vec<_>>())
}

/// Marks the frames whose inner lips meet ([`lips_meet`]) on a clip whose tracker closes the
/// lips itself: `lip_contact_px` is the robust spread (1.4826·MAD, px) of those frames' gaps,
/// how precisely this tracker places a gap where the lips touch. Fewer than three such
/// frames give no spread and nothing is marked. Returns how many frames were marked.
pub fn mark_meeting_lips(track: &mut Track) -> usize {
    let meet = lips_meet(track);
    let gap_px = |f: &FrameLandmarks| Some(inner_lip_gap(f)? * reference_length(f)?);
    let mut gaps: Vec<f64> = track
        .frames
        .iter()
        .zip(&meet)
        .filter(|(_, m)| **m)
        .filter_map(|(f, _)| gap_px(f))
        .collect();
    if gaps.len() < 3 {
        return 0;
    }
    gaps.sort_by(f64::total_cmp);
    let centre = median(&gaps);
    let mut dev: Vec<f64> = gaps.iter().map(|g| (g - centre).abs()).collect();
    dev.sort_by(f64::total_cmp);
    let spread = 1.4826 * median(&dev);
    for (frame, _) in track.frames.iter_mut().zip(&meet).filter(|(_, m)| **m) {
        frame.lip_contact_px = Some(spread);
    }
    gaps.len()
}

/// `track` as fits take it. Under [`Closure::Seal`]: [`seal_inner_lips`] applied; when the
/// lowest gaps are no separate mode (the tracker closes the lips itself) the frames whose
/// lips meet are marked instead ([`mark_meeting_lips`]); otherwise (too few frames, a gap
/// that never varies; the measures report the last, `workflow::utterance_of_clip`) `track`
/// unchanged. Under [`Closure::Off`], `track` as tracked.
pub fn with_sealed_lips(mut track: Track, closure: Closure) -> Track {
    // On error the track is left as it was.
    if let Err(ClosureError::NoSealedMode(_)) = seal_inner_lips(&mut track, closure) {
        mark_meeting_lips(&mut track);
    }
    track
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::landmarks::LandmarkPoint;

    /// Sealed frames at 0.05 ± 0.01, open frames from 0.3 to 0.6.
    fn gaps() -> Vec<Option<f64>> {
        (0..40)
            .map(|f| {
                Some(if f % 4 == 0 {
                    0.3 + 0.3 * (f as f64 / 40.0)
                } else {
                    0.05 + 0.005 * (f % 3) as f64
                })
            })
            .collect()
    }

    /// A frame whose reference length is 10 px and whose inner lips are `gap` px apart.
    fn frame(f: usize, gap: f64) -> FrameLandmarks {
        let mut pts = vec![LandmarkPoint::tracked(0.0, 0.0); 68];
        pts[39] = LandmarkPoint::tracked(-5.0, 0.0);
        pts[42] = LandmarkPoint::tracked(5.0, 0.0);
        pts[30] = LandmarkPoint::tracked(0.0, 10.0);
        for (k, (u, l)) in INNER_LIP_PAIRS.into_iter().enumerate() {
            let x = k as f64 - 1.0;
            pts[u] = LandmarkPoint::tracked(x, 20.0);
            pts[l] = LandmarkPoint::tracked(x, 20.0 + gap);
        }
        FrameLandmarks::new(f, pts)
    }

    #[test]
    fn the_lower_cluster_is_the_sealed_mode() {
        let c = estimate_closed_lips(&gaps()).unwrap();
        assert!((c.mode - 0.055).abs() < 1e-9, "{c:?}");
        assert!(c.split > 0.06 && c.split < 0.3, "{c:?}");
        assert!(c.threshold >= 0.06 && c.threshold < 0.3, "{c:?}");
        assert_eq!(c.sealed, 30);
    }

    #[test]
    fn sealing_closes_the_sealed_frames_only() {
        let mut track = Track::new(
            gaps().iter().enumerate().map(|(f, g)| frame(f, 10.0 * g.unwrap())).collect(),
        );
        let before = track.clone();
        assert_eq!(inner_lip_gap(&track.frames[1]).map(|g| (g * 1e6).round()), Some(55_000.0));
        let c = seal_inner_lips(&mut track, Closure::Seal).unwrap().unwrap();
        assert_eq!(c.sealed, 30);
        assert_eq!(inner_lip_gap(&track.frames[1]), Some(0.0));
        assert!((track.frames[1].points[62].y - 20.275).abs() < 1e-12);
        assert_eq!(track.frames[0], before.frames[0], "an open frame is untouched");
        let mut off = before.clone();
        assert_eq!(seal_inner_lips(&mut off, Closure::Off), Ok(None));
        assert_eq!(off, before);
    }

    #[test]
    fn sealed_frames_carry_the_sealed_modes_spread_as_their_contact_precision() {
        let mut track = Track::new(
            gaps().iter().enumerate().map(|(f, g)| frame(f, 10.0 * g.unwrap())).collect(),
        );
        let c = seal_inner_lips(&mut track, Closure::Seal).unwrap().unwrap();
        // Reference length 10 px (see `frame`): the spread in pixels is ten times its value.
        for f in &track.frames {
            match f.lip_contact_px {
                Some(sd) => assert!((sd - 10.0 * c.spread).abs() < 1e-9 && f.frame % 4 != 0),
                None => assert_eq!(f.frame % 4, 0, "an open frame is not a contact"),
            }
        }
        let off = with_sealed_lips(track.clone(), Closure::Off);
        assert_eq!(off, track, "off leaves the track as given");
    }

    #[test]
    fn a_tracker_that_closes_the_lips_itself_has_its_meeting_frames_marked() {
        // Gaps spread evenly (no separate sealed mode), four frames at or near 0.
        let gaps: Vec<f64> =
            (0..40).map(|f| if f < 4 { 0.01 * f as f64 } else { 0.1 * f as f64 }).collect();
        let track = Track::new(gaps.iter().enumerate().map(|(f, g)| frame(f, 10.0 * g)).collect());
        assert!(matches!(
            estimate_closed_lips(&gaps.iter().map(|g| Some(*g)).collect::<Vec<_>>()),
            Err(ClosureError::NoSealedMode(_))
        ));
        let marked = with_sealed_lips(track.clone(), Closure::Seal);
        // 5 % of the widest gap (3.9) is 0.195: frames 0–3 (and 0.0 … 0.03 ≤ it), nothing else.
        let meet: Vec<usize> =
            marked.frames.iter().filter(|f| f.lip_contact_px.is_some()).map(|f| f.frame).collect();
        assert_eq!(meet, vec![0, 1, 2, 3]);
        for (a, b) in marked.frames.iter().zip(&track.frames) {
            assert_eq!(a.points, b.points, "the points are left as tracked");
        }
        assert_eq!(
            meeting(&[Some(0.0), None, Some(1.0), Some(0.06)]),
            vec![true, false, false, false]
        );
        assert_eq!(meeting(&[None, Some(0.0)]), vec![false, false]);
    }

    #[test]
    fn a_hidden_lip_point_leaves_its_pair_alone() {
        let mut f = frame(0, 1.0);
        f.points[61].visible = false;
        close_inner_lips(&mut f);
        assert_eq!((f.points[61].y, f.points[67].y), (20.0, 21.0));
        assert_eq!((f.points[62].y, f.points[66].y), (20.5, 20.5));
        assert_eq!(inner_lip_gap(&f), Some(0.0));
    }

    #[test]
    fn degenerate_input_is_an_error() {
        assert_eq!(estimate_closed_lips(&[Some(0.1); 3]), Err(ClosureError::TooFewFrames(3)));
        assert_eq!(estimate_closed_lips(&[Some(0.1); 20]), Err(ClosureError::NoSpread));
        // Evenly spread gaps: no separate lower cluster.
        let even: Vec<Option<f64>> = (0..40).map(|f| Some(0.01 * f as f64)).collect();
        assert!(matches!(estimate_closed_lips(&even), Err(ClosureError::NoSealedMode(_))));
        let mut track = Track::new((0..5).map(|f| frame(f, f as f64)).collect());
        let before = track.clone();
        assert!(seal_inner_lips(&mut track, Closure::Seal).is_err());
        assert_eq!(track, before);
    }
}
