//! Pure edit operations on a `Track` of effective landmarks: move a point or a group, toggle
//! visibility, copy from the previous frame, propagate a correction, interpolate keyframes.
//!
//! Every operation returns the `PointChange`s it made (before and after), so a caller can
//! undo or redo it with `apply_changes` and can tell which frames need re-fitting. Hand edits
//! mark points `Corrected`; interpolation marks them `Interpolated`. The tracker's original
//! values live elsewhere (the session keeps them), so nothing here loses data.

use super::track::{LandmarkPoint, PointSource, Track};
use std::fmt;

/// One point of one frame changed from `before` to `after`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PointChange {
    /// Frame number (`FrameLandmarks::frame`), not the position in `Track::frames`.
    pub frame: usize,
    /// 0-based iBUG index.
    pub index: usize,
    pub before: LandmarkPoint,
    pub after: LandmarkPoint,
}

/// Why an edit could not be made.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum EditError {
    /// The track has no frame with this number.
    NoSuchFrame(usize),
    /// The point index is not an iBUG-68 index present in the frame.
    NoSuchPoint(usize),
    /// The frame is the first of the track, so there is nothing to copy from.
    NoPreviousFrame(usize),
    /// A coordinate would become non-finite.
    NonFinite,
}

impl fmt::Display for EditError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::NoSuchFrame(n) => write!(f, "no frame {n} in the track"),
            Self::NoSuchPoint(i) => write!(f, "no landmark {}", super::PointNo(*i)),
            Self::NoPreviousFrame(n) => write!(f, "frame {n} has no previous frame"),
            Self::NonFinite => write!(f, "the edit would make a coordinate non-finite"),
        }
    }
}

impl std::error::Error for EditError {}

/// Sets point `index` of frame `frame` to `after`, recording the change when it differs.
fn set_point(
    track: &mut Track,
    frame: usize,
    index: usize,
    after: LandmarkPoint,
    changes: &mut Vec<PointChange>,
) -> Result<(), EditError> {
    if !after.x.is_finite() || !after.y.is_finite() {
        return Err(EditError::NonFinite);
    }
    let f = track.get_mut(frame).ok_or(EditError::NoSuchFrame(frame))?;
    let p = f.points.get_mut(index).ok_or(EditError::NoSuchPoint(index))?;
    if *p != after {
        changes.push(PointChange { frame, index, before: *p, after });
        *p = after;
    }
    Ok(())
}

fn point(track: &Track, frame: usize, index: usize) -> Result<LandmarkPoint, EditError> {
    let f = track.get(frame).ok_or(EditError::NoSuchFrame(frame))?;
    f.points.get(index).copied().ok_or(EditError::NoSuchPoint(index))
}

/// Moves the given points of one frame by `(dx, dy)` pixels and marks them corrected.
/// Moving a point the tracker lost makes it visible: the user has just placed it.
///
/// # Errors
/// `NoSuchFrame`/`NoSuchPoint` for bad indices (nothing is changed then), `NonFinite`.
pub fn move_points(
    track: &mut Track,
    frame: usize,
    indices: &[usize],
    dx: f64,
    dy: f64,
) -> Result<Vec<PointChange>, EditError> {
    for &i in indices {
        point(track, frame, i)?;
    }
    let mut changes = Vec::with_capacity(indices.len());
    for &i in indices {
        let mut p = point(track, frame, i)?;
        p.x += dx;
        p.y += dy;
        p.visible = true;
        p.source = PointSource::Corrected;
        set_point(track, frame, i, p, &mut changes)?;
    }
    Ok(changes)
}

/// Places one point at `(x, y)` pixels (a mouse drag), marked corrected and visible.
///
/// # Errors
/// As `move_points`.
pub fn place_point(
    track: &mut Track,
    frame: usize,
    index: usize,
    x: f64,
    y: f64,
) -> Result<Vec<PointChange>, EditError> {
    let mut p = point(track, frame, index)?;
    p.x = x;
    p.y = y;
    p.visible = true;
    p.source = PointSource::Corrected;
    let mut changes = Vec::new();
    set_point(track, frame, index, p, &mut changes)?;
    Ok(changes)
}

/// Flips the visibility of the given points (all become the negation of the first one's,
/// so a mixed group toggles as one) and marks them corrected.
///
/// # Errors
/// `NoSuchFrame`/`NoSuchPoint`.
pub fn toggle_visible(
    track: &mut Track,
    frame: usize,
    indices: &[usize],
) -> Result<Vec<PointChange>, EditError> {
    let Some(&first) = indices.first() else { return Ok(Vec::new()) };
    let target = !point(track, frame, first)?.visible;
    for &i in indices {
        point(track, frame, i)?;
    }
    let mut changes = Vec::new();
    for &i in indices {
        let mut p = point(track, frame, i)?;
        p.visible = target;
        p.source = PointSource::Corrected;
        set_point(track, frame, i, p, &mut changes)?;
    }
    Ok(changes)
}

/// Copies the given points from the previous frame of the track (the nearest lower frame
/// number) into `frame`, marked corrected; the tracker's confidence is not copied.
///
/// # Errors
/// `NoPreviousFrame` for the first frame, `NoSuchFrame`/`NoSuchPoint`.
pub fn copy_from_previous(
    track: &mut Track,
    frame: usize,
    indices: &[usize],
) -> Result<Vec<PointChange>, EditError> {
    let pos = track
        .frames
        .binary_search_by_key(&frame, |f| f.frame)
        .map_err(|_| EditError::NoSuchFrame(frame))?;
    if pos == 0 {
        return Err(EditError::NoPreviousFrame(frame));
    }
    let prev = track.frames[pos - 1].frame;
    let mut changes = Vec::new();
    for &i in indices {
        let src = point(track, prev, i)?;
        let mut p = point(track, frame, i)?;
        p.x = src.x;
        p.y = src.y;
        p.visible = src.visible;
        p.confidence = None;
        p.source = PointSource::Corrected;
        set_point(track, frame, i, p, &mut changes)?;
    }
    Ok(changes)
}

/// Propagates the correction of the given points in `frame` to the next `n` frames of the
/// track: each later point is moved by the same offset the correction applied to this
/// frame (`effective − original`), so a tracker that is consistently off by a few pixels is
/// fixed while the point keeps following the motion. `original` is the tracker's track.
/// Points whose offset is zero are skipped; later points already corrected by hand are
/// left alone (the user's later work wins).
///
/// # Errors
/// `NoSuchFrame`/`NoSuchPoint` when `frame` is missing from either track.
pub fn propagate_correction(
    track: &mut Track,
    original: &Track,
    frame: usize,
    indices: &[usize],
    n: usize,
) -> Result<Vec<PointChange>, EditError> {
    let pos = track
        .frames
        .binary_search_by_key(&frame, |f| f.frame)
        .map_err(|_| EditError::NoSuchFrame(frame))?;
    let mut offsets = Vec::with_capacity(indices.len());
    for &i in indices {
        let e = point(track, frame, i)?;
        let o = point(original, frame, i)?;
        offsets.push((i, e.x - o.x, e.y - o.y, e.visible));
    }
    let later: Vec<usize> = track.frames.iter().skip(pos + 1).take(n).map(|f| f.frame).collect();
    let mut changes = Vec::new();
    for f in later {
        for &(i, dx, dy, visible) in &offsets {
            let cur = point(track, f, i)?;
            if cur.source == PointSource::Corrected {
                continue;
            }
            let Ok(orig) = point(original, f, i) else { continue };
            if dx == 0.0 && dy == 0.0 && cur.visible == visible {
                continue;
            }
            let p = LandmarkPoint {
                x: orig.x + dx,
                y: orig.y + dy,
                visible,
                confidence: None,
                source: PointSource::Corrected,
            };
            set_point(track, f, i, p, &mut changes)?;
        }
    }
    Ok(changes)
}

/// Linearly interpolates the given points between consecutive hand-corrected keyframes
/// (frames where the point's source is `Corrected`), by frame number. Points in between
/// become `Interpolated`; a point is visible when both keyframes are. Frames before the first
/// or after the last keyframe are untouched. A point with fewer than two keyframes is skipped.
pub fn interpolate_keyframes(track: &mut Track, indices: &[usize]) -> Vec<PointChange> {
    let mut changes = Vec::new();
    for &i in indices {
        let keys: Vec<(usize, LandmarkPoint)> = track
            .frames
            .iter()
            .filter_map(|f| f.points.get(i).map(|p| (f.frame, *p)))
            .filter(|(_, p)| p.source == PointSource::Corrected)
            .collect();
        for pair in keys.windows(2) {
            let ((f0, p0), (f1, p1)) = (pair[0], pair[1]);
            let span = (f1 - f0) as f64;
            let between: Vec<usize> =
                track.frames.iter().map(|f| f.frame).filter(|&f| f > f0 && f < f1).collect();
            for f in between {
                let t = (f - f0) as f64 / span;
                let p = LandmarkPoint {
                    x: p0.x + t * (p1.x - p0.x),
                    y: p0.y + t * (p1.y - p0.y),
                    visible: p0.visible && p1.visible,
                    confidence: None,
                    source: PointSource::Interpolated,
                };
                // Indices were validated by the keyframe scan, so this cannot fail.
                let _ = set_point(track, f, i, p, &mut changes);
            }
        }
    }
    changes
}

/// Restores the given points of one frame to the tracker's values in `original`.
///
/// # Errors
/// `NoSuchFrame`/`NoSuchPoint`.
pub fn revert_points(
    track: &mut Track,
    original: &Track,
    frame: usize,
    indices: &[usize],
) -> Result<Vec<PointChange>, EditError> {
    let mut changes = Vec::new();
    for &i in indices {
        let o = point(original, frame, i)?;
        set_point(track, frame, i, o, &mut changes)?;
    }
    Ok(changes)
}

/// Sets the points of `derived` marked `Interpolated` (placed by lipmap from the user's
/// input: a re-alignment to corrected points, a track from a drawn face box) into its frame
/// of `track`; the others are left as they are.
///
/// # Errors
/// `NoSuchFrame`/`NoSuchPoint`, `NonFinite` (nothing of that point on is changed).
pub fn set_derived_points(
    track: &mut Track,
    derived: &super::track::FrameLandmarks,
) -> Result<Vec<PointChange>, EditError> {
    let mut changes = Vec::new();
    for (i, p) in derived.points.iter().enumerate() {
        if p.source == PointSource::Interpolated {
            set_point(track, derived.frame, i, *p, &mut changes)?;
        }
    }
    Ok(changes)
}

/// Applies recorded changes forward (`after`) or backward (`before`, in reverse order), for
/// redo and undo. Changes naming frames or points the track lacks are skipped.
pub fn apply_changes(track: &mut Track, changes: &[PointChange], forward: bool) {
    let mut apply = |c: &PointChange| {
        if let Some(p) = track.get_mut(c.frame).and_then(|f| f.points.get_mut(c.index)) {
            *p = if forward { c.after } else { c.before };
        }
    };
    if forward {
        changes.iter().for_each(&mut apply);
    } else {
        changes.iter().rev().for_each(&mut apply);
    }
}

/// The points of `track` that differ from `original` or are not tracker output: the
/// corrections to store beside the tracker's values, as (frame, index, point).
pub fn corrections(original: &Track, track: &Track) -> Vec<(usize, usize, LandmarkPoint)> {
    let mut out = Vec::new();
    for f in &track.frames {
        let orig = original.get(f.frame);
        for (i, p) in f.points.iter().enumerate() {
            let o = orig.and_then(|o| o.points.get(i));
            if p.source != PointSource::Tracked || o != Some(p) {
                out.push((f.frame, i, *p));
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::landmarks::{FrameLandmarks, N_LANDMARKS};

    fn track(n: usize) -> Track {
        Track::new(
            (0..n)
                .map(|f| {
                    let pts = (0..N_LANDMARKS)
                        .map(|i| LandmarkPoint::tracked(i as f64 + f as f64, 2.0 * i as f64))
                        .collect();
                    FrameLandmarks::new(f, pts)
                })
                .collect(),
        )
    }

    #[test]
    fn move_marks_corrected_and_undo_restores() {
        let orig = track(3);
        let mut t = orig.clone();
        let ch = move_points(&mut t, 1, &[48, 54], 2.5, -1.0).unwrap();
        assert_eq!(ch.len(), 2);
        let p = t.get(1).unwrap().points[48];
        assert_eq!((p.x, p.y, p.source), (49.0 + 2.5, 95.0, PointSource::Corrected));
        apply_changes(&mut t, &ch, false);
        assert_eq!(t, orig);
        apply_changes(&mut t, &ch, true);
        assert_eq!(t.get(1).unwrap().points[54].x, 57.5);
    }

    #[test]
    fn bad_indices_change_nothing() {
        let mut t = track(2);
        assert_eq!(move_points(&mut t, 5, &[1], 1.0, 0.0), Err(EditError::NoSuchFrame(5)));
        assert_eq!(move_points(&mut t, 0, &[1, 99], 1.0, 0.0), Err(EditError::NoSuchPoint(99)));
        assert_eq!(t, track(2));
        assert_eq!(copy_from_previous(&mut t, 0, &[1]), Err(EditError::NoPreviousFrame(0)));
        assert_eq!(place_point(&mut t, 0, 1, f64::NAN, 0.0), Err(EditError::NonFinite));
    }

    #[test]
    fn copy_from_previous_takes_positions() {
        let mut t = track(3);
        let ch = copy_from_previous(&mut t, 2, &[10]).unwrap();
        assert_eq!(ch.len(), 1);
        assert_eq!(t.get(2).unwrap().points[10].x, t.get(1).unwrap().points[10].x);
    }

    #[test]
    fn propagate_applies_offset_and_spares_hand_corrections() {
        let orig = track(6);
        let mut t = orig.clone();
        move_points(&mut t, 1, &[60], 3.0, 4.0).unwrap();
        move_points(&mut t, 3, &[60], -1.0, 0.0).unwrap();
        let ch = propagate_correction(&mut t, &orig, 1, &[60], 3).unwrap();
        // frames 2 and 4 follow the offset; 3 was corrected by hand and stays.
        assert_eq!(ch.len(), 2);
        assert_eq!(t.get(2).unwrap().points[60].x, orig.get(2).unwrap().points[60].x + 3.0);
        assert_eq!(t.get(4).unwrap().points[60].y, orig.get(4).unwrap().points[60].y + 4.0);
        assert_eq!(t.get(3).unwrap().points[60].x, orig.get(3).unwrap().points[60].x - 1.0);
        assert_eq!(t.get(5).unwrap().points[60], orig.get(5).unwrap().points[60]);
    }

    #[test]
    fn interpolate_between_keyframes_is_linear() {
        let mut t = track(7);
        place_point(&mut t, 1, 62, 10.0, 20.0).unwrap();
        place_point(&mut t, 5, 62, 30.0, 40.0).unwrap();
        let ch = interpolate_keyframes(&mut t, &[62]);
        assert_eq!(ch.len(), 3);
        let p = t.get(2).unwrap().points[62];
        assert!((p.x - 15.0).abs() < 1e-12 && (p.y - 25.0).abs() < 1e-12);
        assert_eq!(p.source, PointSource::Interpolated);
        assert_eq!(t.get(4).unwrap().points[62].x, 25.0);
        assert_eq!(t.get(0).unwrap().points[62].source, PointSource::Tracked);
        assert_eq!(t.get(6).unwrap().points[62].source, PointSource::Tracked);
    }

    #[test]
    fn corrections_list_only_changed_points() {
        let orig = track(2);
        let mut t = orig.clone();
        assert!(corrections(&orig, &t).is_empty());
        toggle_visible(&mut t, 1, &[3]).unwrap();
        let c = corrections(&orig, &t);
        assert_eq!(c.len(), 1);
        assert_eq!((c[0].0, c[0].1, c[0].2.visible), (1, 3, false));
        revert_points(&mut t, &orig, 1, &[3]).unwrap();
        assert!(corrections(&orig, &t).is_empty());
    }

    #[test]
    fn derived_points_set_only_the_interpolated_ones_and_undo() {
        let orig = track(2);
        let mut t = orig.clone();
        let mut derived = t.get(1).unwrap().clone();
        derived.points[10] = LandmarkPoint {
            source: PointSource::Interpolated,
            ..LandmarkPoint::tracked(99.0, 98.0)
        };
        // A corrected point in the result is the user's: not the derivation's to set.
        derived.points[11] =
            LandmarkPoint { source: PointSource::Corrected, ..LandmarkPoint::tracked(-5.0, -5.0) };
        let ch = set_derived_points(&mut t, &derived).unwrap();
        assert_eq!(ch.len(), 1);
        assert_eq!(
            (t.get(1).unwrap().points[10].x, t.get(1).unwrap().points[11]),
            (99.0, orig.get(1).unwrap().points[11])
        );
        apply_changes(&mut t, &ch, false);
        assert_eq!(t, orig);
        derived.frame = 7;
        assert_eq!(set_derived_points(&mut t, &derived), Err(EditError::NoSuchFrame(7)));
    }
}
