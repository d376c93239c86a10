//! The corrections layer: hand-corrected and interpolated points stored beside the tracker's
//! output (never over it), the frames marked reviewed, and the effective landmarks = both.

use crate::landmarks::{FrameLandmarks, LandmarkPoint, N_LANDMARKS, PointSource, Track};
use serde::{Deserialize, Serialize};
use std::collections::{BTreeMap, BTreeSet};

/// Edits to one clip's landmarks. Removing an entry restores the tracker's point, so every
/// edit can be undone and nothing the tracker gave is lost.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct Corrections {
    /// frame -> 0-based iBUG point -> the point to use instead of the tracked one; its
    /// `source` is `Corrected` or `Interpolated`.
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub points: BTreeMap<usize, BTreeMap<usize, LandmarkPoint>>,
    /// Frames a person has checked and accepted.
    #[serde(default, skip_serializing_if = "BTreeSet::is_empty")]
    pub reviewed: BTreeSet<usize>,
}

impl Corrections {
    /// Stores `p` for (`frame`, `point`). A `Tracked` source is recorded as `Corrected`: a
    /// point in this layer was by definition not left as the tracker gave it.
    ///
    /// # Errors
    /// A message when `point` is not a 0-based iBUG index or a coordinate is not finite.
    pub fn set(&mut self, frame: usize, point: usize, mut p: LandmarkPoint) -> Result<(), String> {
        if point >= N_LANDMARKS {
            return Err(format!("point index {point} is not an iBUG-68 index (0..{N_LANDMARKS})"));
        }
        if !(p.x.is_finite() && p.y.is_finite()) || p.confidence.is_some_and(|c| !c.is_finite()) {
            let point = crate::landmarks::PointNo(point);
            return Err(format!("frame {frame} point {point}: coordinates must be finite"));
        }
        if p.source == PointSource::Tracked {
            p.source = PointSource::Corrected;
        }
        self.points.entry(frame).or_default().insert(point, p);
        Ok(())
    }

    /// Removes the correction of (`frame`, `point`), returning it.
    pub fn clear(&mut self, frame: usize, point: usize) -> Option<LandmarkPoint> {
        let frame_map = self.points.get_mut(&frame)?;
        let old = frame_map.remove(&point);
        if frame_map.is_empty() {
            self.points.remove(&frame);
        }
        old
    }

    /// Removes every correction of `frame`, returning how many there were.
    pub fn clear_frame(&mut self, frame: usize) -> usize {
        self.points.remove(&frame).map_or(0, |m| m.len())
    }

    /// The correction of (`frame`, `point`), if any.
    pub fn get(&self, frame: usize, point: usize) -> Option<&LandmarkPoint> {
        self.points.get(&frame)?.get(&point)
    }

    /// Number of corrected points over all frames.
    pub fn len(&self) -> usize {
        self.points.values().map(BTreeMap::len).sum()
    }

    pub fn is_empty(&self) -> bool {
        self.points.is_empty()
    }

    pub fn set_reviewed(&mut self, frame: usize, reviewed: bool) {
        if reviewed {
            self.reviewed.insert(frame);
        } else {
            self.reviewed.remove(&frame);
        }
    }

    pub fn is_reviewed(&self, frame: usize) -> bool {
        self.reviewed.contains(&frame)
    }

    /// The landmarks of `frame` with corrections applied over the tracked ones. A frame the
    /// tracker missed but that has corrections is built from not-visible points plus them.
    /// `None` when the frame has neither.
    pub fn effective_frame(&self, tracked: &Track, frame: usize) -> Option<FrameLandmarks> {
        let fixes = self.points.get(&frame);
        let mut out = match (tracked.get(frame), fixes) {
            (Some(f), _) => f.clone(),
            (None, Some(_)) => {
                FrameLandmarks::new(frame, vec![LandmarkPoint::missing(); N_LANDMARKS])
            }
            (None, None) => return None,
        };
        if let Some(fixes) = fixes {
            for (&i, p) in fixes {
                if let Some(slot) = out.points.get_mut(i) {
                    *slot = *p;
                }
            }
        }
        Some(out)
    }

    /// Frame numbers with landmarks of either kind, ascending.
    pub fn frames_with_landmarks(&self, tracked: &Track) -> Vec<usize> {
        let mut frames: Vec<usize> = tracked.frames.iter().map(|f| f.frame).collect();
        let extra: Vec<usize> =
            self.points.keys().copied().filter(|f| tracked.get(*f).is_none()).collect();
        if !extra.is_empty() {
            frames.extend(extra);
            frames.sort_unstable();
        }
        frames
    }

    /// The whole clip with corrections applied (for export or a fit over every frame).
    pub fn effective_track(&self, tracked: &Track) -> Track {
        Track::new(
            self.frames_with_landmarks(tracked)
                .into_iter()
                .filter_map(|f| self.effective_frame(tracked, f))
                .collect(),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn track() -> Track {
        let pts =
            (0..N_LANDMARKS).map(|i| LandmarkPoint::tracked(i as f64, 2.0 * i as f64)).collect();
        Track::new(vec![FrameLandmarks::new(3, pts)])
    }

    #[test]
    fn corrections_override_and_clear_restores_tracked() {
        let t = track();
        let mut c = Corrections::default();
        c.set(3, 62, LandmarkPoint::tracked(100.5, 200.25)).unwrap();
        let e = c.effective_frame(&t, 3).unwrap();
        assert_eq!(e.points[62].x, 100.5);
        assert_eq!(e.points[62].source, PointSource::Corrected);
        assert_eq!(e.points[61], t.get(3).unwrap().points[61]);
        assert_eq!(c.clear(3, 62).unwrap().y, 200.25);
        assert_eq!(c.effective_frame(&t, 3).unwrap(), t.get(3).unwrap().clone());
        assert!(c.is_empty());
    }

    #[test]
    fn untracked_frame_with_a_correction_has_only_that_point_visible() {
        let t = track();
        let mut c = Corrections::default();
        assert!(c.effective_frame(&t, 5).is_none());
        c.set(5, 0, LandmarkPoint::tracked(1.0, 1.0)).unwrap();
        let e = c.effective_frame(&t, 5).unwrap();
        assert_eq!(e.visible_points().count(), 1);
        assert_eq!(c.frames_with_landmarks(&t), vec![3, 5]);
        assert_eq!(c.effective_track(&t).len(), 2);
    }

    #[test]
    fn bad_points_are_refused() {
        let mut c = Corrections::default();
        assert!(c.set(0, 68, LandmarkPoint::tracked(0.0, 0.0)).is_err());
        assert!(c.set(0, 1, LandmarkPoint::tracked(f64::NAN, 0.0)).is_err());
        assert!(c.is_empty());
    }
}
