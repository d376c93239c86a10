//! Per-frame failure flags for a clip: sudden temporal jumps of a point, low tracker
//! confidence, high fit residual or a failed fit, and measure outliers, each with its reason.
//!
//! Thresholds are robust (median and MAD over the clip) so they adapt to the speaker, the
//! resolution and the frame rate; absolute floors stop a perfectly still clip from flagging
//! sub-pixel noise. Start at `flag_frames`.

use super::track::Track;
use std::fmt;

/// What the residual flags need of one frame's fit: plain numbers, so this module does not
/// depend on the fitter (which depends on landmarks). `fit::FrameFit` implements it.
pub trait FitResidual {
    /// The frame number.
    fn frame(&self) -> usize;
    /// Reprojection RMS (px); ignored when the fit failed.
    fn reproj_rms_px(&self) -> f64;
    /// Why the fit failed, when it did.
    fn failure(&self) -> Option<&str>;
}

/// Why a frame was flagged.
#[derive(Clone, Debug, PartialEq)]
pub enum FlagReason {
    /// Point `point` moved `px` pixels since the previous frame, far more than it usually does.
    Jump { point: usize, px: f64 },
    /// The tracker reported failure for the frame.
    TrackerFailed,
    /// The frame's (or its worst point's) tracker confidence is below the threshold.
    LowConfidence { value: f32 },
    /// The fit failed for this frame.
    FitFailed { reason: String },
    /// The fit's reprojection RMS is far above the clip's typical value.
    HighResidual { rms_px: f64 },
    /// A measure's value is an outlier for the clip (robust z-score).
    MeasureOutlier { measure: String, z: f64 },
}

impl fmt::Display for FlagReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Jump { point, px } => write!(f, "point {point} jumped {px:.1} px"),
            Self::TrackerFailed => write!(f, "tracker failed"),
            Self::LowConfidence { value } => write!(f, "low confidence {value:.2}"),
            Self::FitFailed { reason } => write!(f, "fit failed: {reason}"),
            Self::HighResidual { rms_px } => write!(f, "fit residual {rms_px:.1} px"),
            Self::MeasureOutlier { measure, z } => write!(f, "{measure} outlier (z {z:.1})"),
        }
    }
}

/// The flags of one frame (only frames with at least one reason are reported).
#[derive(Clone, Debug, PartialEq)]
pub struct FrameFlags {
    pub frame: usize,
    pub reasons: Vec<FlagReason>,
}

/// One measure's values over the clip, keyed by frame number.
#[derive(Clone, Debug, PartialEq)]
pub struct MeasureSeries {
    pub name: String,
    pub values: Vec<(usize, f64)>,
}

/// Thresholds for `flag_frames`.
#[derive(Clone, Debug, PartialEq)]
pub struct FlagThresholds {
    /// A displacement is a jump when it exceeds the point's median displacement by this many
    /// robust standard deviations (1.4826·MAD). 6 keeps fast articulation unflagged.
    pub jump_sigmas: f64,
    /// ...and exceeds this fraction of the face size (outer eye corner distance), so that
    /// still clips do not flag noise.
    pub jump_min_face_fraction: f64,
    /// Frame or point confidence below this is flagged (OpenFace suggests ~0.8 for frames).
    pub min_confidence: f32,
    /// A fit residual is high when above the clip's median by this many robust sigmas...
    pub residual_sigmas: f64,
    /// ...and above this multiple of the median (a tight clip's small spread must not flag
    /// frames that fit nearly as well as the rest)...
    pub residual_ratio: f64,
    /// ...and above this floor in pixels.
    pub residual_min_px: f64,
    /// Robust z-score of a measure's break from its neighbours above which it is flagged.
    pub measure_z: f64,
}

impl Default for FlagThresholds {
    fn default() -> Self {
        Self {
            jump_sigmas: 6.0,
            jump_min_face_fraction: 0.05,
            min_confidence: 0.8,
            residual_sigmas: 4.0,
            residual_ratio: 2.0,
            residual_min_px: 1.0,
            measure_z: 6.0,
        }
    }
}

/// Median and robust sigma (1.4826·MAD) of the values; `None` when empty.
fn median_sigma(values: &[f64]) -> Option<(f64, f64)> {
    let finite: Vec<f64> = values.iter().copied().filter(|v| v.is_finite()).collect();
    if finite.is_empty() {
        return None;
    }
    let med = median(finite.clone());
    let mad = median(finite.iter().map(|v| (v - med).abs()).collect());
    Some((med, 1.4826 * mad))
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(|a, b| a.total_cmp(b));
    let n = v.len();
    if n % 2 == 1 { v[n / 2] } else { 0.5 * (v[n / 2 - 1] + v[n / 2]) }
}

/// Frame flags for a clip, ascending by frame; frames with no reason are omitted.
/// `fits` and `measures` are optional extra evidence, matched to track frames by number.
pub fn flag_frames<F: FitResidual>(
    track: &Track,
    fits: Option<&[F]>,
    measures: &[MeasureSeries],
    th: &FlagThresholds,
) -> Vec<FrameFlags> {
    let mut by_frame: std::collections::BTreeMap<usize, Vec<FlagReason>> = Default::default();
    for (frame, reason) in jump_flags(track, th)
        .into_iter()
        .chain(confidence_flags(track, th))
        .chain(fits.map(|f| fit_flags(f, th)).unwrap_or_default())
        .chain(measures.iter().flat_map(|m| measure_flags(m, th)))
    {
        by_frame.entry(frame).or_default().push(reason);
    }
    by_frame.into_iter().map(|(frame, reasons)| FrameFlags { frame, reasons }).collect()
}

/// Face size of a frame: distance between the outer eye corners, when both are visible.
fn face_size(track: &Track) -> Option<f64> {
    let sizes: Vec<f64> = track
        .frames
        .iter()
        .filter_map(|f| {
            let (a, b) = (f.points.get(36)?, f.points.get(45)?);
            (a.visible && b.visible).then(|| (a.pos() - b.pos()).norm())
        })
        .collect();
    median_sigma(&sizes).map(|(m, _)| m)
}

/// Jumps: per point, two tests over frames where the point is visible. A *step* is the
/// displacement from the previous frame; a *spike* is the distance from the midpoint of the
/// previous and next frames' positions (a second difference), which smooth articulation keeps
/// small however fast it is, while a tracker error that lasts a frame or two stands out even
/// when its step is no bigger than a fast lip movement. Each test flags values above its own
/// robust limit (median + `jump_sigmas`·σ, at least the face-size floor); one reason per frame
/// (its largest jump). A spike counts only where it is a local maximum.
pub fn jump_flags(track: &Track, th: &FlagThresholds) -> Vec<(usize, FlagReason)> {
    let floor = face_size(track).map_or(0.0, |s| s * th.jump_min_face_fraction);
    let mut worst: std::collections::BTreeMap<usize, (usize, f64)> = Default::default();
    let n_points = track.frames.first().map_or(0, |f| f.points.len());
    let consecutive = |a: usize, b: usize| b == a + 1;
    for i in 0..n_points {
        let pos = |k: usize| {
            let p = track.frames[k].points.get(i)?;
            p.visible.then(|| p.pos())
        };
        let mut steps: Vec<(usize, f64)> = Vec::new();
        let mut spikes: Vec<(usize, f64)> = Vec::new();
        for k in 1..track.frames.len() {
            let (f0, f1) = (track.frames[k - 1].frame, track.frames[k].frame);
            if !consecutive(f0, f1) {
                continue;
            }
            if let (Some(a), Some(b)) = (pos(k - 1), pos(k)) {
                steps.push((f1, (b - a).norm()));
                if k + 1 < track.frames.len()
                    && consecutive(f1, track.frames[k + 1].frame)
                    && let Some(c) = pos(k + 1)
                {
                    let mid = nalgebra::center(&a, &c);
                    spikes.push((f1, (b - mid).norm()));
                }
            }
        }
        // A one-frame error also displaces its neighbours' midpoints by half as much: keep
        // only spikes that are local maxima, so the frames around a glitch are not flagged.
        let spike_at: std::collections::HashMap<usize, f64> = spikes.iter().copied().collect();
        spikes.retain(|&(f, d)| {
            let around = [f.checked_sub(1), Some(f + 1)];
            around.iter().flatten().all(|g| spike_at.get(g).is_none_or(|&n| d >= n))
        });
        for series in [&steps, &spikes] {
            let values: Vec<f64> = series.iter().map(|d| d.1).collect();
            let Some((med, sigma)) = median_sigma(&values) else { continue };
            let limit = (med + th.jump_sigmas * sigma).max(floor);
            for &(frame, d) in series.iter() {
                if d > limit && worst.get(&frame).is_none_or(|w| d > w.1) {
                    worst.insert(frame, (i, d));
                }
            }
        }
    }
    worst.into_iter().map(|(f, (point, px))| (f, FlagReason::Jump { point, px })).collect()
}

/// Tracker failure and low frame or point confidence.
pub fn confidence_flags(track: &Track, th: &FlagThresholds) -> Vec<(usize, FlagReason)> {
    let mut out = Vec::new();
    for f in &track.frames {
        if !f.success {
            out.push((f.frame, FlagReason::TrackerFailed));
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

/// Failed fits and reprojection RMS far above the clip's median.
pub fn fit_flags<F: FitResidual>(fits: &[F], th: &FlagThresholds) -> Vec<(usize, FlagReason)> {
    let ok: Vec<f64> =
        fits.iter().filter(|f| f.failure().is_none()).map(|f| f.reproj_rms_px()).collect();
    let limit = median_sigma(&ok).map_or(f64::INFINITY, |(m, s)| {
        (m + th.residual_sigmas * s).max(th.residual_ratio * m).max(th.residual_min_px)
    });
    let mut out = Vec::new();
    for f in fits {
        if let Some(reason) = f.failure() {
            out.push((f.frame(), FlagReason::FitFailed { reason: reason.to_string() }));
        } else if !f.reproj_rms_px().is_finite() || f.reproj_rms_px() > limit {
            out.push((f.frame(), FlagReason::HighResidual { rms_px: f.reproj_rms_px() }));
        }
    }
    out
}

/// Half-width (frames) of the running median a measure value is compared with.
pub const MEASURE_WINDOW: usize = 2;

/// Values that break from their temporal neighbourhood: the residual from the running median
/// of ±`MEASURE_WINDOW` values, as a robust z-score over the clip. A tracker glitch stands out;
/// a wide-open mouth held for a few frames does not (comparing with the clip's median would
/// flag every open frame of a mostly closed clip). A constant series flags nothing.
pub fn measure_flags(series: &MeasureSeries, th: &FlagThresholds) -> Vec<(usize, FlagReason)> {
    let values: Vec<(usize, f64)> =
        series.values.iter().copied().filter(|(_, v)| v.is_finite()).collect();
    let residuals: Vec<(usize, f64)> = (0..values.len())
        .map(|i| {
            let lo = i.saturating_sub(MEASURE_WINDOW);
            let hi = (i + MEASURE_WINDOW + 1).min(values.len());
            let window: Vec<f64> = values[lo..hi].iter().map(|v| v.1).collect();
            (values[i].0, values[i].1 - median(window))
        })
        .collect();
    let r: Vec<f64> = residuals.iter().map(|v| v.1).collect();
    let Some((med, sigma)) = median_sigma(&r) else { return Vec::new() };
    if sigma <= 1e-12 {
        return Vec::new();
    }
    residuals
        .into_iter()
        .map(|(f, v)| (f, (v - med) / sigma))
        .filter(|(_, z)| z.abs() > th.measure_z)
        .map(|(f, z)| (f, FlagReason::MeasureOutlier { measure: series.name.clone(), z }))
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::landmarks::{FrameLandmarks, LandmarkPoint, N_LANDMARKS};

    struct Residual {
        frame: usize,
        rms: f64,
        failed: Option<String>,
    }

    impl FitResidual for Residual {
        fn frame(&self) -> usize {
            self.frame
        }
        fn reproj_rms_px(&self) -> f64 {
            self.rms
        }
        fn failure(&self) -> Option<&str> {
            self.failed.as_deref()
        }
    }

    /// No fits: the flags of the track alone.
    fn track_flags(t: &Track) -> Vec<FrameFlags> {
        flag_frames::<Residual>(t, None, &[], &FlagThresholds::default())
    }

    /// A face drifting smoothly right by ~1 px a frame with a little wobble.
    fn smooth_track(n: usize) -> Track {
        Track::new(
            (0..n)
                .map(|f| {
                    let wobble = ((f * 7 % 5) as f64) * 0.1;
                    let pts = (0..N_LANDMARKS)
                        .map(|i| {
                            LandmarkPoint::tracked(
                                100.0 + f as f64 + wobble + (i % 10) as f64 * 30.0,
                                100.0 + (i / 10) as f64 * 10.0,
                            )
                        })
                        .collect();
                    FrameLandmarks::new(f, pts)
                })
                .collect(),
        )
    }

    #[test]
    fn a_glitch_is_flagged_as_jump_and_smooth_motion_is_not() {
        let mut t = smooth_track(40);
        assert!(jump_flags(&t, &FlagThresholds::default()).is_empty());
        t.get_mut(20).unwrap().points[48].x += 25.0;
        let flags = track_flags(&t);
        let frames: Vec<usize> = flags.iter().map(|f| f.frame).collect();
        assert_eq!(frames, vec![20, 21]);
        assert!(matches!(flags[0].reasons[0], FlagReason::Jump { point: 48, px } if px > 24.0));
    }

    #[test]
    fn low_confidence_and_tracker_failure() {
        let mut t = smooth_track(5);
        t.get_mut(1).unwrap().confidence = Some(0.3);
        t.get_mut(2).unwrap().success = false;
        t.get_mut(3).unwrap().points[5].confidence = Some(0.5);
        let flags = track_flags(&t);
        assert_eq!(flags.len(), 3);
        assert_eq!(flags[0].reasons, vec![FlagReason::LowConfidence { value: 0.3 }]);
        assert_eq!(flags[1].reasons, vec![FlagReason::TrackerFailed]);
        assert_eq!(flags[2].reasons, vec![FlagReason::LowConfidence { value: 0.5 }]);
    }

    #[test]
    fn residual_outliers_and_failures() {
        let fit = |frame, rms: f64, failed: Option<&str>| Residual {
            frame,
            rms,
            failed: failed.map(str::to_string),
        };
        let fits: Vec<Residual> = (0..20)
            .map(|f| match f {
                7 => fit(f, 15.0, None),
                9 => fit(f, f64::NAN, Some("too few landmarks")),
                _ => fit(f, 2.0 + (f % 3) as f64 * 0.1, None),
            })
            .collect();
        let flags = flag_frames(&smooth_track(20), Some(&fits), &[], &FlagThresholds::default());
        assert_eq!(flags.iter().map(|f| f.frame).collect::<Vec<_>>(), vec![7, 9]);
        assert!(matches!(flags[1].reasons[0], FlagReason::FitFailed { .. }));
    }

    #[test]
    fn a_held_open_mouth_is_not_an_outlier() {
        // Mostly closed, open for 8 frames: real articulation, not a glitch.
        let values: Vec<(usize, f64)> = (0..40)
            .map(|f| (f, if (10..18).contains(&f) { 0.5 } else { 0.02 + 0.002 * (f % 3) as f64 }))
            .collect();
        let s = MeasureSeries { name: "H".into(), values };
        assert!(measure_flags(&s, &FlagThresholds::default()).is_empty());
    }

    #[test]
    fn measure_outlier_by_robust_z() {
        let mut values: Vec<(usize, f64)> =
            (0..30).map(|f| (f, 0.3 + 0.01 * ((f % 4) as f64))).collect();
        values[12].1 = 0.9;
        let s = MeasureSeries { name: "W".into(), values };
        let flags = measure_flags(&s, &FlagThresholds::default());
        assert_eq!(flags.len(), 1);
        assert_eq!(flags[0].0, 12);
        let constant = MeasureSeries { name: "H".into(), values: vec![(0, 1.0), (1, 1.0)] };
        assert!(measure_flags(&constant, &FlagThresholds::default()).is_empty());
    }
}
