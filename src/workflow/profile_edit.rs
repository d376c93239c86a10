//! Editing a clip's side-view protrusion setup and its hand corrections, then measuring P:
//! the use case behind `lipmap profile` (the TUI's side view edits the same session fields).
//!
//! Start with [`edit_profiles`]: overrides laid over the stored (or proposed) setup, the
//! setup stored, corrections set or dropped, and the side-view points of every front frame.

use super::error::{Error, Result, Warning};
use super::session::clip_length;
use super::side_view::{
    PROFILE_SETUP_KEY, SidePoint, check_setup_in_frame, profile_setup, side_view_points,
};
use crate::math::Point2;
use crate::measure::profile::{Facing, NoseLength, ProfileSetup, Rect, ReferenceLine, Threshold};
use crate::session::Session;

/// Values laid over a clip's setup; `None` keeps the stored one.
#[derive(Clone, Debug, Default)]
pub struct ProfileOverrides {
    /// Forget the stored setup and propose a new one from the first side frame.
    pub reset: bool,
    /// Mouth crop in side-view pixels: x, y, width, height.
    pub crop: Option<[u32; 4]>,
    /// Reference line parallel to the frontal plane (side-view pixels).
    pub line: Option<(Point2, Point2)>,
    pub facing: Option<Facing>,
    /// Fixed gray-level threshold instead of Otsu's.
    pub threshold: Option<u8>,
    /// Nose-root to nose-tip length in pixels.
    pub nose_px: Option<f64>,
}

/// Hand corrections of side-view frames' upper-lip points (side-view pixels).
#[derive(Clone, Debug, Default)]
pub struct ProfileCorrections {
    pub correct: Vec<(usize, Point2)>,
    pub uncorrect: Vec<usize>,
}

impl ProfileCorrections {
    pub fn is_empty(&self) -> bool {
        self.correct.is_empty() && self.uncorrect.is_empty()
    }
}

/// One clip's measured side view after the edit.
#[derive(Clone, Debug)]
pub struct ClipProfile {
    pub clip: usize,
    pub name: String,
    pub setup: ProfileSetup,
    /// One per front frame.
    pub points: Vec<SidePoint>,
    /// Side-view frames corrected by hand.
    pub corrected: usize,
}

impl ClipProfile {
    /// Front frames with a P value.
    pub fn measured(&self) -> usize {
        self.points.iter().filter(|p| p.p().is_some()).count()
    }
}

/// What [`edit_profiles`] did.
#[derive(Clone, Debug, Default)]
pub struct ProfileEdit {
    pub clips: Vec<ClipProfile>,
    pub warnings: Vec<Warning>,
}

/// Lays `overrides` over the setup of each clip of `clips` that has a side view, stores it,
/// applies `corrections`, and measures the side view at every front frame. The session is
/// changed in memory; the caller saves it.
///
/// # Errors
/// An override or correction that cannot be meant (checked before anything changes): a crop
/// without area, a line of one point, a nose length that is not positive, corrections with
/// several side views selected, a frame both corrected and uncorrected, a side-view frame
/// that does not exist.
pub fn edit_profiles(
    session: &mut Session,
    clips: &[usize],
    overrides: &ProfileOverrides,
    corrections: &ProfileCorrections,
) -> Result<ProfileEdit> {
    check_overrides(overrides)?;
    if !corrections.is_empty() {
        check_corrections(session, clips, corrections)?;
    }
    let mut edit = ProfileEdit::default();
    for &c in clips {
        let name = session.clip(c)?.name.clone();
        if session.clips[c].side.is_none() {
            edit.warnings.push(Warning(format!("lipmap: clip `{name}` has no side view; skipped")));
            continue;
        }
        if overrides.reset {
            session.clips[c].extensions.remove(PROFILE_SETUP_KEY);
        }
        let mut setup = profile_setup(session, c)?;
        apply_overrides(&mut setup, overrides);
        check_setup_in_frame(session, c, &setup)?;
        let value = serde_json::to_value(&setup).map_err(|e| Error::Invalid(e.to_string()))?;
        session.clips[c].extensions.insert(PROFILE_SETUP_KEY.into(), value);
        if !corrections.is_empty() {
            let n_side = session.open_side_frames(c, 1)?.map_or(0, |f| f.len());
            for &(f, _) in &corrections.correct {
                if f >= n_side {
                    return Err(Error::Invalid(format!(
                        "--correct: side-view frame {f} does not exist ({n_side} frames)"
                    )));
                }
            }
            for &f in &corrections.uncorrect {
                if session.clear_profile_correction(c, f)?.is_none() {
                    edit.warnings
                        .push(Warning(format!("lipmap: side-view frame {f} had no correction")));
                }
            }
            for &(f, p) in &corrections.correct {
                session.set_profile_correction(c, f, p)?;
            }
        }
        let n = clip_length(session, c)?;
        let Some((setup, points)) = side_view_points(session, c, n)? else { continue };
        let corrected = session.clips[c].profile_corrections.len();
        edit.clips.push(ClipProfile { clip: c, name, setup, points, corrected });
    }
    Ok(edit)
}

fn check_overrides(o: &ProfileOverrides) -> Result<()> {
    let bad = |m: String| Err(Error::Invalid(m));
    if let Some(c) = o.crop
        && (c[2] == 0 || c[3] == 0)
    {
        return bad(format!("--crop needs a positive width and height, got {c:?}"));
    }
    if let Some((p, q)) = o.line
        && ((p - q).norm() < 1e-9
            || !(p.x.is_finite() && p.y.is_finite() && q.x.is_finite() && q.y.is_finite()))
    {
        return bad(format!("--line needs two distinct finite points, got {p:?} and {q:?}"));
    }
    if let Some(n) = o.nose_px
        && !(n.is_finite() && n > 0.0)
    {
        return bad(format!("--nose-px must be a positive length, got {n}"));
    }
    Ok(())
}

/// Refuses corrections that could land on the wrong clip or contradict each other, before
/// anything is changed.
fn check_corrections(session: &Session, clips: &[usize], c: &ProfileCorrections) -> Result<()> {
    let bad = |m: String| Err(Error::Invalid(m));
    let with_side = clips.iter().filter(|&&k| session.clips[k].side.is_some()).count();
    if with_side == 0 {
        return bad("--correct/--uncorrect: no selected clip has a side view".into());
    }
    if with_side > 1 {
        return bad(format!(
            "--correct/--uncorrect: {with_side} clips have a side view; choose one with --clip"
        ));
    }
    if let Some(&(f, _)) = c.correct.iter().find(|(f, _)| c.uncorrect.contains(f)) {
        return bad(format!("side-view frame {f} is both corrected and uncorrected"));
    }
    Ok(())
}

fn apply_overrides(setup: &mut ProfileSetup, o: &ProfileOverrides) {
    if let Some(c) = o.crop {
        setup.crop = Rect::new(c[0], c[1], c[2], c[3]);
    }
    if let Some((a, b)) = o.line {
        setup.reference_line = ReferenceLine { a, b };
    }
    if let Some(f) = o.facing {
        setup.facing = f;
    }
    if let Some(t) = o.threshold {
        setup.threshold = Threshold::Manual(t);
    }
    if let Some(n) = o.nose_px {
        setup.nose = NoseLength::Px(n);
    }
}

/// Why no frame of any clip has a P value, as one line (`None` when some frame has one, or
/// when no clip was measured): the reasons the side view's points failed, most common first.
pub fn all_failed_reason(edit: &ProfileEdit) -> Option<String> {
    all_failed_in(edit.clips.iter().map(|c| c.points.as_slice()))
}

fn all_failed_in<'a>(clips: impl Iterator<Item = &'a [SidePoint]> + Clone) -> Option<String> {
    let mut any = false;
    let mut reasons = std::collections::BTreeMap::<&str, usize>::new();
    for points in clips {
        any = true;
        for p in points {
            if p.p().is_some() {
                return None;
            }
            let why = p.point.as_ref().and_then(|q| q.failed.as_deref()).unwrap_or("no side frame");
            *reasons.entry(why).or_default() += 1;
        }
    }
    if !any {
        return None;
    }
    let mut reasons: Vec<(&str, usize)> = reasons.into_iter().collect();
    reasons.sort_by_key(|r| std::cmp::Reverse(r.1));
    let list: Vec<String> = reasons.iter().map(|(w, n)| format!("{n}× {w}")).collect();
    Some(format!("no side-view frame gave a lip point ({})", list.join("; ")))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn overrides_that_cannot_be_meant_are_refused() {
        let o = ProfileOverrides { crop: Some([0, 0, 0, 5]), ..Default::default() };
        assert!(check_overrides(&o).unwrap_err().to_string().contains("--crop"));
        let p = Point2::new(1.0, 1.0);
        let o = ProfileOverrides { line: Some((p, p)), ..Default::default() };
        assert!(check_overrides(&o).unwrap_err().to_string().contains("--line"));
        let o = ProfileOverrides { nose_px: Some(-1.0), ..Default::default() };
        assert!(check_overrides(&o).unwrap_err().to_string().contains("--nose-px"));
        let o = ProfileOverrides {
            crop: Some([1, 2, 3, 4]),
            nose_px: Some(30.0),
            ..Default::default()
        };
        assert!(check_overrides(&o).is_ok());
    }

    #[test]
    fn every_frame_failed_gives_one_line_with_the_reasons() {
        let failed = |why: &str| SidePoint {
            side_frame: Some(0),
            point: Some(crate::measure::profile::ProfilePoint {
                frame: 0,
                upper_lip_px: None,
                p_px: None,
                p_norm: None,
                source: Default::default(),
                motion: None,
                failed: Some(why.into()),
            }),
        };
        let points = vec![failed("no lip"), failed("no lip"), failed("dark")];
        let line = all_failed_in([points.as_slice()].into_iter()).unwrap();
        assert_eq!(line, "no side-view frame gave a lip point (2× no lip; 1× dark)");
        assert!(all_failed_reason(&ProfileEdit::default()).is_none());
    }
}
