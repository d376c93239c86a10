//! Demo speakers: the demo head reshaped around the mouth so that its vertical-mouth-height
//! index (100·D7/D1) and mouth-width index (100·D8/D3) fall in chosen classes of the published
//! bounds, for trying a speaker on a head whose mouth is not alike (the corresponding vs
//! non-corresponding heads of `docs/design.md`).
//!
//! A speaker is the head's articulated mesh passed through a smooth warp centred on the mouth
//! (a Gaussian-weighted stretch in x and in y) and a uniform scale. The warp leaves the eyes,
//! nose and chin where they are, so D1 and D3 stay and only D7 and D8 change; its two
//! amplitudes are found by bisection so each index hits its class's target value.

use super::head::{Head, Y_MOUTH};
use crate::math::{Point2, Point3};
use crate::measure::{BoundsTable, FacialIndex, IndexClass, facial_indices};

/// The classes a speaker is made for.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct SpeakerSpec {
    pub vertical_mouth_height: IndexClass,
    pub mouth_width: IndexClass,
}

/// The index value aimed at for a class: the middle of the published middle band, and
/// well clear of the bounds for low and high (VMH bounds 13.58/16.22, MW 49.18/54.80).
pub fn target_value(index: FacialIndex, class: IndexClass) -> f64 {
    match (index, class) {
        (FacialIndex::VerticalMouthHeight, IndexClass::Low) => 12.2,
        (FacialIndex::VerticalMouthHeight, IndexClass::Middle) => 14.9,
        (FacialIndex::VerticalMouthHeight, IndexClass::High) => 18.0,
        (_, IndexClass::Low) => 46.0,
        (_, IndexClass::Middle) => 52.0,
        (_, IndexClass::High) => 58.0,
    }
}

/// Speaker specs for `n` speakers. Speaker 0 is the head itself (`None`); the others go
/// through the mismatches that matter most first (a speaker's mouth classed high or low on
/// both indices, which a head of the other class matches worst): high/high, low/low, then the
/// crossed pairs, then one index at a time.
pub fn default_specs(n: usize) -> Vec<Option<SpeakerSpec>> {
    use IndexClass::*;
    let cycle = [
        (High, High),
        (Low, Low),
        (High, Low),
        (Low, High),
        (Middle, High),
        (Middle, Low),
        (High, Middle),
        (Low, Middle),
    ];
    (0..n)
        .map(|i| {
            (i > 0).then(|| {
                let (v, m) = cycle[(i - 1) % cycle.len()];
                SpeakerSpec { vertical_mouth_height: v, mouth_width: m }
            })
        })
        .collect()
}

/// The mouth warp: `x' = x·(1 + ax·g)`, `y' = y_m + (y − y_m)·(1 + ay·g)` with
/// `g = exp(−(x/40)² − ((y − y_m)/22)²)` (mm), then a uniform `scale` about the origin.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MouthWarp {
    pub ax: f64,
    pub ay: f64,
    pub scale: f64,
}

impl Default for MouthWarp {
    fn default() -> Self {
        Self { ax: 0.0, ay: 0.0, scale: 1.0 }
    }
}

impl MouthWarp {
    pub fn apply(&self, p: &Point3) -> Point3 {
        let dy = p.y - Y_MOUTH;
        let g = (-(p.x / 40.0).powi(2) - (dy / 22.0).powi(2)).exp();
        let q = Point3::new(p.x * (1.0 + self.ax * g), Y_MOUTH + dy * (1.0 + self.ay * g), p.z);
        Point3::from(q.coords * self.scale)
    }

    pub fn apply_all(&self, points: &[Point3]) -> Vec<Point3> {
        points.iter().map(|p| self.apply(p)).collect()
    }
}

/// A demo speaker: how the head is reshaped, and the classes it landed in.
#[derive(Clone, Debug, PartialEq)]
pub struct Speaker {
    pub index: usize,
    /// What it was made for; `None` for the head itself.
    pub spec: Option<SpeakerSpec>,
    pub warp: MouthWarp,
    /// Vertical mouth height and mouth width indices of its neutral face.
    pub vertical_mouth_height: f64,
    pub mouth_width: f64,
}

/// The frontal (x, y) landmarks of `head` reshaped by `warp`, in the form the indices take.
pub fn neutral_landmarks(head: &Head, warp: &MouthWarp) -> Vec<Option<Point2>> {
    (0..crate::landmarks::N_LANDMARKS)
        .map(|l| {
            head.landmarks.vertex(l).map(|v| {
                let p = warp.apply(&head.mesh.vertices[v]);
                Point2::new(p.x, p.y)
            })
        })
        .collect()
}

fn index_of(head: &Head, warp: &MouthWarp, which: FacialIndex) -> Option<f64> {
    facial_indices(&neutral_landmarks(head, warp)).ok().map(|ix| ix.get(which))
}

/// Makes speaker `index` for `spec` with overall `scale`; `None` spec = the head unchanged
/// (apart from the scale).
///
/// # Errors
/// When the indices cannot be computed or a target cannot be reached within the warp's
/// range (amplitudes in [−0.6, 1.5]).
pub fn make_speaker(
    head: &Head,
    index: usize,
    spec: Option<SpeakerSpec>,
    scale: f64,
) -> Result<Speaker, String> {
    let mut warp = MouthWarp { scale, ..MouthWarp::default() };
    if let Some(spec) = spec {
        let goals = [
            (FacialIndex::MouthWidth, target_value(FacialIndex::MouthWidth, spec.mouth_width)),
            (
                FacialIndex::VerticalMouthHeight,
                target_value(FacialIndex::VerticalMouthHeight, spec.vertical_mouth_height),
            ),
        ];
        // The two amplitudes barely interact (D8 lies on the seam, D7 on the midline), so
        // two rounds of one-dimensional bisection settle both.
        for _ in 0..2 {
            for &(which, goal) in &goals {
                let (mut lo, mut hi) = (-0.6, 1.5);
                let set = |w: &mut MouthWarp, a: f64| match which {
                    FacialIndex::MouthWidth => w.ax = a,
                    _ => w.ay = a,
                };
                let mut probe = warp;
                set(&mut probe, lo);
                let at_lo = index_of(head, &probe, which).ok_or("indices undefined")?;
                set(&mut probe, hi);
                let at_hi = index_of(head, &probe, which).ok_or("indices undefined")?;
                if !(at_lo <= goal && goal <= at_hi) {
                    return Err(format!("{which:?} {goal} outside [{at_lo}, {at_hi}]"));
                }
                for _ in 0..50 {
                    let mid = 0.5 * (lo + hi);
                    set(&mut probe, mid);
                    let v = index_of(head, &probe, which).ok_or("indices undefined")?;
                    if v < goal {
                        lo = mid;
                    } else {
                        hi = mid;
                    }
                }
                set(&mut warp, 0.5 * (lo + hi));
            }
        }
    }
    let vmh = index_of(head, &warp, FacialIndex::VerticalMouthHeight).ok_or("indices undefined")?;
    let mw = index_of(head, &warp, FacialIndex::MouthWidth).ok_or("indices undefined")?;
    Ok(Speaker { index, spec, warp, vertical_mouth_height: vmh, mouth_width: mw })
}

impl Speaker {
    /// The classes of this speaker's indices under the published bounds.
    pub fn classes(&self) -> (Option<IndexClass>, Option<IndexClass>) {
        let table = BoundsTable::default();
        (
            table.classify(FacialIndex::VerticalMouthHeight, self.vertical_mouth_height),
            table.classify(FacialIndex::MouthWidth, self.mouth_width),
        )
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::demo::head::build_head;

    #[test]
    fn speakers_land_in_the_classes_they_were_made_for() {
        let head = build_head();
        for (i, spec) in default_specs(9).into_iter().enumerate() {
            let s = make_speaker(&head, i, spec, 1.0).unwrap();
            let (v, m) = s.classes();
            let want = spec.unwrap_or(SpeakerSpec {
                vertical_mouth_height: IndexClass::Middle,
                mouth_width: IndexClass::Middle,
            });
            assert_eq!(v, Some(want.vertical_mouth_height), "speaker {i}: {s:?}");
            assert_eq!(m, Some(want.mouth_width), "speaker {i}: {s:?}");
        }
    }
}
