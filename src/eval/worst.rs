//! The N worst frames: by measure error (|head − video| of W, H or P) and by fit residual
//! (reprojection RMS, failed fits first); each is a jump target for the TUI.

use super::Utterance;
use crate::fit::result::FrameFit;
use crate::measure::Measure;
use serde::{Deserialize, Serialize};

/// A frame ranked by measure error.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WorstFrame {
    /// Utterance name.
    pub utterance: String,
    /// 0-based frame number in the utterance.
    pub frame: usize,
    pub measure: Measure,
    pub video: f64,
    pub head: f64,
    /// head − video (signed; ranked by its absolute value).
    pub error: f64,
    /// The phone label at the frame's time, when the alignment covers it.
    pub phone: Option<String>,
}

/// The `n` frames with the largest |head − video| of measure `m` over all utterances,
/// worst first; ties keep utterance and frame order. Frames without both values are skipped.
pub fn worst_frames_by_error(utterances: &[Utterance], m: Measure, n: usize) -> Vec<WorstFrame> {
    let mut top = Vec::new();
    for u in utterances {
        add_worst_frames(&mut top, u, m, n);
    }
    top
}

/// Merges the frames of `u` into `top`, the `n` worst so far of measure `m` (as
/// [`worst_frames_by_error`] ranks them): utterances can be added one at a time and dropped.
/// Candidates are kept only while they can still rank, so memory is `n` plus a clip.
pub fn add_worst_frames(top: &mut Vec<WorstFrame>, u: &Utterance, m: Measure, n: usize) {
    let (v, h) = (u.video.series(m), u.head.series(m));
    let floor = if top.len() >= n { top.last().map_or(0.0, |w| w.error.abs()) } else { -1.0 };
    for (frame, (a, b)) in v.iter().zip(h).enumerate() {
        let (Some(video), Some(head)) = (*a, *b) else { continue };
        // A later frame that only ties the n-th never ranks: ties keep the earlier one.
        if !(video.is_finite() && head.is_finite()) || (head - video).abs() <= floor {
            continue;
        }
        let phone = (u.fps > 0.0)
            .then(|| u.alignment.phone_at(frame as f64 / u.fps))
            .flatten()
            .map(|p| p.label.clone());
        top.push(WorstFrame {
            utterance: u.name.clone(),
            frame,
            measure: m,
            video,
            head,
            error: head - video,
            phone,
        });
    }
    // Stable: among equal errors the earlier utterance and frame stay first.
    top.sort_by(|a, b| b.error.abs().total_cmp(&a.error.abs()));
    top.truncate(n);
}

/// A frame ranked by fit residual.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct WorstFit {
    /// Clip or utterance name.
    pub clip: String,
    pub frame: usize,
    pub reproj_rms_px: f64,
    /// The fit's failure reason, when it failed.
    pub failed: Option<String>,
}

/// The `n` worst fitted frames over named clips: failed frames first (they need attention
/// whatever their residual), then by reprojection RMS in pixels, largest first; a non-finite
/// RMS ranks as worst.
pub fn worst_frames_by_residual(clips: &[(&str, &[FrameFit])], n: usize) -> Vec<WorstFit> {
    let mut top = Vec::new();
    for (name, fits) in clips {
        add_worst_fits(&mut top, name, fits, n);
    }
    top
}

/// Merges the fits of clip `name` into `top`, the `n` worst so far (as
/// [`worst_frames_by_residual`] ranks them): clips can be added one at a time and dropped.
pub fn add_worst_fits(top: &mut Vec<WorstFit>, name: &str, fits: &[FrameFit], n: usize) {
    top.extend(fits.iter().map(|f| WorstFit {
        clip: name.to_string(),
        frame: f.frame,
        reproj_rms_px: f.reproj_rms_px,
        failed: f.failed.clone(),
    }));
    let key = |w: &WorstFit| {
        let rms = if w.reproj_rms_px.is_finite() { w.reproj_rms_px } else { f64::INFINITY };
        (w.failed.is_some(), rms)
    };
    // Stable: among equal ranks the earlier clip and frame stay first.
    top.sort_by(|a, b| {
        let (fa, ra) = key(a);
        let (fb, rb) = key(b);
        fb.cmp(&fa).then(rb.total_cmp(&ra))
    });
    top.truncate(n);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::alignment::{Alignment, Phone};
    use crate::measure::Trajectory;

    #[test]
    fn ranks_by_absolute_error_with_phone() {
        let u = Utterance {
            name: "a".into(),
            speaker: None,
            alignment: Alignment {
                phones: vec![Phone { start: 0.0, end: 1.0, label: "UW1".into() }],
            },
            fps: 4.0,
            video: Trajectory { w: vec![Some(1.0); 4], h: vec![], p: vec![] },
            head: Trajectory {
                w: vec![Some(1.1), Some(0.5), None, Some(1.3)],
                h: vec![],
                p: vec![],
            },
        };
        let w = worst_frames_by_error(&[u], Measure::W, 2);
        assert_eq!(w.iter().map(|f| f.frame).collect::<Vec<_>>(), [1, 3]);
        assert!((w[0].error + 0.5).abs() < 1e-12);
        assert_eq!(w[0].phone.as_deref(), Some("UW1"));
    }

    #[test]
    fn failed_fits_rank_first() {
        let fit = |frame: usize, rms: f64, failed: bool| FrameFit {
            reproj_rms_px: rms,
            failed: failed.then(|| "too few landmarks".to_string()),
            ..FrameFit::unposed(frame)
        };
        let a = [fit(0, 1.0, false), fit(1, 9.0, false), fit(2, 0.5, true)];
        let b = [fit(0, f64::NAN, false), fit(1, 3.0, false)];
        let w = worst_frames_by_residual(&[("a", &a), ("b", &b)], 3);
        let got: Vec<(&str, usize)> = w.iter().map(|w| (w.clip.as_str(), w.frame)).collect();
        assert_eq!(got, [("a", 2), ("b", 0), ("a", 1)]);
    }
}
