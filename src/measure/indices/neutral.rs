//! The default neutral frame on which indices are taken: the least open mouth in silence.

use crate::alignment::{Alignment, PhoneInventory};
use crate::measure::Series;
use serde::{Deserialize, Serialize};

/// The frame chosen as neutral, and whether it lies inside a silence interval.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct NeutralFrame {
    pub frame: usize,
    pub in_silence: bool,
}

/// The default neutral frame: the frame with the smallest mouth opening `h` (a per-frame
/// series such as the normalised H trajectory) among frames inside silence intervals
/// (labels `phones` takes for silence, frames by [`Alignment::frames_of`]); ties go to the earliest
/// frame. When no silence frame has a value, the smallest opening over the whole clip, with
/// `in_silence = false` so the caller can tell the user. `None` when `h` has no value.
pub fn choose_neutral_frame(
    h: &Series,
    alignment: &Alignment,
    phones: &PhoneInventory,
    fps: f64,
) -> Option<NeutralFrame> {
    let smallest = |frames: &mut dyn Iterator<Item = usize>| -> Option<usize> {
        let mut best: Option<(usize, f64)> = None;
        for f in frames {
            if let Some(v) = h.get(f).copied().flatten().filter(|v| v.is_finite())
                && best.is_none_or(|(_, b)| v < b)
            {
                best = Some((f, v));
            }
        }
        best.map(|(f, _)| f)
    };
    let mut silence = Vec::new();
    if fps.is_finite() && fps > 0.0 {
        for p in alignment.phones.iter().filter(|p| phones.is_silence(&p.label)) {
            silence.extend(Alignment::frames_of(p, fps));
        }
    }
    silence.sort_unstable();
    silence.dedup();
    if let Some(frame) = smallest(&mut silence.into_iter()) {
        return Some(NeutralFrame { frame, in_silence: true });
    }
    smallest(&mut (0..h.len())).map(|frame| NeutralFrame { frame, in_silence: false })
}
