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

/// The meeting frames of `track` as the contact precision reads them: for each frame whose
/// inner lips meet ([`lips_meet`]), its gap and the limit it was chosen under, both in that
/// frame's pixels.
pub fn meeting_gap_samples(track: &Track) -> Vec<(f64, f64)> {
    let gaps: Vec<Option<f64>> = track.frames.iter().map(inner_lip_gap).collect();
    let meet = meeting(&gaps);
    let widest = gaps.iter().flatten().copied().filter(|g| g.is_finite()).fold(0.0, f64::max);
    track
        .frames
        .iter()
        .zip(&gaps)
        .zip(&meet)
        .filter(|(_, m)| **m)
        .filter_map(|((f, g), _)| {
            let r = reference_length(f)?;
            Some((g.as_ref()? * r, MEET_SHARE * widest * r))
        })
        .collect()
}

/// How precisely a tracker places the inner-lip gap where the lips touch (px per
/// coordinate), from the meeting frames of all the clips it tracked: [`meeting_gap_spread`]
/// of their [`meeting_gap_samples`] pooled. The precision is the tracker's, not a clip's,
/// and a clip has few meeting frames (a demo sentence 7–17): clip by clip the bound is
/// loose or absent (on held-out demo speaker 1, 30 of 40 sentences showed none), pooled it
/// is what the tracker shows (`docs/closure.md`). `None` below three meeting frames or when
/// they show no precision.
pub fn contact_precision<T: std::borrow::Borrow<Track>>(
    tracks: impl IntoIterator<Item = T>,
) -> Option<f64> {
    let samples: Vec<(f64, f64)> =
        tracks.into_iter().flat_map(|t| meeting_gap_samples(t.borrow())).collect();
    if samples.len() < 3 {
        return None;
    }
    meeting_gap_spread(&samples)
}

/// Marks the frames whose inner lips meet ([`lips_meet`]) on a clip whose tracker closes the
/// lips itself: `lip_contact_px` is how precisely this tracker places the gap where the lips
/// touch: `pooled` when the tracker's clips show it ([`contact_precision`]), otherwise
/// [`meeting_gap_spread`] of this clip's own meeting frames. Without `pooled`, fewer than
/// three such frames, or gaps that show no precision of their own, mark nothing. Returns how
/// many frames were marked.
pub fn mark_meeting_lips(track: &mut Track, pooled: Option<f64>) -> usize {
    let meet = lips_meet(track);
    let spread = match pooled {
        Some(p) => p,
        None => {
            let chosen = meeting_gap_samples(track);
            if chosen.len() < 3 {
                return 0;
            }
            let Some(spread) = meeting_gap_spread(&chosen) else {
                return 0;
            };
            spread
        }
    };
    let mut marked = 0;
    for (frame, _) in track.frames.iter_mut().zip(&meet).filter(|(_, m)| **m) {
        frame.lip_contact_px = Some(spread);
        marked += 1;
    }
    marked
}

/// The tracker's per-coordinate spread σ (px) of the inner-lip gap where the lips meet, as
/// far as `chosen` (each meeting frame's gap g and the limit t it was chosen under, px)
/// show it: the largest σ their likelihood allows at 95 % (profile likelihood, χ²₁).
/// Where the lips meet the tracked gap vector is the tracker's error, taken as isotropic
/// Gaussian, so its length follows Rayleigh's law; the frames were picked for a gap at or
/// below t, so the law is truncated there. With θ = 1/(2σ²), s = g² and T = t²:
/// `ℓ(θ) = Σ ln θ − θs − ln(1 − e^{−θT})`, concave in θ, tending to `−Σ ln T` (gaps spread
/// evenly over the disc below their limits: no precision at all) as θ → 0.
///
/// The spread of the chosen gaps themselves (their MAD) is no estimate: frames chosen for a
/// small gap have small gaps whatever the tracker. On the demo's tracker it gave 0.37 px
/// where the gap's error against the true landmarks is 1.03 px per coordinate; the maximum
/// of ℓ gives 1.06 px (`docs/closure.md`). The bound rather than the maximum, because a
/// clip has few meeting frames (the demo's: a median of 9) and a precision the contact is
/// weighed by must be one they show. `None` when no precision is shown (ℓ at θ → 0 within
/// the χ²₁ 95 % margin of its maximum); `Some(0)` when every gap is 0.
pub fn meeting_gap_spread(chosen: &[(f64, f64)]) -> Option<f64> {
    let n = chosen.len() as f64;
    let s_sum: f64 = chosen.iter().map(|(g, _)| g * g).sum();
    if !s_sum.is_finite() || chosen.iter().any(|(_, t)| !(t.is_finite() && *t > 0.0)) {
        return None;
    }
    if s_sum == 0.0 {
        return Some(0.0);
    }
    let log_likelihood = |theta: f64| {
        chosen
            .iter()
            .map(|(g, t)| theta.ln() - theta * g * g - (-(-theta * t * t).exp_m1()).ln())
            .sum::<f64>()
    };
    let slope = |theta: f64| {
        chosen
            .iter()
            .map(|(g, t)| 1.0 / theta - g * g - t * t / (theta * t * t).exp_m1())
            .sum::<f64>()
    };
    // Bisection on ln θ. The slope tends to Σ(T/2 − s) at 0 and is negative at n/Σs (the
    // untruncated estimate); when it is not positive at 0 the maximum is there.
    let bisect = |mut lo: f64, mut hi: f64, rising: &dyn Fn(f64) -> bool| {
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if rising(mid.exp()) {
                lo = mid;
            } else {
                hi = mid;
            }
        }
        0.5 * (lo + hi)
    };
    let half_t_sum: f64 = chosen.iter().map(|(_, t)| 0.5 * t * t).sum();
    if s_sum >= half_t_sum {
        return None;
    }
    let floor = (1e-9 * n / s_sum).ln();
    let best = bisect(floor, (n / s_sum).ln(), &|theta| slope(theta) > 0.0);
    let at_zero = -chosen.iter().map(|(_, t)| 2.0 * t.ln()).sum::<f64>();
    let margin = 0.5 * CHI2_1_95;
    let top = log_likelihood(best.exp());
    if top - at_zero <= margin {
        return None;
    }
    // The bound: the θ below the maximum where ℓ has fallen by the margin.
    let bound = bisect(floor, best, &|theta| top - log_likelihood(theta) > margin);
    Some((0.5 / bound.exp()).sqrt())
}

/// The 95 % point of χ² with one degree of freedom.
const CHI2_1_95: f64 = 3.841_458_820_694_124;

/// `track` as fits take it. Under [`Closure::Seal`]: [`seal_inner_lips`] applied; when the
/// lowest gaps are no separate mode (the tracker closes the lips itself) the frames whose
/// lips meet are marked instead ([`mark_meeting_lips`]); otherwise (too few frames, a gap
/// that never varies; the measures report the last, `workflow::utterance_of_clip`) `track`
/// unchanged. `pooled` is the tracker's contact precision over all its clips
/// ([`contact_precision`]): when given, every contact (sealed or meeting) carries it instead
/// of the clip's own estimate. Under [`Closure::Off`], `track` as tracked.
pub fn with_sealed_lips(mut track: Track, closure: Closure, pooled: Option<f64>) -> Track {
    match seal_inner_lips(&mut track, closure) {
        Ok(Some(_)) => {
            if let Some(p) = pooled {
                for f in track.frames.iter_mut().filter(|f| f.lip_contact_px.is_some()) {
                    f.lip_contact_px = Some(p);
                }
            }
        }
        Err(ClosureError::NoSealedMode(_)) => {
            mark_meeting_lips(&mut track, pooled);
        }
        // Off, or no estimate (too few frames, no spread): the track as it was.
        Ok(None) | Err(_) => {}
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
        let off = with_sealed_lips(track.clone(), Closure::Off, None);
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
        let marked = with_sealed_lips(track.clone(), Closure::Seal, None);
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

    /// `n` gaps of a tracker whose gap vector errs by `sigma` per coordinate (Gaussian),
    /// kept when at most `limit`: what meeting frames look like. Also returns the MAD spread
    /// the estimate replaced.
    fn truncated_gaps(sigma: f64, limit: f64, n: usize, seed: u64) -> (Vec<(f64, f64)>, f64) {
        use rand::{SeedableRng, rngs::StdRng};
        use rand_distr::{Distribution, Normal};
        let mut rng = StdRng::seed_from_u64(seed);
        let normal = Normal::new(0.0, sigma).unwrap();
        let mut chosen = Vec::new();
        while chosen.len() < n {
            let g = f64::hypot(normal.sample(&mut rng), normal.sample(&mut rng));
            if g <= limit {
                chosen.push((g, limit));
            }
        }
        let mut g: Vec<f64> = chosen.iter().map(|c| c.0).collect();
        g.sort_by(f64::total_cmp);
        let centre = median(&g);
        let mut dev: Vec<f64> = g.iter().map(|x| (x - centre).abs()).collect();
        dev.sort_by(f64::total_cmp);
        (chosen, 1.4826 * median(&dev))
    }

    #[test]
    fn the_meeting_gaps_spread_is_the_trackers_own_though_they_were_chosen_small() {
        // A tracker erring 1 px per coordinate, its meeting frames those at most 1.7 px (the
        // demo's median limit): the gaps' own MAD is far below 1; the bound, from 2,000
        // frames, just above 1.
        for seed in 0..5 {
            let (chosen, mad) = truncated_gaps(1.0, 1.7, 2000, seed);
            let sigma = meeting_gap_spread(&chosen).unwrap();
            assert!((0.95..1.2).contains(&sigma), "seed {seed}: {sigma}");
            assert!(mad < 0.6, "seed {seed}: MAD {mad}");
        }
        // Nine such frames (a demo clip's) show no precision at all more often than not
        // (12 of these 20 draws).
        let shown = (0..20)
            .filter(|&seed| meeting_gap_spread(&truncated_gaps(1.0, 1.7, 9, seed).0).is_some())
            .count();
        assert!(shown < 10, "{shown} of 20");
        // A tracker that closes the lips to 0.2 px, far inside its limit: 0.2 again.
        let (chosen, _) = truncated_gaps(0.2, 3.0, 200, 7);
        let sigma = meeting_gap_spread(&chosen).unwrap();
        assert!((0.2..0.25).contains(&sigma), "{sigma}");
        // Gaps crowding towards their limit (more there than uniform over the disc's area,
        // which is where the likelihood's slope at σ → ∞ turns): no precision of their own.
        let disc: Vec<(f64, f64)> =
            (0..50).map(|i| (2.0 * ((i as f64 + 0.5) / 50.0).powf(0.25), 2.0)).collect();
        assert_eq!(meeting_gap_spread(&disc), None);
        assert_eq!(meeting_gap_spread(&[(0.0, 1.0), (0.0, 2.0), (0.0, 1.0)]), Some(0.0));
    }

    /// A clip of a tracker erring `sigma` px per coordinate on the gap: 9 frames whose lips
    /// meet (gaps drawn as [`truncated_gaps`] under 1.7 px) and 31 open ones spread evenly
    /// up to 34 px, so that 1.7 px is 5 % of its widest gap and no sealed mode stands apart.
    fn clip_meeting_nine_times(sigma: f64, seed: u64) -> Track {
        let (meet, _) = truncated_gaps(sigma, 1.7, 9, seed);
        let open = (0..31).map(|k| 3.0 + k as f64 * 31.0 / 30.0);
        let gaps = meet.iter().map(|m| m.0).chain(open);
        Track::new(gaps.enumerate().map(|(f, g)| frame(f, g)).collect())
    }

    #[test]
    fn clips_too_short_to_show_the_trackers_contact_precision_show_it_pooled() {
        let clips: Vec<Track> = (0..40).map(|seed| clip_meeting_nine_times(1.0, seed)).collect();
        let own: Vec<Option<f64>> =
            clips.iter().map(|t| meeting_gap_spread(&meeting_gap_samples(t))).collect();
        let silent = own.iter().filter(|o| o.is_none()).count();
        assert!(silent >= 10, "{silent} of 40 clips show no precision of their own: {own:?}");
        let pooled = contact_precision(&clips).unwrap();
        assert!((0.95..1.3).contains(&pooled), "{pooled}");
        // Every meeting frame carries the pooled precision, in the clips that show none too;
        // the open frames carry none.
        for (t, own) in clips.iter().zip(&own) {
            let fitted = with_sealed_lips(t.clone(), Closure::Seal, Some(pooled));
            let marked: Vec<usize> = fitted
                .frames
                .iter()
                .filter(|f| f.lip_contact_px == Some(pooled))
                .map(|f| f.frame)
                .collect();
            assert_eq!(marked, (0..9).collect::<Vec<_>>(), "own {own:?}");
            let alone = with_sealed_lips(t.clone(), Closure::Seal, None);
            let marked_alone = alone.frames.iter().filter(|f| f.lip_contact_px.is_some()).count();
            assert_eq!(marked_alone, if own.is_some() { 9 } else { 0 });
            assert_eq!(with_sealed_lips(t.clone(), Closure::Off, Some(pooled)), *t);
        }
        // A clip with a sealed mode of its own: its sealed frames carry the pooled precision.
        let sealed = Track::new(
            gaps().iter().enumerate().map(|(f, g)| frame(f, 10.0 * g.unwrap())).collect(),
        );
        let fitted = with_sealed_lips(sealed, Closure::Seal, Some(pooled));
        let carried: Vec<Option<f64>> =
            fitted.frames.iter().filter_map(|f| f.lip_contact_px.map(Some)).collect();
        assert_eq!(carried, vec![Some(pooled); 30]);
        assert_eq!(contact_precision(&clips[..0]), None);
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
