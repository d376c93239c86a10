//! Foreground/background gray threshold: Otsu's (Otsu 1979) over the region's histogram,
//! then moved toward the background while the background's side still holds a compact
//! second face tone (lips or shadow on a dark background).

/// Otsu's threshold (Otsu 1979): the `t` maximising the between-class variance
/// `ω₀ω₁(μ₀ − μ₁)²` of the classes `<= t` and `> t`. When a range of `t` ties (empty bins
/// between two clusters), the middle of the range is returned, so a half-covered edge pixel
/// falls on the side it is closer to. `None` when the histogram has fewer than two levels.
///
/// ```
/// let mut h = [0u64; 256];
/// h[10] = 3;
/// h[200] = 3;
/// assert_eq!(lipmap::measure::profile::otsu_threshold(&h), Some(104));
/// ```
pub fn otsu_threshold(histogram: &[u64; 256]) -> Option<u8> {
    let n: f64 = histogram.iter().map(|&c| c as f64).sum();
    let sum: f64 = histogram.iter().enumerate().map(|(v, &c)| v as f64 * c as f64).sum();
    let (mut n0, mut s0) = (0.0, 0.0);
    let mut best = -1.0;
    let (mut first, mut last) = (0usize, 0usize);
    for (t, &c) in histogram.iter().enumerate().take(255) {
        n0 += c as f64;
        s0 += t as f64 * c as f64;
        let n1 = n - n0;
        if n0 == 0.0 || n1 == 0.0 {
            continue;
        }
        let diff = s0 / n0 - (sum - s0) / n1;
        let var = n0 * n1 * diff * diff;
        if var > best * (1.0 + 1e-12) {
            best = var;
            first = t;
            last = t;
        } else if var >= best * (1.0 - 1e-12) && last + 1 == t {
            last = t;
        }
    }
    (best > 0.0).then(|| ((first + last) / 2) as u8)
}

/// Histogram of gray levels.
pub fn histogram(values: &[u8]) -> [u64; 256] {
    let mut h = [0u64; 256];
    for &v in values {
        h[v as usize] += 1;
    }
    h
}

/// Smallest share of the region a second tone on the background's side must have to count
/// as face. A small lip in a wide crop can cover as little as 2 % of it, so a floor at 2 %
/// would keep the lip on some frames and lose it on their neighbours; anti-aliased edge
/// pixels are kept out by the compactness test instead.
const SECOND_MODE_MIN_SHARE: f64 = 0.01;

/// Smallest share of the region the background itself must have: the crop's front part is
/// background by construction, so a few stray pixels beyond the background's level are not it.
const BACKGROUND_MIN_SHARE: f64 = 0.05;

/// A second tone must be peaked: its σ at most this fraction of the σ of a uniform spread
/// over its gray interval (`width/√12`). Anti-aliased edge pixels spread about uniformly
/// between the tones (ratio near 1); a shaded lip is a clear mode (ratio around 0.5).
const SECOND_MODE_MAX_SPREAD: f64 = 0.75;

/// A second tone's mean must lie this many background σ...
const SECOND_MODE_MIN_SEPARATION_SD: f64 = 4.0;
/// ...plus this many gray levels from the background's mean: σ alone would let a perfectly
/// flat background (σ = 0) call its neighbouring level a second tone.
const SECOND_MODE_MIN_SEPARATION_LEVELS: f64 = 8.0;

/// A second tone's σ must stay below this share of the split side's gray span: a mode, not
/// the whole side.
const SECOND_MODE_MAX_SPAN_SHARE: f64 = 0.2;

/// Re-splits at most this often: skin, lips and a shadow are the most tones a mouth crop
/// holds on the background's side, so a fourth split would only cut noise.
const MAX_REFINEMENTS: usize = 3;

/// Otsu splits the histogram's two strongest tones, which in a mouth crop on a dark
/// background can be the lips and the skin rather than face and background (the background
/// is often the minority). So while the background's side of `t` still holds a compact second
/// tone — at least [`SECOND_MODE_MIN_SHARE`] of the pixels, clearly apart from the background
/// (mean more than 4 σ + 8 levels away) and not a smear (σ below a fifth of the side's span
/// and below [`SECOND_MODE_MAX_SPREAD`] of a uniform spread), with the part left beyond it
/// holding at least [`BACKGROUND_MIN_SHARE`] (a handful of stray pixels is no background) —
/// that side is split again by Otsu, moving `t` toward the background.
pub(super) fn refine_toward_background(
    hist: &[u64; 256],
    mut t: u8,
    background_bright: bool,
) -> u8 {
    let total: f64 = hist.iter().map(|&c| c as f64).sum();
    let stats = |range: std::ops::RangeInclusive<usize>| {
        let n: f64 = range.clone().map(|v| hist[v] as f64).sum();
        if n == 0.0 {
            return (0.0, 0.0, 0.0);
        }
        let mean = range.clone().map(|v| v as f64 * hist[v] as f64).sum::<f64>() / n;
        let var = range.map(|v| (v as f64 - mean).powi(2) * hist[v] as f64).sum::<f64>() / n;
        (n, mean, var.sqrt())
    };
    for _ in 0..MAX_REFINEMENTS {
        let side = if background_bright { t as usize + 1..=255 } else { 0..=t as usize };
        let mut sub = [0u64; 256];
        for v in side.clone() {
            sub[v] = hist[v];
        }
        let Some(t2) = otsu_threshold(&sub) else { break };
        let t2 = t2 as usize;
        let (bg, other) = if background_bright {
            (t2 + 1..=*side.end(), *side.start()..=t2)
        } else {
            (*side.start()..=t2, t2 + 1..=*side.end())
        };
        let other_range = other.clone();
        let (bg_n, bg_mean, bg_sd) = stats(bg);
        let (n, mean, sd) = stats(other);
        let span = (side.end() - side.start()) as f64;
        let distinct = (mean - bg_mean).abs()
            > SECOND_MODE_MIN_SEPARATION_SD * bg_sd + SECOND_MODE_MIN_SEPARATION_LEVELS;
        // The split-off extreme must itself be a real tone: a few stray pixels darker (or
        // brighter) than the background would otherwise be taken for it, and the whole
        // background for a second face tone.
        let shares = n / total >= SECOND_MODE_MIN_SHARE && bg_n / total >= BACKGROUND_MIN_SHARE;
        let width = (other_range.end() - other_range.start() + 1) as f64;
        let compact = sd < SECOND_MODE_MAX_SPAN_SHARE * span
            && sd < SECOND_MODE_MAX_SPREAD * width / 12f64.sqrt();
        if shares && distinct && compact {
            t = t2 as u8;
        } else {
            break;
        }
    }
    t
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A histogram of tones `(level, count)`, each spread evenly over level ± 3.
    fn tones(t: &[(usize, u64)]) -> [u64; 256] {
        let mut h = [0u64; 256];
        for &(v, c) in t {
            for d in 0..7 {
                h[v + d - 3] += c / 7;
            }
        }
        h
    }

    #[test]
    fn otsu_splits_two_tones_between_them() {
        let t = otsu_threshold(&tones(&[(40, 700), (200, 700)])).unwrap();
        assert!((43..197).contains(&t), "{t}");
        assert_eq!(otsu_threshold(&histogram(&[9; 20])), None);
    }

    #[test]
    fn lips_on_a_dark_background_move_the_threshold_below_them() {
        // Dark background 30 %, lips 10 %, skin 60 %: Otsu alone splits lips from skin.
        let h = tones(&[(30, 300), (110, 100), (190, 600)]);
        let t0 = otsu_threshold(&h).unwrap();
        assert!(t0 > 113, "{t0}");
        let t = refine_toward_background(&h, t0, false);
        assert!((33..107).contains(&t), "{t}");
    }

    #[test]
    fn two_tones_keep_otsus_threshold() {
        let h = tones(&[(30, 400), (190, 600)]);
        let t0 = otsu_threshold(&h).unwrap();
        assert_eq!(refine_toward_background(&h, t0, false), t0);
        // A handful of stray pixels darker than the background are no background of their own.
        let mut h = tones(&[(60, 400), (190, 600)]);
        h[5] = 3;
        let t0 = otsu_threshold(&h).unwrap();
        assert_eq!(refine_toward_background(&h, t0, false), t0);
    }
}
