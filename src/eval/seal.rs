//! Sealed lips as the tables measure them: on the frames where the video's inner lips meet
//! (its H at or below `landmarks::closure::MEET_SHARE` of the clip's widest; a sealed frame's
//! H is 0), how far apart the head's inner lips are, as a share of the head's widest opening
//! over the clip. Both are the H of the tables, so the figure is in the comparison the tables
//! name (frontal or image plane) and is unaffected by how the mouth is normalised.
//!
//! The share means something only when the head opens: a model that cannot follow the
//! mouth's opening (the SFM shape model without its expression blendshapes parts its lips by
//! less than a millimetre) has a "widest opening" of the same size as its gap at the seals,
//! and the share is a ratio of two sub-pixel numbers. The head's widest H against the video's
//! ([`LipSeal::opening_ratio`]) says whether it does. `docs/closure.md` has the figures.

use super::Utterance;
use super::report::{Cell, Table};
use crate::landmarks::closure::meeting;

/// The head's inner-lip gap on the frames where the video's lips meet, in H units.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LipSeal {
    /// Frames where the video's lips meet and the head was measured.
    pub frames: usize,
    /// The head's median H on them.
    pub head_median: f64,
    /// The head's largest H on them.
    pub head_max: f64,
    /// The head's widest H over the clip.
    pub head_widest: f64,
    /// The video's widest H over the clip.
    pub video_widest: f64,
}

impl LipSeal {
    /// The median gap as a share of the widest opening (0–1).
    pub fn share(&self) -> f64 {
        self.head_median / self.head_widest
    }

    /// The head's widest opening as a share of the video's (0–1 and above): both are H in
    /// the same comparison, so a head fitted to the video's points that follows its mouth
    /// reads near 1, and one whose model cannot open its lips reads near 0.
    pub fn opening_ratio(&self) -> f64 {
        self.head_widest / self.video_widest
    }

    /// Whether the head opens at all in the sense the share needs: its widest opening is at
    /// least [`LEAST_OPENING_RATIO`] of the video's.
    pub fn head_opens(&self) -> bool {
        self.opening_ratio() >= LEAST_OPENING_RATIO
    }
}

/// Least share of the video's widest H the head's widest must reach for the sealed-lips
/// share to measure sealing. A fitted head measured like the video follows its opening: 84 %
/// of it on carphone with the SFM model and its expressions, 85–104 % on held-out demo
/// speakers 0–2; the SFM shape model alone reaches 1.4 % (`docs/closure.md`). A quarter
/// leaves a wide margin to both.
pub const LEAST_OPENING_RATIO: f64 = 0.25;

/// [`LipSeal`] of an utterance (its raw, not normalised, H); `None` when the video's lips
/// never meet on a frame the head was measured on, or the head never opens.
pub fn lip_seal(u: &Utterance) -> Option<LipSeal> {
    let head_widest = u.head.h.iter().flatten().copied().fold(0.0, f64::max);
    let video_widest = u.video.h.iter().flatten().copied().fold(0.0, f64::max);
    let mut gaps: Vec<f64> = meeting(&u.video.h)
        .iter()
        .zip(&u.head.h)
        .filter_map(|(meet, h)| h.filter(|_| *meet))
        .collect();
    if gaps.is_empty() || head_widest <= 0.0 || video_widest <= 0.0 {
        return None;
    }
    gaps.sort_by(f64::total_cmp);
    let n = gaps.len();
    let head_median = if n % 2 == 1 { gaps[n / 2] } else { 0.5 * (gaps[n / 2 - 1] + gaps[n / 2]) };
    Some(LipSeal { frames: n, head_median, head_max: gaps[n - 1], head_widest, video_widest })
}

/// One row per sentence (its name and [`lip_seal`]): where the video's lips meet, the head's
/// H there (median and largest), its widest H, the median's share of it and the head's
/// widest as a share of the video's (below [`LEAST_OPENING_RATIO`] the head does not open
/// and the share says nothing about sealing). Sentences whose lips never meet get a row of
/// blanks after their frame count of 0.
pub fn seal_table(seals: &[(String, Option<LipSeal>)]) -> Table {
    let headers = ["sentence", "frames lips meet", "head H median", "head H max", "head H widest"];
    let mut headers: Vec<String> = headers.iter().map(|h| h.to_string()).collect();
    headers.push("median % of widest".into());
    headers.push("head widest % of video's".into());
    let mut t = Table::new("sealed lips: the head's H where the video's lips meet", headers);
    for (sentence, seal) in seals {
        let mut row = vec![Cell::text(sentence)];
        match seal {
            Some(s) => row.extend([
                Cell::Int(s.frames as i64),
                Cell::num(Some(s.head_median)),
                Cell::num(Some(s.head_max)),
                Cell::num(Some(s.head_widest)),
                Cell::num(Some(100.0 * s.share())),
                Cell::num(Some(100.0 * s.opening_ratio())),
            ]),
            None => row.push(Cell::Int(0)),
        }
        t.push_row(row);
    }
    t.notes.push(format!(
        "lips meet: the video's H at or below {:.0} % of its widest in the clip (0 on sealed frames)",
        100.0 * crate::landmarks::closure::MEET_SHARE
    ));
    if seals.iter().any(|(_, s)| s.is_some_and(|s| !s.head_opens())) {
        t.notes.push(format!(
            "a head whose widest opening is below {:.0} % of the video's does not open: its \
             share measures no sealing (the model cannot part its lips; `lipmap eval` says why)",
            100.0 * LEAST_OPENING_RATIO
        ));
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measure::Trajectory;

    fn utterance(video: &[f64], head: &[f64]) -> Utterance {
        let mut u = Utterance { name: "s".into(), fps: 25.0, ..Default::default() };
        u.video = Trajectory { h: video.iter().map(|v| Some(*v)).collect(), ..Default::default() };
        u.head = Trajectory { h: head.iter().map(|v| Some(*v)).collect(), ..Default::default() };
        u
    }

    #[test]
    fn the_heads_gap_where_the_video_meets_as_a_share_of_its_widest() {
        // Video meets on frames 0, 1 and 4 (≤ 5 % of 1.0); the head keeps 0.1, 0.3 and 0.2.
        let u = utterance(&[0.0, 0.04, 0.6, 1.0, 0.0], &[0.1, 0.3, 1.5, 2.0, 0.2]);
        let s = lip_seal(&u).unwrap();
        assert_eq!(s.frames, 3);
        assert!((s.head_median - 0.2).abs() < 1e-12 && (s.head_max - 0.3).abs() < 1e-12);
        assert!((s.share() - 0.1).abs() < 1e-12, "{s:?}");
        let apart = utterance(&[0.5, 0.6], &[1.0, 1.0]);
        let t = seal_table(&[u, apart].map(|u| (u.name.clone(), lip_seal(&u))));
        assert!(matches!(t.rows[0][5], Cell::Num(v) if (v - 10.0).abs() < 1e-9), "{:?}", t.rows[0]);
        assert!(
            matches!(t.rows[0][6], Cell::Num(v) if (v - 200.0).abs() < 1e-9),
            "{:?}",
            t.rows[0]
        );
        assert_eq!(t.rows[1], vec![Cell::text("s"), Cell::Int(0)]);
        assert_eq!(t.notes.len(), 1, "{:?}", t.notes);
    }

    #[test]
    fn a_head_that_never_opens_is_named_not_scored() {
        // The head parts its lips by 0.02 at most where the video opens to 1.0: its "share"
        // of 0.3 is noise on an opening it never makes.
        let u = utterance(&[0.0, 0.0, 1.0, 0.5], &[0.006, 0.006, 0.02, 0.01]);
        let s = lip_seal(&u).unwrap();
        assert!((s.opening_ratio() - 0.02).abs() < 1e-12 && !s.head_opens(), "{s:?}");
        let t = seal_table(&[(u.name.clone(), Some(s))]);
        assert!(t.notes.iter().any(|n| n.contains("does not open")), "{:?}", t.notes);
    }
}
