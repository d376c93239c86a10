//! Flagging a clip's frames as the TUI, `lipmap fit` and `lipmap eval` all do: the track's
//! own checks (`landmarks::flags`), the fits' residuals when there are fits, the video's
//! W and H from the effective landmarks as measure series, and (where the frames can be read)
//! what the frames show where the tracker put the lips (`clip_image_flags`).

use crate::fit::FrameFit;
use crate::landmarks::Track;
use crate::landmarks::flags::{
    FlagReason, FlagThresholds, FrameFlags, MeasureSeries, add_reasons, flag_frames, image_flags,
};
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

/// Decoded frames a clip's image checks may keep at once (MB): they read each frame once.
const IMAGE_CACHE_MB: usize = 32;

/// The image-evidence flags of clip `clip` of `session` for its landmarks `track`
/// (`landmarks::flags::image_flags`), read from the clip's frames; `None` when the frames
/// cannot be opened (the reason), and frames that cannot be decoded give no flag.
pub fn clip_image_flags(
    session: &Session,
    clip: usize,
    track: &Track,
    thresholds: &FlagThresholds,
) -> Result<Vec<(usize, FlagReason)>, String> {
    let frames = session.open_frames(clip, IMAGE_CACHE_MB).map_err(|e| e.to_string())?;
    Ok(image_flags(track, |f| frames.get(f).ok(), thresholds))
}

/// [`flag_lines`] of clip `clip` of `session` from its effective landmarks, `fits` and the
/// image evidence of its frames ([`clip_image_flags`]); when the frames cannot be read, a
/// line says the image checks were skipped and why.
///
/// # Errors
/// Unknown clip.
pub fn clip_flag_lines(
    session: &Session,
    clip: usize,
    fits: &[FrameFit],
) -> Result<Vec<String>, SessionError> {
    let track = session.effective_track(clip)?;
    let name = &session.clip(clip)?.name;
    let thresholds = FlagThresholds::default();
    let mut flags = clip_flags(&track, fits, &[], &thresholds);
    let skipped = match clip_image_flags(session, clip, &track, &thresholds) {
        Ok(found) => {
            add_reasons(&mut flags, found);
            None
        }
        Err(why) => Some(format!("{name}: image checks skipped: {why}")),
    };
    let mut lines = flag_lines(name, &flags, track.len());
    lines.extend(skipped);
    Ok(lines)
}
