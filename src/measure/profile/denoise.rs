//! Salt-and-pepper removal before thresholding, leaving edges untouched.

/// Gray levels by which an impulse must stand outside all 8 neighbours to be removed.
const IMPULSE_MARGIN: u8 = 16;

/// Switching 3×3 median (edges replicate): a pixel is replaced by its window's median only
/// when it lies more than [`IMPULSE_MARGIN`] outside the range of all 8 neighbours, i.e. it
/// is an isolated salt-and-pepper impulse. Unlike a plain median this leaves edges and the
/// sharp corners of a silhouette (nose tip, lip) exactly as they were.
pub(super) fn remove_impulses(values: &[u8], width: usize, height: usize) -> Vec<u8> {
    let mut out = values.to_vec();
    let mut win = [0u8; 9];
    for r in 0..height {
        for c in 0..width {
            let mut k = 0;
            for dr in [-1isize, 0, 1] {
                let rr = (r as isize + dr).clamp(0, height as isize - 1) as usize;
                for dc in [-1isize, 0, 1] {
                    let cc = (c as isize + dc).clamp(0, width as isize - 1) as usize;
                    win[k] = values[rr * width + cc];
                    k += 1;
                }
            }
            let v = win[4];
            let (lo, hi) = win
                .iter()
                .enumerate()
                .filter(|&(i, _)| i != 4)
                .fold((u8::MAX, u8::MIN), |(lo, hi), (_, &x)| (lo.min(x), hi.max(x)));
            if v > hi.saturating_add(IMPULSE_MARGIN) || v.saturating_add(IMPULSE_MARGIN) < lo {
                win.sort_unstable();
                out[r * width + c] = win[4];
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_isolated_speck_goes_and_an_edge_stays() {
        let (w, h) = (8, 6);
        // A vertical step edge between columns 3 and 4, a corner pixel, and one speck.
        let mut v: Vec<u8> = (0..w * h).map(|i| if i % w < 4 { 200 } else { 40 }).collect();
        v[w + 6] = 250;
        v[4 * w + 4] = 200; // a one-pixel corner jutting from the edge: not isolated
        let out = remove_impulses(&v, w, h);
        assert_eq!(out[w + 6], 40);
        let mut expected = v.clone();
        expected[w + 6] = 40;
        assert_eq!(out, expected);
    }
}
