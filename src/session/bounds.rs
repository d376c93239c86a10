//! Bounds on the values a session file carries: frame numbers, frame rates, sizes, phone
//! times and fit settings. A session is passed between people and edited by hand, so it is
//! untrusted input; every number that later sizes a table or a loop is checked here, once,
//! when the file is loaded (and before it is saved), with a message naming the field.
//!
//! The rules themselves live with the values they bound: `landmarks::MAX_FRAME`,
//! `io::frames::{FPS_RANGE, MAX_IMAGE_SIDE}`, `Alignment::check_times`.

use super::model::{Clip, Session, View};
use crate::fit::FitSettings;
use crate::io::frames::{MAX_IMAGE_SIDE, check_fps_value};
use crate::landmarks::{MAX_COORDINATE_PX, MAX_FRAME, N_LANDMARKS, point_out_of_bounds};
use crate::math::short_number;

/// Most camera/shape alternations a session may ask for; each is a full solve per frame.
pub const MAX_ITERATIONS: usize = 1000;

/// Checks every bounded value of `session`.
///
/// # Errors
/// A message naming the clip and field at fault.
pub fn check_values(session: &Session) -> Result<(), String> {
    check_fit_settings(&session.fit_settings).map_err(|m| format!("fit_settings: {m}"))?;
    for clip in &session.clips {
        check_clip(clip).map_err(|m| format!("clip {:?}: {m}", clip.name))?;
    }
    Ok(())
}

/// The frames clip `clip` spans: up to its last tracked, corrected, reviewed or
/// profile-corrected frame, or its last phone's end. At most [`MAX_FRAME`] + 1 (12 hours at
/// 24 fps): a clip's analyses hold a few values per frame of its span, and the uses cases
/// work clip by clip, so this per-clip bound is what keeps a small hand-edited file from
/// sizing gigabytes through frame numbers alone, however many clips a session has.
pub fn clip_span(clip: &Clip) -> usize {
    let last = [
        clip.tracked_summary().last_frame,
        clip.corrections.points.keys().next_back().copied(),
        clip.corrections.reviewed.iter().next_back().copied(),
        clip.profile_corrections.keys().next_back().copied(),
    ];
    let frames = last.into_iter().flatten().max().map_or(0, |f| f + 1);
    let end = clip.alignment.iter().flat_map(|a| &a.phones).fold(0.0, |m: f64, p| m.max(p.end));
    let phones = (end * clip.front.fps).ceil();
    // Bounded by the per-clip checks; `as` saturates on anything else.
    frames.max(phones as usize)
}

/// The one rule for a tracked frame, inline in a session or in its track file: 68 points,
/// a frame number lipmap accepts, finite timestamp and confidences, coordinates within
/// ±[`MAX_COORDINATE_PX`].
///
/// # Errors
/// A message naming the point or field.
pub fn check_tracked_frame(f: &crate::landmarks::FrameLandmarks) -> Result<(), String> {
    if f.points.len() != N_LANDMARKS {
        return Err(format!("has {} points, not {N_LANDMARKS}", f.points.len()));
    }
    if f.frame > MAX_FRAME {
        return Err(format!("{PAST} ({MAX_FRAME})"));
    }
    if f.timestamp.is_some_and(|t| !t.is_finite())
        || f.confidence.is_some_and(|v| !v.is_finite())
        || f.rerun_disagreement.is_some_and(|v| !v.is_finite())
    {
        return Err("has a non-finite timestamp, confidence or rerun_disagreement".into());
    }
    if let Some(i) = f.points.iter().position(|p| p.confidence.is_some_and(|v| !v.is_finite())) {
        return Err(format!("point {}: confidence is not finite", crate::landmarks::PointNo(i)));
    }
    point_out_of_bounds(f).map_or(Ok(()), Err)
}

/// The one rule for a clip's cached fits: each entry as [`check_settings_frames`] says, and
/// at most [`super::cache::MAX_CACHED_SETTINGS_PER_CLIP`] of them.
///
/// # Errors
/// A message naming the entry's frame and field.
pub fn check_cache_entries(entries: &[super::FitCacheEntry]) -> Result<(), String> {
    let most = super::cache::MAX_CACHED_SETTINGS_PER_CLIP;
    if entries.len() > most {
        return Err(format!("{} cached fit settings, more than {most}", entries.len()));
    }
    entries.iter().try_for_each(check_settings_frames)
}

/// One cache entry: settings within bounds, frames lipmap accepts, finite fits (JSON and
/// the fits file hold no NaN), and coefficient counts that agree.
///
/// # Errors
/// A message naming the frame and field.
pub(crate) fn check_settings_frames(e: &super::FitCacheEntry) -> Result<(), String> {
    check_fit_settings(&e.settings).map_err(|m| format!("cached fit settings: {m}"))?;
    if let Some(f) = e.frames.iter().find(|f| f.fit.frame > MAX_FRAME) {
        return Err(format!("cached fit of frame {} {}", f.fit.frame, PAST));
    }
    if let Some(f) = e.frames.iter().find(|f| super::cache::storable_fit(f.fit.clone()) != f.fit) {
        return Err(format!("cached fit of frame {} has non-finite values", f.fit.frame));
    }
    // One model fitted every frame of an entry, so its good fits agree on their coefficient
    // counts; whether those match the model is checked where the model is loaded.
    let mut good = e.frames.iter().map(|f| &f.fit).filter(|f| f.is_usable());
    if let Some(first) = good.next() {
        let counts = (first.identity.len(), first.expression.len());
        if let Some(f) = good.find(|f| (f.identity.len(), f.expression.len()) != counts) {
            return Err(format!(
                "cached fit of frame {} has {} identity and {} expression coefficients where \
                 frame {} has {} and {}",
                f.frame,
                f.identity.len(),
                f.expression.len(),
                first.frame,
                counts.0,
                counts.1
            ));
        }
    }
    Ok(())
}

const PAST: &str = "is past the largest frame lipmap accepts";

fn check_frame(what: &str, frame: Option<usize>) -> Result<(), String> {
    match frame {
        Some(f) if f > MAX_FRAME => Err(format!("{what} {f} {PAST} ({MAX_FRAME})")),
        _ => Ok(()),
    }
}

fn check_clip(clip: &Clip) -> Result<(), String> {
    check_view(&clip.front).map_err(|m| format!("front: {m}"))?;
    if let Some(side) = &clip.side {
        check_view(side).map_err(|m| format!("side: {m}"))?;
    }
    // Frame keys are sorted: the last is the largest. Tracked frames are checked one by one
    // in memory (`Session::validate`) and when their file is read.
    check_frame("tracked frame", clip.tracked_summary().last_frame)?;
    let far = |v: f64| !(v.is_finite() && v.abs() <= MAX_COORDINATE_PX);
    for (frame, points) in &clip.corrections.points {
        if let Some((i, p)) = points.iter().find(|(_, p)| far(p.x) || far(p.y)) {
            return Err(format!(
                "correction of frame {frame} point {}: ({}, {}) is not within \
                 ±{MAX_COORDINATE_PX:e} px",
                crate::landmarks::PointNo(*i),
                short_number(p.x),
                short_number(p.y)
            ));
        }
    }
    check_frame("correction of frame", clip.corrections.points.keys().next_back().copied())?;
    check_frame("reviewed frame", clip.corrections.reviewed.iter().next_back().copied())?;
    check_frame(
        "profile correction of frame",
        clip.profile_corrections.keys().next_back().copied(),
    )?;
    if let Some(a) = &clip.audio {
        check_audio(a).map_err(|m| format!("audio: {m}"))?;
    }
    if let Some(a) = &clip.alignment {
        // A phone past the last frame lipmap accepts at this clip's rate would size the
        // per-frame phone table beyond it.
        let max_end = (MAX_FRAME + 1) as f64 / clip.front.fps;
        a.check_times(max_end).map_err(|m| format!("alignment: {m}"))?;
    }
    Ok(())
}

fn check_audio(a: &super::ClipAudio) -> Result<(), String> {
    let max = crate::io::wav::MAX_SAMPLE_RATE_HZ;
    if !(1..=max).contains(&a.sample_rate) {
        return Err(format!("sample_rate {} Hz is not within 1–{max} Hz", a.sample_rate));
    }
    if a.channels == 0 {
        return Err("channels is 0".into());
    }
    let max_offset = MAX_FRAME as f64;
    if !(a.offset_s.is_finite() && a.offset_s.abs() <= max_offset) {
        return Err(format!("offset_s {} is not within ±{max_offset} s", short_number(a.offset_s)));
    }
    Ok(())
}

fn check_view(v: &View) -> Result<(), String> {
    check_fps_value(v.fps).map_err(|m| format!("fps: {m}"))?;
    // Front and side views are cut from one recording session: an offset longer than the
    // longest clip is a corrupt file.
    let max_offset = MAX_FRAME as f64;
    if !(v.offset_s.is_finite() && v.offset_s.abs() <= max_offset) {
        return Err(format!("offset_s {} is not within ±{max_offset} s", short_number(v.offset_s)));
    }
    if let Some([w, h]) = v.size
        && !((1..=MAX_IMAGE_SIDE).contains(&w) && (1..=MAX_IMAGE_SIDE).contains(&h))
    {
        return Err(format!("size {w}×{h} is outside 1–{MAX_IMAGE_SIDE} px"));
    }
    Ok(())
}

/// The one rule for fit settings, wherever they come from (a session, flags): prior weights
/// and the smoothness weight finite and ≥ 0, a positive failure threshold, a tolerance in
/// [0, 1), at most [`MAX_ITERATIONS`] alternations and one weight per iBUG landmark.
///
/// # Errors
/// A message naming the field.
pub fn check_fit_settings(s: &FitSettings) -> Result<(), String> {
    let non_negative = [
        ("lambda", s.lambda),
        ("lambda_expression", s.lambda_expression),
        ("temporal_smoothness", s.temporal_smoothness),
    ];
    for (name, v) in non_negative {
        if !(v.is_finite() && v >= 0.0) {
            return Err(format!("{name} {} must be finite and ≥ 0", short_number(v)));
        }
    }
    if !(s.max_reproj_rms_px.is_finite() && s.max_reproj_rms_px > 0.0) {
        return Err(format!(
            "max_reproj_rms_px {} must be finite and > 0",
            short_number(s.max_reproj_rms_px)
        ));
    }
    if !(s.convergence_tolerance.is_finite() && (0.0..1.0).contains(&s.convergence_tolerance)) {
        return Err(format!("convergence_tolerance {} must be in [0, 1)", s.convergence_tolerance));
    }
    if s.iterations > MAX_ITERATIONS {
        return Err(format!("iterations {} is more than {MAX_ITERATIONS}", s.iterations));
    }
    if s.solver.pose_refinement_steps() > MAX_ITERATIONS {
        return Err(format!(
            "pose_refinement_steps {} is more than {MAX_ITERATIONS}",
            s.solver.pose_refinement_steps()
        ));
    }
    let w = &s.landmark_weights;
    if w.len() > N_LANDMARKS {
        return Err(format!(
            "landmark_weights has {} entries; there are {N_LANDMARKS} landmarks",
            w.len()
        ));
    }
    if let Some((i, v)) = w.iter().enumerate().find(|(_, v)| !(v.is_finite() && **v >= 0.0)) {
        return Err(format!("landmark_weights[{i}] {} must be finite and ≥ 0", short_number(*v)));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::session::{FramesRef, Session};

    fn session_with_clip() -> Session {
        let mut s = Session::new(std::path::Path::new("/tmp/x.lipmap.json"));
        let view = View::new(FramesRef::Images { dir: "/tmp/frames".into() }, 25.0);
        s.clips.push(Clip::new("a", view));
        s
    }

    #[test]
    fn a_plain_session_passes() {
        assert_eq!(check_values(&session_with_clip()), Ok(()));
    }

    fn refused(field: &str, edit: impl Fn(&mut Session)) {
        let mut s = session_with_clip();
        edit(&mut s);
        let err = s.validate().expect_err(field);
        assert!(err.contains(field), "{field}: {err}");
        assert!(!err.contains('\n'), "one line: {err}");
    }

    fn phones(s: &mut Session, start: f64, end: f64) {
        let phone = crate::alignment::Phone { start, end, label: "AA".into() };
        s.clips[0].alignment = Some(crate::alignment::Alignment { phones: vec![phone] });
    }

    #[test]
    fn cached_fits_of_one_entry_agree_on_coefficient_counts() {
        let fit = |frame: usize, identity: usize| {
            let mut f = crate::fit::FrameFit::unposed(frame);
            f.failed = None;
            f.identity = vec![0.0; identity];
            f.expression = vec![0.0; 2];
            super::super::CachedFrame { input: String::new(), fit: f }
        };
        let entry = |frames| super::super::FitCacheEntry {
            settings: Default::default(),
            context: String::new(),
            clip_input: None,
            frames,
        };
        assert_eq!(check_cache_entries(&[entry(vec![fit(0, 3), fit(1, 3)])]), Ok(()));
        let err = check_cache_entries(&[entry(vec![fit(0, 3), fit(1, 0)])]).unwrap_err();
        assert!(err.contains("frame 1 has 0 identity"), "{err}");
        let mut nan = fit(1, 3);
        nan.fit.tx = f64::NAN;
        let err = check_cache_entries(&[entry(vec![fit(0, 3), nan])]).unwrap_err();
        assert!(err.contains("frame 1 has non-finite values"), "{err}");
    }

    #[test]
    fn each_bound_names_its_field() {
        refused("fps", |s| s.clips[0].front.fps = 1e20);
        refused("fps", |s| s.clips[0].front.fps = 1e-300);
        refused("size", |s| s.clips[0].front.size = Some([4_000_000_000, 10]));
        refused("offset_s", |s| s.clips[0].front.offset_s = 1e300);
        refused("lambda", |s| s.fit_settings.lambda = -1.0);
        refused("lambda_expression", |s| s.fit_settings.lambda_expression = f64::NAN);
        refused("iterations", |s| s.fit_settings.iterations = 1 << 40);
        refused("landmark_weights has 70", |s| s.fit_settings.landmark_weights = vec![1.0; 70]);
        refused("landmark_weights[3]", |s| {
            s.fit_settings.landmark_weights = vec![1.0, 1.0, 1.0, -2.0];
        });
        refused("max_reproj_rms_px", |s| s.fit_settings.max_reproj_rms_px = 0.0);
        refused("correction of frame 1000000000000", |s| {
            let p = crate::landmarks::LandmarkPoint::tracked(1.0, 2.0);
            s.clips[0].corrections.set(1_000_000_000_000, 3, p).unwrap();
        });
        refused("tracked frame 0: point 1 (1e300, 2)", |s| {
            let mut points = vec![crate::landmarks::LandmarkPoint::tracked(1.0, 2.0); N_LANDMARKS];
            points[0].x = 1e300;
            let frame = crate::landmarks::FrameLandmarks::new(0, points);
            s.clips[0].set_tracked(crate::landmarks::Track::new(vec![frame]));
        });
        refused("correction of frame 3 point 5: (-2000000, 1)", |s| {
            let p = crate::landmarks::LandmarkPoint::tracked(-2e6, 1.0);
            s.clips[0].corrections.set(3, 4, p).unwrap();
        });
        refused("reviewed frame", |s| {
            s.clips[0].corrections.reviewed.insert(4_000_000_000);
        });
        refused("profile correction", |s| {
            let p = crate::math::Point2::new(1.0, 1.0);
            s.clips[0].profile_corrections.insert(MAX_FRAME + 1, p);
        });
        let audio = |rate: u32, channels: u16| crate::session::ClipAudio {
            file: "/tmp/a.wav".into(),
            sample_rate: rate,
            channels,
            offset_s: 0.0,
        };
        refused("audio: sample_rate 0 Hz", |s| s.clips[0].audio = Some(audio(0, 1)));
        refused("audio: sample_rate 1000000 Hz", |s| s.clips[0].audio = Some(audio(1_000_000, 1)));
        refused("audio: channels is 0", |s| s.clips[0].audio = Some(audio(16_000, 0)));
        refused("end before its start", |s| phones(s, 2.0, 1.0));
        refused("end past", |s| phones(s, 0.0, 1e9));
        refused("negative start", |s| phones(s, -1.0, 1.0));
    }

    #[test]
    fn each_clip_spans_at_most_the_largest_frame_however_many_clips() {
        let mut s = session_with_clip();
        s.clips[0].corrections.reviewed.insert(MAX_FRAME);
        for k in 0..4 {
            let mut b = s.clips[0].clone();
            b.name = format!("b{k}");
            s.clips.push(b);
        }
        assert_eq!(check_values(&s), Ok(()));
        assert_eq!(clip_span(&s.clips[0]), MAX_FRAME + 1);
        // Phones count as frames too.
        s.clips[0].corrections.reviewed.clear();
        phones(&mut s, 0.0, 2.0);
        assert_eq!(clip_span(&s.clips[0]), 50);
        phones(&mut s, 0.0, (MAX_FRAME + 10) as f64 / 25.0);
        let err = check_values(&s).unwrap_err();
        assert!(err.starts_with("clip \"a\": alignment") && err.contains("end past"), "{err}");
    }

    #[test]
    fn bounds_are_inclusive_at_the_edges() {
        let mut s = session_with_clip();
        s.clips[0].front.fps = 1000.0;
        s.clips[0].corrections.reviewed.insert(MAX_FRAME);
        s.fit_settings.landmark_weights = vec![0.0; N_LANDMARKS];
        assert_eq!(check_values(&s), Ok(()));
    }
}
