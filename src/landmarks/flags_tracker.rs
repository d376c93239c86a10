//! What a tracker says of its own frames: the failure it reports, a low confidence, and — for
//! landmarks made by lipmap's own tracker — its self-check. That tracker re-runs its
//! cascade from the box of each frame's result (`track::tracker`); on a face it has locked
//! onto the two runs land together, and where they part (the start was off: a fast move, a
//! cut, an occlusion, texture taken for a face) the frame is suspect. The parting is kept on
//! the frame (`FrameLandmarks::rerun_disagreement`, in eye-corner distances) and flagged here
//! as its own reason, [`FlagReason::TrackerRerun`], in place of the confidence derived from
//! it. Start at [`tracker_flags`].
//!
//! A frame whose every point has since been placed again (by hand, by a re-alignment to
//! corrected points, by tracking from a face box the user drew) no longer carries what the
//! tracker said of it: none of these reasons is given for it.

use super::flags::{FlagReason, FlagThresholds};
use super::track::{FrameLandmarks, PointSource, Track};

/// Whether some visible point of the frame is still the tracker's own.
fn has_tracker_points(f: &FrameLandmarks) -> bool {
    f.points.iter().any(|p| p.source == PointSource::Tracked && (p.visible || !f.success))
}

/// Tracker failure, low frame or point confidence, and lipmap's tracker disagreeing with
/// its own re-run by more than `max_rerun_disagreement` eye distances.
pub fn tracker_flags(track: &Track, th: &FlagThresholds) -> Vec<(usize, FlagReason)> {
    let mut out = Vec::new();
    for f in track.frames.iter().filter(|f| has_tracker_points(f)) {
        if !f.success {
            out.push((f.frame, FlagReason::TrackerFailed));
        }
        if let Some(d) = f.rerun_disagreement {
            // The frame's confidence is this number rescaled: one reason, not two.
            if f64::from(d) > th.max_rerun_disagreement {
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
        let mut agreeing = frame(0);
        agreeing.rerun_disagreement = Some(0.01);
        agreeing.confidence = Some(0.9);
        let mut parting = frame(1);
        parting.rerun_disagreement = Some(0.034);
        parting.confidence = Some(0.66);
        let mut other_tracker = frame(2);
        other_tracker.confidence = Some(0.5);
        let mut lost = frame(3);
        lost.success = false;
        lost.points = vec![LandmarkPoint::missing(); N_LANDMARKS];
        let track = Track::new(vec![agreeing, parting, other_tracker, lost.clone()]);
        let flags = tracker_flags(&track, &th);
        assert_eq!(
            flags,
            vec![
                (1, FlagReason::TrackerRerun { disagreement: f64::from(0.034f32) }),
                (2, FlagReason::LowConfidence { value: 0.5 }),
                (3, FlagReason::TrackerFailed),
            ]
        );
        assert_eq!(
            flags[0].1.to_string(),
            "tracker's re-run parts from its result by 0.034 of eye distance"
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
}
