//! Mouth trajectories from phone timings by the Cohen–Massaro coarticulation model: each
//! phone segment pulls every articulatory parameter towards its viseme's target with a
//! dominance that decays exponentially from the segment's centre, and the parameter at time t
//! is the dominance-weighted mean of the targets (Cohen & Massaro 1993, "Modeling
//! coarticulation in synthetic visual speech").
//!
//! `D_sk(t) = α_sk · exp(−θ_s± · |t − c_s|)` with c = 1 (the published exponent is a
//! parameter; 1 gives the classic tent-shaped spread), θ− before the centre (anticipation),
//! θ+ after it (carry-over). Bilabials and labiodentals dominate the closure parameters
//! strongly, so lips close fully inside /b p m/ whatever the vowels around them; rounded
//! segments dominate the lip-shape parameters and anticipate slowly, so rounding spreads
//! back over preceding consonants, as it does in speech.

use super::visemes::{Articulation, N_PARAMS, Viseme, phone_viseme};
use crate::alignment::Alignment;

/// Which parameters set the mouth's opening (as opposed to its shape).
const CLOSURE: [bool; N_PARAMS] = [true, false, false, false, true, true, true, true];

/// Dominance of a segment: magnitude per parameter and decay rates (1/s) before and after
/// the centre.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Dominance {
    pub alpha: [f64; N_PARAMS],
    pub theta_before: f64,
    pub theta_after: f64,
}

/// The dominance of a viseme (`None` = silence, whose target is the neutral face).
pub fn dominance(viseme: Option<Viseme>) -> Dominance {
    let (closure, shape, before, after) = match viseme {
        None => (1.5, 1.5, 15.0, 15.0),
        Some(Viseme::Pbm) => (20.0, 0.8, 50.0, 50.0),
        Some(Viseme::Fv) => (12.0, 0.8, 45.0, 45.0),
        Some(Viseme::W | Viseme::Uw | Viseme::Ao | Viseme::Sh | Viseme::R) => (2.0, 5.0, 8.0, 15.0),
        Some(Viseme::Tdn | Viseme::Kg | Viseme::L | Viseme::Sz | Viseme::Th) => {
            (1.0, 0.3, 20.0, 20.0)
        }
        Some(_) => (2.0, 1.0, 18.0, 18.0),
    };
    let mut alpha = [0.0; N_PARAMS];
    for (k, a) in alpha.iter_mut().enumerate() {
        *a = if CLOSURE[k] { closure } else { shape };
    }
    Dominance { alpha, theta_before: before, theta_after: after }
}

/// The articulation at each frame time `f / fps`, for `n_frames` frames.
///
/// Empty alignments give the neutral face throughout.
pub fn mouth_trajectory(alignment: &Alignment, fps: f64, n_frames: usize) -> Vec<Articulation> {
    let segments: Vec<(f64, Articulation, Dominance)> = alignment
        .phones
        .iter()
        .map(|p| {
            let v = phone_viseme(&p.label);
            let target = v.map_or_else(Articulation::default, Viseme::target);
            (0.5 * (p.start + p.end), target, dominance(v))
        })
        .collect();
    (0..n_frames)
        .map(|f| {
            let t = f as f64 / fps;
            let mut num = [0.0; N_PARAMS];
            let mut den = [0.0; N_PARAMS];
            for (c, target, d) in &segments {
                let dt = t - c;
                let theta = if dt < 0.0 { d.theta_before } else { d.theta_after };
                let decay = (-theta * dt.abs()).exp();
                let tg = target.to_array();
                for k in 0..N_PARAMS {
                    let w = d.alpha[k] * decay;
                    num[k] += w * tg[k];
                    den[k] += w;
                }
            }
            let mut out = [0.0; N_PARAMS];
            for k in 0..N_PARAMS {
                // Far from every segment all weights underflow: rest at neutral.
                out[k] = if den[k] > 1e-300 { num[k] / den[k] } else { 0.0 };
            }
            Articulation::from_array(out)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::alignment::Phone;

    fn ph(start: f64, end: f64, label: &str) -> Phone {
        Phone { start, end, label: label.into() }
    }

    #[test]
    fn bilabials_close_the_jaw_between_open_vowels() {
        let a = Alignment {
            phones: vec![
                ph(0.0, 0.2, "sil"),
                ph(0.2, 0.35, "AA1"),
                ph(0.35, 0.43, "B"),
                ph(0.43, 0.58, "AA1"),
                ph(0.58, 0.9, "sil"),
            ],
        };
        let traj = mouth_trajectory(&a, 100.0, 90);
        let open = traj[27].jaw_deg;
        let closed = traj[39].jaw_deg;
        assert!(open > 8.0, "vowel jaw {open}");
        assert!(closed < 0.1 * open, "bilabial jaw {closed} vs {open}");
        assert!(traj[0].jaw_deg < 1.0);
    }

    #[test]
    fn rounding_is_anticipated_over_a_consonant() {
        let a = Alignment {
            phones: vec![ph(0.0, 0.2, "IY1"), ph(0.2, 0.28, "T"), ph(0.28, 0.45, "UW1")],
        };
        let traj = mouth_trajectory(&a, 100.0, 45);
        // Inside /t/ the lips are already more rounded than spread.
        assert!(traj[24].round_mm > 0.5 * Viseme::Uw.target().round_mm, "{:?}", traj[24]);
    }
}
