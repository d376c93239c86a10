//! A clip's automatic protrusion points and the user's corrections, kept apart so every
//! edit can be undone.

use super::{ProfilePoint, ProfileSetup};
use crate::landmarks::PointSource;
use crate::math::{Point2, Real};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// A clip's automatic measurements and the user's corrections, kept apart so every edit can
/// be undone (the model of landmark corrections).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ProfileTrack {
    /// As measured, one per frame, ascending by frame.
    pub automatic: Vec<ProfilePoint>,
    /// Frame → the upper lip point the user set (image px).
    #[serde(default)]
    pub corrected: BTreeMap<usize, Point2>,
    /// The nose length used for `p_norm` (px), resolved once.
    #[serde(default)]
    pub nose_length_px: Option<Real>,
}

impl ProfileTrack {
    pub fn new(automatic: Vec<ProfilePoint>, nose_length_px: Option<Real>) -> Self {
        let mut automatic = automatic;
        automatic.sort_by_key(|p| p.frame);
        Self { automatic, corrected: BTreeMap::new(), nose_length_px }
    }

    /// Sets the user's point for `frame` (image px).
    pub fn correct(&mut self, frame: usize, point: Point2) {
        self.corrected.insert(frame, point);
    }

    /// Drops the user's point for `frame`; returns it if there was one.
    pub fn clear_correction(&mut self, frame: usize) -> Option<Point2> {
        self.corrected.remove(&frame)
    }

    /// The automatic point of `frame`, if measured.
    pub fn automatic(&self, frame: usize) -> Option<&ProfilePoint> {
        self.automatic.binary_search_by_key(&frame, |p| p.frame).ok().map(|i| &self.automatic[i])
    }

    /// The point in force for `frame`: the correction (P recomputed from the setup's line)
    /// when there is one, else the automatic point.
    pub fn effective(&self, frame: usize, setup: &ProfileSetup) -> Option<ProfilePoint> {
        match self.corrected.get(&frame) {
            Some(&p) => Some(ProfilePoint::at(
                frame,
                p,
                setup,
                self.nose_length_px,
                PointSource::Corrected,
                self.automatic(frame).and_then(|a| a.motion),
            )),
            None => self.automatic(frame).cloned(),
        }
    }

    /// Every frame's effective point (automatic frames plus frames only corrected).
    pub fn effective_all(&self, setup: &ProfileSetup) -> Vec<ProfilePoint> {
        let mut frames: Vec<usize> = self.automatic.iter().map(|p| p.frame).collect();
        frames.extend(self.corrected.keys().copied());
        frames.sort_unstable();
        frames.dedup();
        frames.into_iter().filter_map(|f| self.effective(f, setup)).collect()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measure::profile::synthetic::mouth_setup;

    #[test]
    fn corrections_override_and_undo() {
        let setup = mouth_setup();
        let auto = |f| {
            ProfilePoint::at(
                f,
                Point2::new(110.0, 150.0),
                &setup,
                Some(20.0),
                PointSource::Tracked,
                None,
            )
        };
        let mut track = ProfileTrack::new(vec![auto(2), auto(0), auto(1)], Some(20.0));
        assert_eq!(track.automatic.iter().map(|p| p.frame).collect::<Vec<_>>(), vec![0, 1, 2]);
        track.correct(1, Point2::new(104.0, 150.0));
        track.correct(5, Point2::new(106.0, 150.0));
        let all = track.effective_all(&setup);
        assert_eq!(all.iter().map(|p| p.frame).collect::<Vec<_>>(), vec![0, 1, 2, 5]);
        assert_eq!(
            (all[1].p_px, all[1].p_norm, all[1].source),
            (Some(4.0), Some(0.2), PointSource::Corrected)
        );
        assert_eq!(all[0], auto(0));
        assert_eq!(track.clear_correction(1), Some(Point2::new(104.0, 150.0)));
        assert_eq!(track.effective(1, &setup), Some(auto(1)));
        assert_eq!(track.clear_correction(1), None);
    }
}
