//! What a tracker says of its own frames: the failure it reports, a low confidence, and — for
//! landmarks made by lipmap's own tracker — its self-check. That tracker re-runs its
//! cascade from the box of each frame's result (`track::tracker`); on a face it has locked
//! onto the two runs land together, and where they part (the start was off: a fast move, a
//! cut, an occlusion, texture taken for a face) the frame is suspect. The parting is kept on
//! the frame (`FrameLandmarks::rerun_disagreement`, in eye-corner distances) and flagged here
//! as its own reason, [`FlagReason::TrackerRerun`], in place of the confidence derived from
//! it. Start at [`tracker_flags`].
//!
//! The self-check flags a frame on its own word only when the parting is clearly
//! significant: above `max_rerun_disagreement` **and** above the clip's own spread of it
//! (median + `rerun_sigmas` robust σ, the rule the jump and shape checks follow). A parting
//! above the floor but within the clip's spread is a doubt, not evidence: it is added as a
//! reason to a frame other checks flag ([`tracker_doubts`]), and flags no frame by itself.
//!
//! A frame whose every point has since been placed again (by hand, by a re-alignment to
//! corrected points, by tracking from a face box the user drew) no longer carries what the
//! tracker said of it: none of these reasons is given for it.

use super::flags::{FlagReason, FlagThresholds, median_sigma};
use super::track::{FrameLandmarks, PointSource, Track};

/// Whether some visible point of the frame is still the tracker's own.
fn has_tracker_points(f: &FrameLandmarks) -> bool {
    f.points.iter().any(|p| p.source == PointSource::Tracked && (p.visible || !f.success))
}

/// The self-check's partings of the frames whose points are still the tracker's own.
fn rerun_disagreements(track: &Track) -> impl Iterator<Item = (usize, f64)> + '_ {
    track
        .frames
        .iter()
        .filter(|f| has_tracker_points(f))
        .filter_map(|f| f.rerun_disagreement.map(|d| (f.frame, f64::from(d))))
}

/// The parting (eye distances) above which lipmap's tracker's self-check flags a frame by
/// itself: `max_rerun_disagreement`, or the clip's median + `rerun_sigmas` robust σ of the
/// partings when higher.
pub fn rerun_limit(track: &Track, th: &FlagThresholds) -> f64 {
    let d: Vec<f64> = rerun_disagreements(track).map(|(_, d)| d).collect();
    median_sigma(&d)
        .map_or(th.max_rerun_disagreement, |(m, s)| m + th.rerun_sigmas * s)
        .max(th.max_rerun_disagreement)
}

/// The self-check's doubts: frames whose parting is above `max_rerun_disagreement` but not
/// above [`rerun_limit`], as reasons to add to frames that other checks flag (they flag no
/// frame by themselves).
pub fn tracker_doubts(track: &Track, th: &FlagThresholds) -> Vec<(usize, FlagReason)> {
    let limit = rerun_limit(track, th);
    rerun_disagreements(track)
        .filter(|(_, d)| *d > th.max_rerun_disagreement && *d <= limit)
        .map(|(frame, disagreement)| (frame, FlagReason::TrackerRerun { disagreement }))
        .collect()
}

/// Tracker failure, low frame or point confidence, and lipmap's tracker disagreeing with
/// its own re-run by more than [`rerun_limit`].
pub fn tracker_flags(track: &Track, th: &FlagThresholds) -> Vec<(usize, FlagReason)> {
    let limit = rerun_limit(track, th);
    let mut out = Vec::new();
    for f in track.frames.iter().filter(|f| has_tracker_points(f)) {
        if !f.success {
            out.push((f.frame, FlagReason::TrackerFailed));
        }
        if let Some(d) = f.rerun_disagreement {
            // The frame's confidence is this number rescaled: one reason, not two.
            if f64::from(d) > limit {
                out.push((f.frame, FlagReason::TrackerRerun { disagreement: f64::from(d) }));
            }
            continue;
        }
        let point_min =
            f.points.iter().filter(|p| p.visible).filter_map(|p| p.confidence).reduce(f32::min);
        let lowest = match (f.confidence, point_min) {
            (Some(a), Some(b)) => Some(a.min(b)),
            (a, b) => a.or(b),
        };
        if let Some(value) = lowest.filter(|v| *v < th.min_confidence) {
            out.push((f.frame, FlagReason::LowConfidence { value }));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::landmarks::{LandmarkPoint, N_LANDMARKS};

    fn frame(n: usize) -> FrameLandmarks {
        FrameLandmarks::new(n, vec![LandmarkPoint::tracked(1.0, 2.0); N_LANDMARKS])
    }

    #[test]
    fn the_self_check_is_its_own_reason_and_replaces_the_confidence() {
        let th = FlagThresholds::default();
        // A clip the tracker agrees with itself on (partings 0.008–0.012)...
        let mut frames: Vec<FrameLandmarks> = (0..20)
            .map(|n| {
                let mut f = frame(n);
                f.rerun_disagreement = Some(0.008 + 0.001 * (n % 5) as f32);
                f.confidence = Some(0.9);
                f
            })
            .collect();
        // ...but for a frame where it parts clearly, one just above the floor, a frame of
        // another tracker with a low confidence, and a lost one.
        frames[7].rerun_disagreement = Some(0.034);
        frames[7].confidence = Some(0.66);
        frames[9].rerun_disagreement = Some(0.021);
        frames[11].rerun_disagreement = None;
        frames[11].confidence = Some(0.5);
        let mut lost = frame(12);
        lost.success = false;
        lost.points = vec![LandmarkPoint::missing(); N_LANDMARKS];
        frames[12] = lost.clone();
        let track = Track::new(frames);
        let limit = rerun_limit(&track, &th);
        assert!(limit > 0.021 && limit < 0.034, "{limit}");
        let flags = tracker_flags(&track, &th);
        assert_eq!(
            flags,
            vec![
                (7, FlagReason::TrackerRerun { disagreement: f64::from(0.034f32) }),
                (11, FlagReason::LowConfidence { value: 0.5 }),
                (12, FlagReason::TrackerFailed),
            ]
        );
        assert_eq!(
            flags[0].1.to_string(),
            "tracker's re-run parts from its result by 0.034 of eye distance"
        );
        // Just above the floor: a doubt, not a flag.
        assert_eq!(
            tracker_doubts(&track, &th),
            vec![(9, FlagReason::TrackerRerun { disagreement: f64::from(0.021f32) })]
        );
        // Every point placed again (a face box tracked from): the tracker's word is gone.
        for p in &mut lost.points {
            *p = LandmarkPoint {
                source: PointSource::Interpolated,
                ..LandmarkPoint::tracked(3.0, 4.0)
            };
        }
        assert!(tracker_flags(&Track::new(vec![lost]), &th).is_empty());
    }

    #[test]
    fn a_clip_that_parts_often_raises_the_limit_to_its_own_spread() {
        let th = FlagThresholds::default();
        // Partings 0.015–0.033 all through: the floor alone would flag most of the clip.
        let track = Track::new(
            (0..30)
                .map(|n| {
                    let mut f = frame(n);
                    f.rerun_disagreement = Some(0.015 + 0.002 * (n % 10) as f32);
                    f
                })
                .collect(),
        );
        let limit = rerun_limit(&track, &th);
        assert!(limit > 0.033, "{limit}");
        assert!(tracker_flags(&track, &th).is_empty());
        assert_eq!(tracker_doubts(&track, &th).len(), 21);
    }
}
