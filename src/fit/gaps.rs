//! Filling the frames of a clip that have no usable fit, for the analyses that learn from a
//! clip's motion frame by frame (SAQP's corpus, the speech model's training): the one policy
//! both use.
//!
//! The policy: a frame without a usable fit (failed, missing, or left out by the caller)
//! takes the shape coefficients (identity α and expression β) interpolated linearly between
//! the nearest usable frames on either side, and those of the nearest one before the first
//! and after the last. Linear in the coefficients is linear in the shape (`S = m + B·α`), so
//! a bridged mouth moves straight from one fitted shape to the next instead of freezing and
//! jumping. Only short runs are filled: a phone lasts about a tenth of a second, and past
//! [`MAX_FILLED_S`] the filled-in motion would span phones the video never showed, so such a
//! clip is refused ([`GapError::TooLong`]) rather than invented.

use super::FrameFit;

/// Longest run, in seconds, filled in from the neighbouring usable fits.
pub const MAX_FILLED_S: f64 = 1.0;

/// Why a clip's frames cannot be filled in.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum GapError {
    /// No frame has a usable fit.
    #[error("has no successful fit")]
    NoUsableFit,
    /// The longest run without a usable fit, frames `first..=last`, is longer than
    /// [`MAX_FILLED_S`].
    #[error(
        "frames {first}–{last} ({seconds:.1} s) have no usable fit; at most {MAX_FILLED_S} s is \
         filled in from the neighbouring frames"
    )]
    TooLong { first: usize, last: usize, seconds: f64 },
}

/// A clip's fits with every frame filled in.
#[derive(Clone, Debug, PartialEq)]
pub struct Filled {
    /// One fit per frame `0..n`, in order. A filled frame has the interpolated coefficients,
    /// the pose of the usable frame before it (after it, for leading frames), no residuals
    /// and no failure.
    pub fits: Vec<FrameFit>,
    /// How many frames were filled in.
    pub filled: usize,
}

/// Fills frames `0..n` of a clip at `fps` from `fits` by the module's policy. Frames listed
/// in `skip` are treated as unusable too, unless that would leave no usable frame (then
/// `skip` is ignored). A run too long to fill is found before anything is allocated per
/// frame, so a frame number far past the clip's end costs nothing.
///
/// # Errors
/// [`GapError::NoUsableFit`]; [`GapError::TooLong`] naming the longest run.
pub fn fill_gaps(
    fits: &[FrameFit],
    n: usize,
    fps: f64,
    skip: &[usize],
) -> Result<Filled, GapError> {
    let good: Vec<&FrameFit> = {
        let mut g: Vec<&FrameFit> = fits.iter().filter(|f| f.is_usable_within(n)).collect();
        g.sort_by_key(|f| f.frame);
        g.dedup_by_key(|f| f.frame);
        g
    };
    if good.is_empty() {
        return Err(GapError::NoUsableFit);
    }
    let skip: std::collections::HashSet<usize> = skip.iter().copied().collect();
    let kept: Vec<&FrameFit> = good.iter().copied().filter(|f| !skip.contains(&f.frame)).collect();
    let known = if kept.is_empty() { good } else { kept };
    let frames: Vec<usize> = known.iter().map(|f| f.frame).collect();
    if let Some(e) = longest_gap(&frames, n, fps) {
        return Err(e);
    }
    let out = (0..n)
        .map(|frame| {
            let after = frames.partition_point(|&k| k < frame);
            match (after.checked_sub(1).map(|i| known[i]), known.get(after).copied()) {
                (_, Some(b)) if b.frame == frame => b.clone(),
                (Some(a), Some(b)) => {
                    let t = (frame - a.frame) as f64 / (b.frame - a.frame) as f64;
                    FrameFit {
                        identity: lerp(&a.identity, &b.identity, t),
                        expression: lerp(&a.expression, &b.expression, t),
                        ..filled_from(a, frame)
                    }
                }
                (Some(a), None) => filled_from(a, frame),
                (None, Some(b)) => filled_from(b, frame),
                (None, None) => unreachable!("some frame is usable"),
            }
        })
        .collect();
    Ok(Filled { fits: out, filled: n - known.len() })
}

/// Frame `frame` filled in with `from`'s pose and coefficients.
fn filled_from(from: &FrameFit, frame: usize) -> FrameFit {
    FrameFit { frame, residuals: Vec::new(), ..from.clone() }
}

/// `(1 − t)·a + t·b`, element by element.
fn lerp(a: &[f64], b: &[f64], t: f64) -> Vec<f64> {
    a.iter().zip(b).map(|(x, y)| x * (1.0 - t) + y * t).collect()
}

/// The longest run of frames in `0..n` without one of the ascending `good` frames (runs
/// before the first and after the last count too), as an error when it is longer than
/// [`MAX_FILLED_S`] at `fps`.
fn longest_gap(good: &[usize], n: usize, fps: f64) -> Option<GapError> {
    let (mut worst, mut start) = ((0usize, 0usize), 0usize);
    for &f in good.iter().filter(|&&f| f < n).chain(std::iter::once(&n)) {
        if f.saturating_sub(start) > worst.1 - worst.0 {
            worst = (start, f);
        }
        start = start.max(f + 1);
    }
    let (a, b) = worst;
    let seconds = (b - a) as f64 / fps;
    // Lazily: with no gap at all, `b` is 0.
    (seconds > MAX_FILLED_S).then(|| GapError::TooLong { first: a, last: b - 1, seconds })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fit(frame: usize, value: f64) -> FrameFit {
        FrameFit { identity: vec![1.0], expression: vec![value], ..FrameFit::unposed(frame) }
    }

    fn values(filled: &Filled) -> Vec<f64> {
        filled.fits.iter().map(|f| f.expression[0]).collect()
    }

    #[test]
    fn skipped_and_failed_frames_are_bridged_linearly_and_held_at_the_ends() {
        let mut fits: Vec<FrameFit> =
            [(0, 9.0), (1, 0.0), (2, 2.0), (3, 50.0), (4, 6.0)].map(|(f, v)| fit(f, v)).to_vec();
        fits[1].failed = Some("too few landmarks".into());
        // Frame 5 is missing from the fits; frame 3 is skipped, frame 0 too.
        let filled = fill_gaps(&fits, 7, 25.0, &[0, 3]).unwrap();
        assert_eq!(values(&filled), vec![2.0, 2.0, 2.0, 4.0, 6.0, 6.0, 6.0]);
        assert_eq!(filled.filled, 5);
        assert!(filled.fits.iter().all(|f| f.identity == [1.0] && f.is_usable()));
        assert_eq!(filled.fits.iter().map(|f| f.frame).collect::<Vec<_>>(), [0, 1, 2, 3, 4, 5, 6]);
        // A skip list that would leave nothing is ignored; no usable fit at all is an error.
        let filled = fill_gaps(&fits[..1], 2, 25.0, &[0]).unwrap();
        assert_eq!((values(&filled), filled.filled), (vec![9.0, 9.0], 1));
        fits.iter_mut().for_each(|f| f.failed = Some("x".into()));
        assert_eq!(fill_gaps(&fits, 5, 25.0, &[]), Err(GapError::NoUsableFit));
    }

    #[test]
    fn a_gap_longer_than_a_second_is_not_filled() {
        let fits: Vec<FrameFit> = [0, 1, 27].map(|f| fit(f, 1.0)).to_vec();
        // 25 missing frames at 25 fps are a second: filled.
        assert!(fill_gaps(&fits, 28, 25.0, &[]).is_ok());
        // One more, or a skipped frame that widens the gap, is not.
        let e = fill_gaps(&fits, 28, 24.0, &[]).unwrap_err();
        assert!(e.to_string().starts_with("frames 2–26 (1.0 s)"), "{e}");
        assert!(fill_gaps(&fits, 28, 25.0, &[1]).is_err());
        // Leading and trailing runs count; a last frame far past the fits (a hand-edited
        // session) is refused at once.
        let e = fill_gaps(&fits[2..], 30, 10.0, &[]).unwrap_err();
        assert!(e.to_string().starts_with("frames 0–26 (2.7 s)"), "{e}");
        let e = fill_gaps(&fits, 1 << 20, 25.0, &[]).unwrap_err();
        assert!(e.to_string().starts_with("frames 28–1048575"), "{e}");
        // Nothing to fill: the fits as they are.
        let all = fill_gaps(&fits[..2], 2, 1.0, &[]).unwrap();
        assert_eq!((all.fits, all.filled), (fits[..2].to_vec(), 0));
        // Fits past n are not frames of this clip.
        let e = fill_gaps(&[fit(0, 1.0), fit(500, 1.0)], 5, 1.0, &[]).unwrap_err();
        assert_eq!(e, GapError::TooLong { first: 1, last: 4, seconds: 4.0 });
    }
}
