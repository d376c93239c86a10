//! Fitting a session's clips with the fit cache: refit only what the cache cannot give.

use super::error::Result;
use super::resources::{Resources, check_map_for_fit};
use super::session::image_height;
use crate::fit::{FitSettings, FrameFit, fit_clip, fitted_shape};
use crate::landmarks::FrameLandmarks;
use crate::math::DVector;
use crate::model::MorphableModel;
use crate::session::Session;

/// What fitting one clip did.
#[derive(Clone, Debug)]
pub struct ClipFits {
    /// One fit per frame with landmarks, ascending by frame.
    pub fits: Vec<FrameFit>,
    /// How many frames were fitted now (the rest came from the cache).
    pub refitted: usize,
}

impl ClipFits {
    pub fn failed(&self) -> usize {
        self.fits.iter().filter(|f| f.failed.is_some()).count()
    }
}

/// Fits clip `clip` with `settings`, refitting only what the cache cannot give: the stale
/// frames in per-frame mode, the whole clip in clip mode (its identity is shared, so one
/// changed frame changes them all). The new fits are stored in the session's cache.
/// `progress` receives (frames done, frames to do).
///
/// # Errors
/// Unknown clip; landmarks missing for a frame the cache names; a map the fit cannot use
/// ([`check_map_for_fit`]), before anything is fitted.
pub fn fit_clip_cached(
    session: &mut Session,
    res: &Resources,
    clip: usize,
    settings: &FitSettings,
    progress: Option<&(dyn Fn(usize, usize) + Sync)>,
) -> Result<ClipFits> {
    check_map_for_fit(&res.map, res.model.num_vertices(), settings)?;
    let stale = session.stale_frames_with(clip, settings);
    let height = image_height(session, clip)?;
    let track = session.fit_input_track(clip, settings)?;
    let to_fit: Vec<FrameLandmarks> = if stale.is_empty() {
        Vec::new()
    } else if settings.clip {
        track.frames.clone()
    } else {
        let stale: std::collections::BTreeSet<usize> = stale.into_iter().collect();
        track.frames.iter().filter(|f| stale.contains(&f.frame)).cloned().collect()
    };
    let refitted = to_fit.len();
    if refitted > 0 {
        let total = refitted;
        let report = |done: usize| {
            if let Some(p) = progress {
                p(done, total);
            }
        };
        let fits = fit_clip(&res.model, &res.map, &to_fit, height, settings, Some(&report));
        session.store_fits(clip, settings, fits)?;
    }
    let fits: Vec<FrameFit> = session.cached_fits(clip, settings).into_iter().cloned().collect();
    Ok(ClipFits { fits, refitted })
}

/// Fitted model-space shapes indexed by frame number (`None` for failed or missing fits),
/// `n_frames` long. Every shape is a whole mesh: for measures use
/// [`super::measure_fits::head_trajectory`], which keeps none.
pub fn shapes_by_frame(
    model: &MorphableModel,
    fits: &[FrameFit],
    n_frames: usize,
) -> Vec<Option<DVector>> {
    let mut shapes = vec![None; n_frames];
    for f in fits.iter().filter(|f| f.failed.is_none()) {
        if f.frame < n_frames {
            shapes[f.frame] = Some(fitted_shape(model, f));
        }
    }
    shapes
}

/// Longest stretch, in seconds, that the analyses learning from a clip's motion (SAQP's
/// corpus, the speech model's training) fill in from the neighbouring good fits. A phone
/// lasts about a tenth of a second: past a second the filled-in motion would span several
/// phones the video never showed, so such a clip is left out instead.
pub const MAX_FILLED_S: f64 = 1.0;

/// Why frames `0..n` of a clip at `fps` cannot be filled in from `good` (the ascending
/// frames with a usable fit): the longest run without one, named with its length, when it is
/// longer than [`MAX_FILLED_S`]; `None` when every run is short enough. Runs before the first
/// and after the last good frame count too. Nothing is allocated per frame, so a frame number
/// far past the clip's end costs nothing here.
pub fn unfillable_run(good: &[usize], n: usize, fps: f64) -> Option<String> {
    let (mut worst, mut start) = ((0usize, 0usize), 0usize);
    for &f in good.iter().filter(|&&f| f < n).chain(std::iter::once(&n)) {
        if f.saturating_sub(start) > worst.1 - worst.0 {
            worst = (start, f);
        }
        start = start.max(f + 1);
    }
    let (a, b) = worst;
    let seconds = (b - a) as f64 / fps;
    (seconds > MAX_FILLED_S).then(|| {
        format!(
            "frames {a}–{} ({seconds:.1} s) have no usable fit; at most {MAX_FILLED_S} s is \
             filled in from the neighbouring frames",
            b - 1
        )
    })
}

/// `n` fits, frame f's or, where it failed or is missing, the last good one before it (the
/// first good one for leading frames); `None` without any good fit.
pub fn held_fits(fits: &[FrameFit], n: usize) -> Option<Vec<FrameFit>> {
    let mut by_frame: Vec<Option<&FrameFit>> = vec![None; n];
    for f in fits.iter().filter(|f| f.failed.is_none() && f.frame < n) {
        by_frame[f.frame] = Some(f);
    }
    let first = by_frame.iter().flatten().next().copied()?;
    let mut last = first;
    Some(
        by_frame
            .iter()
            .enumerate()
            .map(|(frame, f)| {
                last = f.unwrap_or(last);
                FrameFit { frame, ..last.clone() }
            })
            .collect(),
    )
}

/// `n` fits, frame f's where it succeeded and is not in `skip` (ascending), else its
/// coefficients interpolated linearly between the nearest such frames on either side (held
/// at the clip's ends) with the pose of the frame's own fit when it has one (the held fit's
/// otherwise); `None` without any usable fit. When `skip` leaves none, it is ignored.
pub fn bridged_fits(fits: &[FrameFit], n: usize, skip: &[usize]) -> Option<Vec<FrameFit>> {
    let held = held_fits(fits, n)?;
    let good: Vec<usize> =
        fits.iter().filter(|f| f.failed.is_none() && f.frame < n).map(|f| f.frame).collect();
    let kept: Vec<usize> = good.iter().copied().filter(|f| skip.binary_search(f).is_err()).collect();
    let known = if kept.is_empty() { good } else { kept };
    let blend = |a: &[f64], b: &[f64], t: f64| -> Vec<f64> {
        a.iter().zip(b).map(|(x, y)| x * (1.0 - t) + y * t).collect()
    };
    Some(
        (0..n)
            .map(|f| {
                let after = known.partition_point(|&k| k < f);
                let (before, next) = (after.checked_sub(1).map(|i| known[i]), known.get(after).copied());
                let (a, b, t) = match (before, next) {
                    (_, Some(b)) if b == f => return held[f].clone(),
                    (Some(a), Some(b)) => (a, b, (f - a) as f64 / (b - a) as f64),
                    (Some(a), None) => (a, a, 0.0),
                    (None, Some(b)) => (b, b, 0.0),
                    (None, None) => return held[f].clone(),
                };
                FrameFit {
                    identity: blend(&held[a].identity, &held[b].identity, t),
                    expression: blend(&held[a].expression, &held[b].expression, t),
                    ..held[f].clone()
                }
            })
            .collect(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_longest_unfitted_run_is_named_when_longer_than_a_second() {
        // At 10 fps: frames 3–12 (1.0 s) are missing: short enough.
        assert_eq!(unfillable_run(&[0, 1, 2, 13], 14, 10.0), None);
        let why = unfillable_run(&[0, 1, 2, 14], 15, 10.0).unwrap();
        assert!(why.starts_with("frames 3–13 (1.1 s)"), "{why}");
        // Leading and trailing runs count; the worst is named.
        let why = unfillable_run(&[20, 21], 25, 10.0).unwrap();
        assert!(why.starts_with("frames 0–19 (2.0 s)"), "{why}");
        let why = unfillable_run(&[0], 1 << 20, 25.0).unwrap();
        assert!(why.starts_with("frames 1–1048575"), "{why}");
        // Frames past n are not fits of this clip.
        assert!(unfillable_run(&[0, 500], 5, 1.0).unwrap().starts_with("frames 1–4"));
        assert_eq!(unfillable_run(&[0, 1, 2], 3, 1.0), None);
    }

    #[test]
    fn discredited_frames_are_bridged_linearly_between_usable_ones() {
        let fit = |frame: usize, a: f64| FrameFit {
            identity: vec![a, 2.0 * a],
            failed: None,
            ..FrameFit::unposed(frame)
        };
        let fits = vec![fit(0, 0.0), fit(1, 9.0), fit(2, 9.0), fit(3, 3.0), fit(4, 5.0)];
        let b = bridged_fits(&fits, 6, &[1, 2]).unwrap();
        let ids: Vec<f64> = b.iter().map(|f| f.identity[0]).collect();
        assert_eq!(ids, vec![0.0, 1.0, 2.0, 3.0, 5.0, 5.0]);
        assert_eq!(b[2].identity[1], 4.0);
        assert_eq!(b.iter().map(|f| f.frame).collect::<Vec<_>>(), vec![0, 1, 2, 3, 4, 5]);
        // Skipping every good frame leaves them as they are.
        let all = bridged_fits(&fits, 5, &[0, 1, 2, 3, 4]).unwrap();
        assert_eq!(all[1].identity[0], 9.0);
        assert!(bridged_fits(&[], 3, &[]).is_none());
    }
}
