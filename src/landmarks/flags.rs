//! Per-frame failure flags for a clip, each with its reason and the number that triggered
//! it: a point jumping relative to the head (`flags_motion`), lip contours out of anatomical
//! order (`flags_lips`), a lip shape that breaks from its neighbours once head motion is
//! removed (`flags_procrustes`), the tracker's own doubt (`flags_tracker`: its failure, a
//! low confidence, lipmap's tracker parting from its re-run), a high fit residual or failed fit,
//! and a measure that breaks from its neighbours by much of the speaker's own range.
//!
//! Distances are in face sizes (the outer eye-corner distance) and limits are robust (median
//! and MAD over the clip), so they adapt to the speaker, the resolution and the frame rate;
//! floors stop a perfectly still clip from flagging sub-pixel noise. Start at `flag_frames`;
//! the thresholds and what they were calibrated on are in `docs/flags.md`.

use super::PointNo;
pub use super::flags_image::{
    EdgeOffset, FrameRgb, LipEdgeOffset, RgbPixels, flags_of_lip_edges, image_flags,
    lip_edge_offsets, lip_edge_registration, lower_lip_edge_offset, lower_lip_off_opening,
    outer_lower_lip_edge_offset,
};
pub use super::flags_lips::lip_order_flags;
pub use super::flags_motion::jump_flags;
pub use super::flags_procrustes::shape_flags;
pub use super::flags_tracker::{rerun_limit, tracker_doubts, tracker_flags};
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
    /// Point `point` moved `px` pixels (`face_fraction` of the face size) relative to the
    /// head, far more than it usually does.
    Jump { point: usize, px: f64, face_fraction: f64 },
    /// Lip point `lower` sits above lip point `upper` by `face_fraction` of the face size.
    LipOrder { upper: usize, lower: usize, face_fraction: f64 },
    /// The lip shape, aligned to its neighbours' mean, is `face_fraction` of the face size
    /// (RMS) away from it.
    ShapeBreak { face_fraction: f64 },
    /// The tracker reported failure for the frame.
    TrackerFailed,
    /// The frame's (or its worst point's) tracker confidence is below the threshold.
    LowConfidence { value: f32 },
    /// lipmap's tracker: the cascade re-run from the box of its result parts from it by
    /// `disagreement` eye-corner distances (`flags_tracker`).
    TrackerRerun { disagreement: f64 },
    /// The fit failed for this frame.
    FitFailed { reason: String },
    /// The fit's reprojection RMS is far above the clip's typical value.
    HighResidual { rms_px: f64 },
    /// A measure's value breaks from its neighbours by `range_fraction` of the clip's range
    /// (5th to 95th percentile), a robust z-score `z` of such breaks.
    MeasureOutlier { measure: String, z: f64, range_fraction: f64 },
    /// Image evidence: inner lower lip point `point` sits `px` pixels (`face_fraction` of the
    /// face size) above the lower lip's edge in the image, on the tongue between the lip and
    /// the open mouth's dark (`flags_image`).
    LowerLipOffOpening { point: usize, px: f64, face_fraction: f64 },
    /// Image evidence: outer lower lip point `point` sits `px` pixels (`face_fraction` of
    /// the face size) below the lower lip's lower edge in the image, on the chin
    /// (`flags_image`).
    OuterLowerLipOffEdge { point: usize, px: f64, face_fraction: f64 },
}

impl fmt::Display for FlagReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Jump { point, px, face_fraction } => {
                let what = if MOUTH_CORNERS.contains(point) { "mouth corner" } else { "point" };
                let point = PointNo(*point);
                write!(f, "{what} {point} jumped {px:.1} px ({face_fraction:.3} of eye distance)")
            }
            Self::LipOrder { upper, lower, face_fraction } => write!(
                f,
                "lip order: point {} above point {} by {face_fraction:.3} of eye distance",
                PointNo(*lower),
                PointNo(*upper)
            ),
            Self::ShapeBreak { face_fraction } => {
                write!(f, "lip shape off its neighbours by {face_fraction:.3} of eye distance")
            }
            Self::TrackerFailed => write!(f, "tracker failed"),
            Self::LowConfidence { value } => write!(f, "low confidence {value:.2}"),
            Self::TrackerRerun { disagreement } => write!(
                f,
                "tracker's re-run parts from its result by {disagreement:.3} of eye distance"
            ),
            Self::FitFailed { reason } => write!(f, "fit failed: {reason}"),
            Self::HighResidual { rms_px } => write!(f, "reprojection RMS {rms_px:.1} px"),
            Self::MeasureOutlier { measure, z, range_fraction } => {
                write!(f, "{measure} break {range_fraction:.2} of its range (z {z:.1})")
            }
            Self::LowerLipOffOpening { point, px, face_fraction } => write!(
                f,
                "point {} lower lip on the tongue: {px:.1} px ({face_fraction:.3} of eye \
                 distance) above the lower lip's edge in the image",
                PointNo(*point)
            ),
            Self::OuterLowerLipOffEdge { point, px, face_fraction } => write!(
                f,
                "point {} lower lip on the chin: {px:.1} px ({face_fraction:.3} of eye \
                 distance) below the lower lip's lower edge in the image",
                PointNo(*point)
            ),
        }
    }
}

impl FlagReason {
    /// Whether the reason is evidence that the frame's landmarks or fit are wrong, not only
    /// that its motion is unusual: a jump or a measure break alone also marks real fast
    /// speech (a wide opening), while a crossed lip, a broken lip shape, a fit that cannot
    /// follow the points or the tracker's own doubt do not happen on a good track.
    pub fn discredits_frame(&self) -> bool {
        !matches!(self, Self::Jump { .. } | Self::MeasureOutlier { .. })
    }

    /// The point the reason is about (0-based), when it names one: what the TUI selects.
    pub fn point(&self) -> Option<usize> {
        match self {
            Self::Jump { point, .. }
            | Self::LowerLipOffOpening { point, .. }
            | Self::OuterLowerLipOffEdge { point, .. } => Some(*point),
            Self::LipOrder { lower, .. } => Some(*lower),
            _ => None,
        }
    }
}

/// The outer and inner mouth corners, whose jumps are named as such.
pub const MOUTH_CORNERS: [usize; 4] = [48, 54, 60, 64];

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
    /// A displacement relative to the head is a jump when it exceeds the point's median
    /// displacement by this many robust standard deviations (1.4826·MAD)...
    pub jump_sigmas: f64,
    /// ...and exceeds this fraction of the face size (outer eye corner distance), so that
    /// still clips do not flag noise. This floor is for steps (frame to frame), which fast
    /// real articulation makes large...
    pub jump_min_face_fraction: f64,
    /// ...while spikes (the distance from the neighbours' midpoint), which articulation keeps
    /// small however fast it is, have this lower floor...
    pub spike_min_face_fraction: f64,
    /// ...and this one in pixels: a tracker's jitter is a pixel or two whatever the face's
    /// size, so on a small face a relative floor alone would flag it.
    pub spike_min_px: f64,
    /// Lip points out of order by more than this fraction of the face size are flagged.
    pub lip_order_face_fraction: f64,
    /// A lip shape breaks from its neighbours when its aligned RMS distance exceeds the
    /// clip's median by this many robust sigmas...
    pub shape_sigmas: f64,
    /// ...and this fraction of the face size.
    pub shape_min_face_fraction: f64,
    /// Frame or point confidence below this is flagged (OpenFace suggests ~0.8 for frames).
    pub min_confidence: f32,
    /// lipmap's tracker's result and its re-run parting by more than this many eye-corner
    /// distances is a doubt (the confidence 0.8 it writes for other programs)...
    pub max_rerun_disagreement: f64,
    /// ...flagged by itself when the parting is also above the clip's median by this many
    /// robust sigmas, and otherwise a reason added to frames other checks flag.
    pub rerun_sigmas: f64,
    /// A fit residual is high when above the clip's median by this many robust sigmas...
    pub residual_sigmas: f64,
    /// ...and above this multiple of the median (a tight clip's small spread must not flag
    /// frames that fit nearly as well as the rest)...
    pub residual_ratio: f64,
    /// ...and above this floor in pixels.
    pub residual_min_px: f64,
    /// Robust z-score of a measure's break from its neighbours above which it is flagged...
    pub measure_z: f64,
    /// ...when the break is also at least this fraction of the measure's range over the
    /// clip: a fast real opening is a large z on a mostly still clip, but a small part of
    /// the speaker's range.
    pub measure_range_fraction: f64,
    /// The image evidence on the lower lip reads only frames whose inner lips are further
    /// apart than this fraction of the face size...
    pub lower_lip_opening_face_fraction: f64,
    /// ...plus this many pixels, the blur of the open mouth's two edges (a pixel each): an
    /// opening narrower holds no interior the lip's edge could be read under.
    pub lower_lip_edge_px: f64,
    /// An inner lower lip point more than this fraction of the face size above the lower
    /// lip's edge in the image (on the tongue) is flagged.
    pub lower_lip_edge_face_fraction: f64,
    /// Outer lower lip points more than this fraction of the face size below the lip's
    /// lower edge in the image (on the chin) are flagged.
    pub outer_lip_edge_face_fraction: f64,
}

impl Default for FlagThresholds {
    fn default() -> Self {
        Self {
            jump_sigmas: 6.0,
            jump_min_face_fraction: 0.1,
            spike_min_face_fraction: 0.05,
            spike_min_px: 4.0,
            lip_order_face_fraction: 0.04,
            shape_sigmas: 6.0,
            shape_min_face_fraction: 0.03,
            min_confidence: 0.8,
            max_rerun_disagreement: 0.02,
            rerun_sigmas: 6.0,
            residual_sigmas: 4.0,
            residual_ratio: 2.0,
            residual_min_px: 1.0,
            measure_z: 6.0,
            measure_range_fraction: 0.5,
            lower_lip_opening_face_fraction: 0.08,
            lower_lip_edge_px: 2.0,
            lower_lip_edge_face_fraction: 0.025,
            outer_lip_edge_face_fraction: 0.045,
        }
    }
}

/// Median and robust sigma (1.4826·MAD) of the values; `None` when empty.
pub(super) fn median_sigma(values: &[f64]) -> Option<(f64, f64)> {
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
        .chain(lip_order_flags(track, th))
        .chain(shape_flags(track, th))
        .chain(tracker_flags(track, th))
        .chain(fits.map(|f| fit_flags(f, th)).unwrap_or_default())
        .chain(measures.iter().flat_map(|m| measure_flags(m, th)))
    {
        by_frame.entry(frame).or_default().push(reason);
    }
    for (frame, doubt) in tracker_doubts(track, th) {
        if let Some(reasons) = by_frame.get_mut(&frame) {
            reasons.push(doubt);
        }
    }
    by_frame.into_iter().map(|(frame, reasons)| FrameFlags { frame, reasons }).collect()
}

/// `flags` (ascending by frame, as [`flag_frames`] gives them) with `extra` reasons added
/// to their frames, new frames inserted in order.
pub fn add_reasons(
    flags: &mut Vec<FrameFlags>,
    extra: impl IntoIterator<Item = (usize, FlagReason)>,
) {
    for (frame, reason) in extra {
        match flags.binary_search_by_key(&frame, |f| f.frame) {
            Ok(i) => flags[i].reasons.push(reason),
            Err(i) => flags.insert(i, FrameFlags { frame, reasons: vec![reason] }),
        }
    }
}

/// Face size per frame of `track` (its outer eye-corner distance, 36–45), the clip's median
/// where a frame lacks either corner; all `None` when no frame has both.
pub(super) fn face_sizes(track: &Track) -> Vec<Option<f64>> {
    let own: Vec<Option<f64>> = track
        .frames
        .iter()
        .map(|f| {
            let (a, b) = (f.points.get(36)?, f.points.get(45)?);
            let d = (a.pos() - b.pos()).norm();
            (a.visible && b.visible && d > 1e-9).then_some(d)
        })
        .collect();
    let known: Vec<f64> = own.iter().flatten().copied().collect();
    let fallback = median_sigma(&known).map(|(m, _)| m);
    own.into_iter().map(|s| s.or(fallback)).collect()
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
/// of ±`MEASURE_WINDOW` values, flagged when it is both a robust outlier among the clip's
/// residuals (z above `measure_z`) and a large part of the speaker's own range of the measure
/// (above `measure_range_fraction` of the 5th–95th percentile span). A tracker glitch stands
/// out on both; a quick real opening in a mostly still clip has a large z but stays a small
/// part of the range, and a wide-open mouth held for a few frames breaks from nothing.
/// A constant series flags nothing.
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
    let range = percentile_span(values.iter().map(|v| v.1).collect(), 0.05);
    if sigma <= 1e-12 || range <= 1e-12 {
        return Vec::new();
    }
    residuals
        .into_iter()
        .map(|(f, v)| (f, (v - med) / sigma, v.abs() / range))
        .filter(|&(_, z, part)| z.abs() > th.measure_z && part > th.measure_range_fraction)
        .map(|(f, z, range_fraction)| {
            (f, FlagReason::MeasureOutlier { measure: series.name.clone(), z, range_fraction })
        })
        .collect()
}

/// The span between the `q` and `1 − q` quantiles (nearest rank) of the values.
fn percentile_span(mut v: Vec<f64>, q: f64) -> f64 {
    if v.is_empty() {
        return 0.0;
    }
    v.sort_by(|a, b| a.total_cmp(b));
    let at = |p: f64| v[((p * (v.len() - 1) as f64).round() as usize).min(v.len() - 1)];
    at(1.0 - q) - at(q)
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

    #[test]
    fn reasons_number_points_as_people_do() {
        let jump = FlagReason::Jump { point: 56, px: 3.6, face_fraction: 0.113 };
        assert_eq!(jump.to_string(), "point 57 jumped 3.6 px (0.113 of eye distance)");
        let corner = FlagReason::Jump { point: 48, px: 1.0, face_fraction: 0.1 };
        assert!(corner.to_string().starts_with("mouth corner 49 jumped"));
        let order = FlagReason::LipOrder { upper: 61, lower: 67, face_fraction: 0.05 };
        assert!(order.to_string().starts_with("lip order: point 68 above point 62"));
        let high = FlagReason::HighResidual { rms_px: 2.34 };
        assert_eq!(high.to_string(), "reprojection RMS 2.3 px");
    }

    /// No fits: the flags of the track alone.
    fn track_flags(t: &Track) -> Vec<FrameFlags> {
        flag_frames::<Residual>(t, None, &[], &FlagThresholds::default())
    }

    /// Where point `i` sits on a still face: a grid for the points outside the mouth (outer
    /// eye corners 36 and 45 about 32 px apart), and a closed-ish mouth whose lips are in
    /// order (outer upper above inner upper above inner lower above outer lower).
    fn face_point(i: usize) -> (f64, f64) {
        const MOUTH: [(f64, f64); 20] = [
            (-12.0, 0.0), // 48 corner
            (-8.0, -5.0), // 49..53 outer upper
            (-4.0, -6.0),
            (0.0, -6.0),
            (4.0, -6.0),
            (8.0, -5.0),
            (12.0, 0.0), // 54 corner
            (8.0, 7.0),  // 55..59 outer lower, right to left
            (4.0, 8.0),
            (0.0, 8.0),
            (-4.0, 8.0),
            (-8.0, 7.0),
            (-10.0, 0.0), // 60 inner corner
            (-4.0, -2.0), // 61..63 inner upper
            (0.0, -2.0),
            (4.0, -2.0),
            (10.0, 0.0), // 64 inner corner
            (4.0, 2.0),  // 65..67 inner lower, right to left
            (0.0, 2.0),
            (-4.0, 2.0),
        ];
        match i {
            48..=67 => (265.0 + MOUTH[i - 48].0, 200.0 + MOUTH[i - 48].1),
            _ => ((i % 10) as f64 * 30.0, (i / 10) as f64 * 10.0),
        }
    }

    /// A face drifting smoothly right by ~1 px a frame with a little wobble.
    fn smooth_track(n: usize) -> Track {
        Track::new(
            (0..n)
                .map(|f| {
                    let wobble = ((f * 7 % 5) as f64) * 0.1;
                    let pts = (0..N_LANDMARKS)
                        .map(|i| {
                            let (x, y) = face_point(i);
                            LandmarkPoint::tracked(100.0 + f as f64 + wobble + x, 100.0 + y)
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
        assert_eq!(frames, vec![20]);
        assert!(matches!(flags[0].reasons[0], FlagReason::Jump { point: 48, px, .. } if px > 24.0));
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

    #[test]
    fn added_reasons_join_their_frames_in_order() {
        let mut flags = vec![
            FrameFlags { frame: 2, reasons: vec![FlagReason::TrackerFailed] },
            FrameFlags { frame: 9, reasons: vec![FlagReason::TrackerFailed] },
        ];
        let r = |point| FlagReason::LowerLipOffOpening { point, px: 3.0, face_fraction: 0.1 };
        add_reasons(&mut flags, [(9, r(66)), (5, r(65)), (0, r(67))]);
        assert_eq!(flags.iter().map(|f| f.frame).collect::<Vec<_>>(), vec![0, 2, 5, 9]);
        assert_eq!(flags[3].reasons, vec![FlagReason::TrackerFailed, r(66)]);
        assert_eq!(flags[3].reasons[1].point(), Some(66));
        assert_eq!(FlagReason::TrackerFailed.point(), None);
    }
}
