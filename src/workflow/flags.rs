//! Flagging a clip's frames as the TUI, `lipmap fit` and `lipmap eval` all do: the track's
//! own checks (`landmarks::flags`), the fits' residuals when there are fits, and the video's
//! W and H from the effective landmarks as measure series.

use crate::fit::FrameFit;
use crate::landmarks::Track;
use crate::landmarks::flags::{FlagReason, FlagThresholds, FrameFlags, MeasureSeries, flag_frames};
use crate::measure::Measure;
use crate::session::{Session, SessionError};

/// The video's W and H per frame (from `track`) as flaggable series named "video W"/"video H".
pub fn video_measures(track: &Track) -> Vec<MeasureSeries> {
    let t = crate::measure::mouth::trajectory_from_track(track, None);
    [Measure::W, Measure::H]
        .into_iter()
        .map(|m| MeasureSeries {
            name: format!("video {}", m.as_str()),
            values: t.series(m).iter().enumerate().filter_map(|(f, v)| v.map(|v| (f, v))).collect(),
        })
        .collect()
}

/// The flags of a clip from its effective landmarks, its fits when given (an empty slice
/// counts as none) and any `extra` measure series besides the video's W and H.
pub fn clip_flags(
    track: &Track,
    fits: &[FrameFit],
    extra: &[MeasureSeries],
    thresholds: &FlagThresholds,
) -> Vec<FrameFlags> {
    let mut measures = video_measures(track);
    measures.extend(extra.iter().cloned());
    let fits = (!fits.is_empty()).then_some(fits);
    flag_frames(track, fits, &measures, thresholds)
}

/// Lines summarising `flags` of clip `name` over `n_frames` frames: a count, then one line
/// per flagged frame with its reasons. Failed fits are left out: the fit's own summary
/// reports them, once per reason.
pub fn flag_lines(name: &str, flags: &[FrameFlags], n_frames: usize) -> Vec<String> {
    let flags: Vec<(usize, Vec<String>)> = flags
        .iter()
        .map(|f| {
            let reasons = f
                .reasons
                .iter()
                .filter(|r| !matches!(r, FlagReason::FitFailed { .. }))
                .map(ToString::to_string)
                .collect();
            (f.frame, reasons)
        })
        .filter(|(_, reasons): &(usize, Vec<String>)| !reasons.is_empty())
        .collect();
    let pct = if n_frames == 0 { 0.0 } else { 100.0 * flags.len() as f64 / n_frames as f64 };
    let mut lines =
        vec![format!("{name}: {} of {n_frames} frames flagged ({pct:.1} %)", flags.len())];
    for (frame, reasons) in flags {
        lines.push(format!("{name}: frame {frame}: {}", reasons.join("; ")));
    }
    lines
}

/// [`flag_lines`] of clip `clip` of `session` from its effective landmarks and `fits`.
///
/// # Errors
/// Unknown clip.
pub fn clip_flag_lines(
    session: &Session,
    clip: usize,
    fits: &[FrameFit],
) -> Result<Vec<String>, SessionError> {
    let track = session.effective_track(clip)?;
    let flags = clip_flags(&track, fits, &[], &FlagThresholds::default());
    Ok(flag_lines(&session.clip(clip)?.name, &flags, track.len()))
}
