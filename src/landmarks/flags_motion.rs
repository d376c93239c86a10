//! Jumps: a point that moves, relative to the head, far more than the speaker's own points
//! move. Head motion is removed first (each neighbour frame is mapped into the frame by the
//! similarity of its nose and eye points, `flags_procrustes::head_motion`), distances are
//! measured in face sizes (outer eye-corner distance), and each point is judged against its
//! own robust spread over the clip, so a fast but real lip movement of this speaker is not a
//! jump while a tracker's slip is. Start at [`jump_flags`].

use super::flags::{FlagReason, FlagThresholds, face_sizes, median_sigma};
use super::flags_procrustes::{Similarity2, head_motion};
use super::track::Track;
use crate::math::Point2;
use std::collections::{BTreeMap, HashMap};

/// Per point, two tests over consecutive frames where the point is visible. A *step* is the
/// displacement from the previous frame; a *spike* is the distance from the midpoint of the
/// previous and next frames' positions (a second difference), which smooth articulation keeps
/// small however fast it is, while a tracker error that lasts a frame or two stands out even
/// when its step is no bigger than a fast lip movement. Both are in face sizes, after head
/// motion is removed. Each test flags values above its own robust limit (median +
/// `jump_sigmas`·σ of that point's values, at least `jump_min_face_fraction` for steps and
/// the lower `spike_min_face_fraction`, and `spike_min_px`, for spikes); one reason per
/// frame (its largest jump). A spike counts only where it is a local maximum, and the step
/// back after a spiked frame is not counted again.
pub fn jump_flags(track: &Track, th: &FlagThresholds) -> Vec<(usize, FlagReason)> {
    let sizes = face_sizes(track);
    let n = track.frames.len();
    let consecutive = |k: usize| k > 0 && track.frames[k - 1].frame + 1 == track.frames[k].frame;
    // Head motion into frame k from its previous / next frame; identity when unknown (a face
    // without eyes or nose still gets raw jumps).
    let into = |from: usize, to: usize| head_motion(track, from, to);
    let from_prev: Vec<Option<Similarity2>> =
        (0..n).map(|k| if consecutive(k) { into(k - 1, k) } else { None }).collect();
    let from_next: Vec<Option<Similarity2>> = (0..n)
        .map(|k| if k + 1 < n && consecutive(k + 1) { into(k + 1, k) } else { None })
        .collect();
    let map = |s: &Option<Similarity2>, p: Point2| s.map_or(p, |s| s.apply(&p));

    let mut worst: BTreeMap<usize, (usize, f64, f64)> = BTreeMap::new();
    let n_points = track.frames.first().map_or(0, |f| f.points.len());
    for i in 0..n_points {
        let pos = |k: usize| {
            let p = track.frames[k].points.get(i)?;
            p.visible.then(|| p.pos())
        };
        // (frame, px, face fraction)
        let mut steps: Vec<(usize, f64, f64)> = Vec::new();
        let mut spikes: Vec<(usize, f64, f64)> = Vec::new();
        for k in 1..n {
            let Some(size) = sizes[k] else { continue };
            if !consecutive(k) {
                continue;
            }
            let f1 = track.frames[k].frame;
            if let (Some(a), Some(b)) = (pos(k - 1), pos(k)) {
                let a = map(&from_prev[k], a);
                let px = (b - a).norm();
                steps.push((f1, px, px / size));
                if k + 1 < n
                    && consecutive(k + 1)
                    && let Some(c) = pos(k + 1)
                {
                    let mid = nalgebra::center(&a, &map(&from_next[k], c));
                    let px = (b - mid).norm();
                    spikes.push((f1, px, px / size));
                }
            }
        }
        // A one-frame error also displaces its neighbours' midpoints by half as much: keep
        // only spikes that are local maxima, so the frames around a glitch are not flagged.
        let spike_at: HashMap<usize, f64> = spikes.iter().map(|s| (s.0, s.2)).collect();
        spikes.retain(|&(f, _, d)| {
            let around = [f.checked_sub(1), Some(f + 1)];
            around.iter().flatten().all(|g| spike_at.get(g).is_none_or(|&n| d >= n))
        });
        let mut spiked: Vec<usize> = Vec::new();
        for (is_step, series) in [(false, &spikes), (true, &steps)] {
            let values: Vec<f64> = series.iter().map(|d| d.2).collect();
            let Some((med, sigma)) = median_sigma(&values) else { continue };
            let floor =
                if is_step { th.jump_min_face_fraction } else { th.spike_min_face_fraction };
            let limit = (med + th.jump_sigmas * sigma).max(floor);
            for &(frame, px, d) in series.iter() {
                // The step back from a one-frame glitch is the glitch ending, not a new jump.
                let returns = is_step && frame.checked_sub(1).is_some_and(|g| spiked.contains(&g));
                let below_jitter = !is_step && px <= th.spike_min_px;
                if d <= limit || returns || below_jitter {
                    continue;
                }
                if !is_step {
                    spiked.push(frame);
                }
                if worst.get(&frame).is_none_or(|w| d > w.2) {
                    worst.insert(frame, (i, px, d));
                }
            }
        }
    }
    worst
        .into_iter()
        .map(|(f, (point, px, face_fraction))| (f, FlagReason::Jump { point, px, face_fraction }))
        .collect()
}
