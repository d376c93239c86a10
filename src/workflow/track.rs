//! Tracking landmarks inside lipmap, as `lipmap track`, `new`/`import --track` and the
//! re-alignment commands use it: load the predictor and the detector once, track a clip's
//! frames into a [`Track`], re-align a corrected frame, propagate a correction forward.
//!
//! Start at [`load_tracker`], then [`track_frames`]. Re-alignment: [`realign_session_frame`]
//! and [`propagate_correction`] compute on a session in memory (the TUI's edits),
//! [`apply_realigned`] stores their result, [`propagate_session_correction`] is `lipmap
//! propagate` on a session file.

use super::error::{Error, Progress, ProgressFn, Result};
use super::session::{clip_or_first, open_for_edit};
use crate::io::frames::{FrameOptions, FrameSource};
use crate::landmarks::{FrameLandmarks, LandmarkPoint, PointSource, Track};
use crate::session::Session;
use crate::track::realign::{
    CorrectedFrame, NextFrame, PropagateOptions, PropagationEnd, propagate_realignment,
    realign_shape,
};
use crate::track::tracker::{
    FaceTracker, StartKind, TrackOptions, TrackedFrame, shape_disagreement,
};
use crate::track::{
    DEBIAN_CASCADE_PATH, DEBIAN_PREDICTOR_PATH, FaceBox, GrayImage, GrayView, HaarCascade,
    ShapePredictor, ShapePrior, read_haar_cascade, read_shape_predictor,
};
use nalgebra::Vector2;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// The files the tracker reads (`None`: Debian's install paths).
#[derive(Clone, Debug, Default, PartialEq, Eq)]
pub struct TrackerFiles {
    /// dlib's shape predictor (`shape_predictor_68_face_landmarks.dat`).
    pub predictor: Option<PathBuf>,
    /// An OpenCV Haar face cascade (XML).
    pub detector: Option<PathBuf>,
}

/// A loaded predictor and detector.
pub struct Tracker {
    pub predictor: ShapePredictor,
    pub detector: HaarCascade,
    pub options: TrackOptions,
    /// The predictor's shape prior, made on the first re-alignment (tracking never needs it).
    prior: OnceLock<ShapePrior>,
}

impl Tracker {
    /// A tracker of these files' contents.
    pub fn new(predictor: ShapePredictor, detector: HaarCascade, options: TrackOptions) -> Self {
        Self { predictor, detector, options, prior: OnceLock::new() }
    }

    /// The predictor's shape prior, which carries a re-aligned frame's points with the ones
    /// held: made from the predictor's leaves on the first call (≈ 0.2 s of CPU for dlib's
    /// 68-point model), then kept.
    pub fn shape_prior(&self) -> &ShapePrior {
        self.prior.get_or_init(|| ShapePrior::of_predictor(&self.predictor))
    }
}

impl std::fmt::Debug for Tracker {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Tracker").field("parts", &self.predictor.num_parts()).finish()
    }
}

/// The file to read: the one given, else the Debian path when it exists, else an error
/// saying which package installs it.
fn resolve(
    given: Option<&Path>,
    debian: &str,
    what: &'static str,
    flag: &'static str,
    package: &'static str,
) -> Result<PathBuf> {
    match given {
        Some(p) => Ok(p.to_path_buf()),
        None if Path::new(debian).is_file() => Ok(PathBuf::from(debian)),
        None => Err(Error::NoTrackerFile { what, path: PathBuf::from(debian), package, flag }),
    }
}

/// Reads the predictor and the detector.
///
/// # Errors
/// A file that is missing (with the package that installs it) or does not parse.
pub fn load_tracker(files: &TrackerFiles) -> Result<Tracker> {
    let predictor_path = resolve(
        files.predictor.as_deref(),
        DEBIAN_PREDICTOR_PATH,
        "shape predictor",
        "--predictor",
        "libdlib-data",
    )?;
    let detector_path = resolve(
        files.detector.as_deref(),
        DEBIAN_CASCADE_PATH,
        "face detector cascade",
        "--detector",
        "opencv-data",
    )?;
    let predictor = read_shape_predictor(&predictor_path)?;
    if predictor.num_parts() != crate::landmarks::ibug::N_LANDMARKS {
        return Err(Error::Invalid(format!(
            "{}: a predictor of {} points, but lipmap tracks the 68 iBUG points",
            predictor_path.display(),
            predictor.num_parts()
        )));
    }
    let detector = read_haar_cascade(&detector_path)?;
    Ok(Tracker::new(predictor, detector, TrackOptions::default()))
}

/// A clip tracked: its landmarks and what happened on the way.
#[derive(Clone, Debug)]
pub struct Tracked {
    pub track: Track,
    /// Frames where no face was found (their points are not visible, `success` false).
    pub lost: Vec<usize>,
    /// Frames where the face was (re)detected rather than followed.
    pub detected: Vec<usize>,
}

/// A frame's grey levels as dlib computes them.
pub fn gray_of(frames: &FrameSource, i: usize) -> Result<GrayImage> {
    let img = frames.get(i)?;
    Ok(GrayImage::from_rgb(img.width() as usize, img.height() as usize, img.as_raw()))
}

/// A tracked frame as landmarks: every point `Tracked`, visible, with the frame's
/// confidence on the frame and on each point (so formats with only point confidences keep
/// it), and the self-check's disagreement that confidence comes from (the flags read it).
pub fn frame_landmarks(frame: usize, t: &TrackedFrame) -> FrameLandmarks {
    let points = t
        .points
        .iter()
        .map(|p| LandmarkPoint {
            confidence: Some(t.confidence),
            ..LandmarkPoint::tracked(p.x, p.y)
        })
        .collect();
    FrameLandmarks {
        confidence: Some(t.confidence),
        rerun_disagreement: Some(t.disagreement as f32),
        ..FrameLandmarks::new(frame, points)
    }
}

/// Tracks every frame of `frames`. Frames where no face was found (and none was followed
/// from the frame before) are in [`Tracked::lost`], with points not visible; a front lets
/// the user draw a face box there ([`track_from_box`]).
///
/// # Errors
/// A frame that cannot be decoded.
pub fn track_frames(
    tracker: &Tracker,
    frames: &FrameSource,
    progress: ProgressFn,
) -> Result<Tracked> {
    progress(Progress::Stage {
        what: format!("tracking {}", frames.path().display()),
        total: frames.len(),
    });
    let tracked = track_images(tracker, frames.len(), |i| gray_of(frames, i), progress);
    progress(Progress::Finished);
    tracked
}

/// Tracks `n` frames, frame `i` given by `frame(i)` in order: the loop of [`track_frames`]
/// without the decoding (benchmarks time it on decoded frames).
///
/// # Errors
/// The first error `frame` returns.
pub fn track_images(
    tracker: &Tracker,
    n: usize,
    mut frame: impl FnMut(usize) -> Result<GrayImage>,
    progress: ProgressFn,
) -> Result<Tracked> {
    let ft = FaceTracker {
        predictor: &tracker.predictor,
        detector: Some(&tracker.detector),
        options: tracker.options.clone(),
    };
    let mut out = Vec::with_capacity(n);
    let (mut lost, mut detected) = (Vec::new(), Vec::new());
    let mut previous: Option<TrackedFrame> = None;
    for i in 0..n {
        let gray = frame(i)?;
        match ft.track_frame(gray.view(), previous.as_ref()) {
            Some(t) => {
                if t.start != StartKind::Previous {
                    detected.push(i);
                }
                out.push(frame_landmarks(i, &t));
                previous = Some(t);
            }
            None => {
                lost.push(i);
                let points = vec![LandmarkPoint::missing(); crate::landmarks::ibug::N_LANDMARKS];
                out.push(FrameLandmarks { success: false, ..FrameLandmarks::new(i, points) });
            }
        }
        progress(Progress::Steps { done: i + 1, total: n });
    }
    Ok(Tracked { track: Track::new(out), lost, detected })
}

/// Opens `path` (a folder of images or a video) and tracks it.
///
/// # Errors
/// As [`FrameSource::open`] and [`track_frames`].
pub fn track_path(
    tracker: &Tracker,
    path: &Path,
    fps: Option<f64>,
    progress: ProgressFn,
) -> Result<Tracked> {
    let frames = FrameSource::open(path, &FrameOptions { fps, ..Default::default() })?;
    track_frames(tracker, &frames, progress)
}

fn points_of(f: &FrameLandmarks) -> Vec<Vector2<f64>> {
    f.points.iter().map(|p| Vector2::new(p.x, p.y)).collect()
}

/// Re-aligns one frame to its corrected points: the cascade runs from the tracker's points
/// of the frame ([`realign_start`]) with the `held` points (indices) put where `frame` has
/// them, and the others are carried with them by the predictor's shape prior
/// ([`realign_shape`]). Returns the frame's new points: held ones unchanged, the others
/// marked `Interpolated` (derived by lipmap from the user's corrections, not placed by hand,
/// so a later re-alignment holds only the user's own points).
///
/// `tracked` is the tracker's own landmarks of the frame (the clip's track before any
/// correction): what the held points are corrected *from*, which is what is carried.
///
/// # Errors
/// A held index out of range, or a frame that is not a 68-point shape with an extent.
pub fn realign_frame(
    tracker: &Tracker,
    image: GrayView<'_>,
    frame: &FrameLandmarks,
    tracked: Option<&FrameLandmarks>,
    held: &[usize],
) -> Result<FrameLandmarks> {
    let n = tracker.predictor.num_parts();
    if let Some(bad) = held.iter().find(|&&i| i >= n) {
        return Err(Error::Invalid(format!(
            "point {} does not exist (points are 1–{n})",
            crate::landmarks::PointNo(*bad)
        )));
    }
    let current = points_of(frame);
    let held_pts: Vec<(usize, Vector2<f64>)> = held.iter().map(|&i| (i, current[i])).collect();
    let start = realign_start(frame, tracked);
    let prior = tracker.shape_prior();
    let shape =
        realign_shape(&tracker.predictor, prior, image, &start, &held_pts).ok_or_else(|| {
            Error::Invalid(format!(
                "frame {}: not a shape of {n} points with an extent",
                frame.frame
            ))
        })?;
    Ok(with_derived_points(frame, &shape, held))
}

/// The shape a re-alignment of `frame` starts from: the tracker's own points there
/// (`tracked`) when the tracker found the face on that frame, else the frame's current
/// points. The held points' corrections are measured from it, so the user's fix is carried
/// from where the tracker was wrong; and a frame re-aligned before (its other points already
/// carried) is re-derived from the tracker's points and all the user's, not carried twice.
/// A frame the tracker lost (tracked since from a face box) starts from its current points:
/// its held points are held, but there is no tracker's position to carry a correction from.
pub fn realign_start(
    frame: &FrameLandmarks,
    tracked: Option<&FrameLandmarks>,
) -> Vec<Vector2<f64>> {
    match tracked {
        Some(t) if t.success && t.points.len() == frame.points.len() => points_of(t),
        _ => points_of(frame),
    }
}

/// `frame` with every point not in `keep` moved to `shape` and marked `Interpolated`.
fn with_derived_points(
    frame: &FrameLandmarks,
    shape: &[Vector2<f64>],
    keep: &[usize],
) -> FrameLandmarks {
    with_tracked_points(frame, shape, keep, None)
}

/// `frame` with every point not in `keep` moved to `shape`, visible, marked `Interpolated`
/// and given `confidence` (the tracker's for the frame, when it ran).
fn with_tracked_points(
    frame: &FrameLandmarks,
    shape: &[Vector2<f64>],
    keep: &[usize],
    confidence: Option<f32>,
) -> FrameLandmarks {
    let mut out = frame.clone();
    for (i, (p, s)) in out.points.iter_mut().zip(shape).enumerate() {
        if !keep.contains(&i) {
            *p = LandmarkPoint {
                source: PointSource::Interpolated,
                confidence,
                ..LandmarkPoint::tracked(s.x, s.y)
            };
        }
    }
    out
}

/// Tracks a clip from a face box a person drew on frame `first` (where the detector found
/// no face, or the wrong one): the cascade runs in the box as in a detection's box
/// ([`FaceTracker::fit_in_box`]), then each following frame of `existing` is tracked from
/// the one before ([`FaceTracker::track_frame`]) until the result agrees with the landmarks
/// `existing` has there (within `opts.agree_disagreement` eye distances; a frame the tracker
/// lost never agrees; that frame is left as it was) or `opts.max_frames` frames are done.
/// `image(f)` gives frame `f`'s grey levels, called in order and only for the frames walked.
///
/// Returns the changed frames, `first` first: every point moved to the new track, visible,
/// marked `Interpolated` (derived from the user's box) and given the frame's confidence;
/// points a person `Corrected` are kept.
///
/// # Errors
/// `first` has no landmarks in `existing` (lost frames have placeholders); the box is not a
/// positive finite rectangle; the first error `image` returns.
pub fn track_from_box(
    tracker: &Tracker,
    face: FaceBox,
    existing: &Track,
    first: usize,
    mut image: impl FnMut(usize) -> Result<GrayImage>,
    opts: &PropagateOptions,
) -> Result<Vec<FrameLandmarks>> {
    if !face.is_valid() {
        return Err(Error::Invalid(format!("frame {first}: the face box has no area")));
    }
    let Some(start) = existing.frames.iter().position(|f| f.frame == first) else {
        return Err(Error::Invalid(format!("frame {first} has no landmarks in the clip")));
    };
    let ft = FaceTracker {
        predictor: &tracker.predictor,
        detector: Some(&tracker.detector),
        options: tracker.options.clone(),
    };
    let gray = image(first)?;
    let mut previous = ft.fit_in_box(gray.view(), face, StartKind::Given);
    let own = &existing.frames[start];
    let mut out = vec![with_tracked_points(
        own,
        &previous.points,
        &corrected_points(own),
        Some(previous.confidence),
    )];
    for own in existing.frames[start + 1..].iter().take(opts.max_frames) {
        let gray = image(own.frame)?;
        let Some(t) = ft.track_frame(gray.view(), Some(&previous)) else { break };
        if own.success && shape_disagreement(&points_of(own), &t.points) <= opts.agree_disagreement
        {
            break;
        }
        out.push(with_tracked_points(own, &t.points, &corrected_points(own), Some(t.confidence)));
        previous = t;
    }
    Ok(out)
}

/// The points of a frame a person placed (`Corrected`), which re-alignment holds.
pub fn corrected_points(frame: &FrameLandmarks) -> Vec<usize> {
    frame
        .points
        .iter()
        .enumerate()
        .filter(|(_, p)| p.source == PointSource::Corrected)
        .map(|(i, _)| i)
        .collect()
}

/// What [`propagate_session_correction`] changed.
#[derive(Clone, Debug, PartialEq)]
pub struct Propagated {
    pub clip: String,
    /// The corrected frame (first) and the frames after it that were re-aligned, in order.
    pub frames: Vec<usize>,
    /// The points held on the corrected frame (its corrected ones).
    pub held: Vec<usize>,
    /// Why the walk stopped.
    pub end: PropagationEnd,
}

/// A frame of a session's clip re-aligned from its corrected points, without changing the
/// session: the frame's landmarks with every other point moved and marked `Interpolated`.
/// A front that keeps the session in memory (the TUI's re-align key) applies the
/// `Interpolated` points as edits with [`apply_realigned`], so that they undo like any edit.
///
/// # Errors
/// An unknown clip or frame; a frame with no corrected point; a frame that cannot be read.
pub fn realign_session_frame(
    session: &Session,
    index: usize,
    frame: usize,
    tracker: &Tracker,
) -> Result<FrameLandmarks> {
    let frames = session.open_frames(index, 16)?;
    let effective = session.effective_track(index)?;
    let current = corrected_frame(session, index, &effective, frame)?;
    let tracked = session.clip(index)?.tracked()?;
    let held = corrected_points(current);
    realign_frame(tracker, gray_of(&frames, frame)?.view(), current, tracked.get(frame), &held)
}

/// The frame's effective landmarks, when it has at least one corrected point.
fn corrected_frame<'t>(
    session: &Session,
    index: usize,
    effective: &'t Track,
    frame: usize,
) -> Result<&'t FrameLandmarks> {
    let name = &session.clip(index)?.name;
    let Some(current) = effective.get(frame) else {
        return Err(Error::Invalid(format!("clip `{name}` has no landmarks on frame {frame}")));
    };
    if corrected_points(current).is_empty() {
        return Err(Error::Invalid(format!(
            "clip `{name}` frame {frame} has no corrected point to re-align from (move some in `lipmap tui`)"
        )));
    }
    Ok(current)
}

/// Re-aligns frame `frame` of a session's clip from its corrected points, then carries the
/// correction through the following frames ([`propagate_realignment`]: the corrected points
/// followed by their image patches, each frame re-aligned to them from the tracker's points)
/// until the tracker agrees again, a patch is lost, or `opts.max_frames`. Returns the changed
/// frames (the corrected one first), their derived points marked `Interpolated` (points a
/// person corrected on a following frame are kept), and why the walk stopped; the session is
/// not changed ([`apply_realigned`] stores them).
///
/// # Errors
/// As [`realign_session_frame`]; a following frame that cannot be read.
pub fn propagate_correction(
    session: &Session,
    index: usize,
    frame: usize,
    tracker: &Tracker,
    opts: &PropagateOptions,
) -> Result<(Vec<FrameLandmarks>, PropagationEnd)> {
    let effective = session.effective_track(index)?;
    let corrected = corrected_frame(session, index, &effective, frame)?;
    let frames = session.open_frames(index, 64)?;
    let held = corrected_points(corrected);
    let tracked = session.clip(index)?.tracked()?;
    let image = gray_of(&frames, frame)?;
    let realigned = realign_frame(tracker, image.view(), corrected, tracked.get(frame), &held)?;
    let start_points = realign_start(corrected, tracked.get(frame));
    let held_points: Vec<(usize, Vector2<f64>)> = held
        .iter()
        .map(|&i| (i, Vector2::new(corrected.points[i].x, corrected.points[i].y)))
        .collect();
    let start = CorrectedFrame { image: image.view(), tracked: &start_points, held: &held_points };
    // Frames are decoded as the walk reaches them; a frame that cannot be decoded ends it. The
    // tracker's own points of a frame are what a correction is measured from (as on the
    // corrected frame); a frame the tracker lost has none.
    let mut decode_error = None;
    let walk = (frame + 1..frames.len()).map_while(|f| match gray_of(&frames, f) {
        Ok(image) => {
            let tracked = effective
                .get(f)
                .filter(|fl| fl.success)
                .map(|fl| realign_start(fl, tracked.get(f)));
            Some(NextFrame { frame: f, image, tracked })
        }
        Err(e) => {
            decode_error = Some(e);
            None
        }
    });
    let propagation =
        propagate_realignment(&tracker.predictor, tracker.shape_prior(), &start, walk, opts);
    if let Some(e) = decode_error {
        return Err(e);
    }
    let mut changed = vec![realigned];
    for (f, shape) in (frame + 1..).zip(&propagation.shapes) {
        let own = effective.get(f).expect("a frame the walk re-aligned has landmarks");
        changed.push(with_derived_points(own, shape, &corrected_points(own)));
    }
    Ok((changed, propagation.end))
}

/// Stores the `Interpolated` points of re-aligned frames as corrections of clip `index`.
///
/// # Errors
/// An unknown clip; a point the corrections refuse.
pub fn apply_realigned(
    session: &mut Session,
    index: usize,
    frames: &[FrameLandmarks],
) -> Result<()> {
    session.clip(index)?;
    for fl in frames {
        for (i, p) in fl.points.iter().enumerate() {
            if p.source == PointSource::Interpolated {
                session.set_correction(index, fl.frame, i, *p)?;
            }
        }
    }
    Ok(())
}

/// `lipmap propagate`: [`propagate_correction`] on a session file, stored and saved.
///
/// # Errors
/// The session cannot be opened, locked or saved; as [`propagate_correction`].
pub fn propagate_session_correction(
    session: &str,
    clip: Option<&str>,
    frame: usize,
    tracker: &Tracker,
    opts: &PropagateOptions,
) -> Result<Propagated> {
    let mut edit = open_for_edit(session)?;
    let index = clip_or_first(&edit.session, clip)?;
    let (changed, end) = propagate_correction(&edit.session, index, frame, tracker, opts)?;
    let held = changed.first().map(corrected_points).unwrap_or_default();
    apply_realigned(&mut edit.session, index, &changed)?;
    edit.session.save(&edit.path)?;
    Ok(Propagated {
        clip: edit.session.clip(index)?.name.clone(),
        frames: changed.iter().map(|f| f.frame).collect(),
        held,
        end,
    })
}
