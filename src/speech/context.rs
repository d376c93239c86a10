//! Co-articulation context (Terissi et al. 2011, §3): the audio vector of frame t stacks the
//! per-frame features of frames t − t_c … t + t_c,
//! `o_at = [a_{t−t_c}ᵀ, …, a_tᵀ, …, a_{t+t_c}ᵀ]ᵀ`.

use crate::math::DMatrix;

/// Stacks each row of `frames` (T × d, one feature vector per video frame) with its `t_c`
/// neighbours on either side into a T × d(2t_c + 1) matrix, oldest frame first.
///
/// The paper does not say what happens at a clip's ends; frames beyond them repeat the first
/// or last frame, so every frame keeps a vector of the same size and silence-like edges stay
/// silence-like.
pub fn stack_context(frames: &DMatrix, t_c: usize) -> DMatrix {
    let (t_len, d) = frames.shape();
    let width = 2 * t_c + 1;
    let mut out = DMatrix::zeros(t_len, d * width);
    if t_len == 0 {
        return out;
    }
    for t in 0..t_len {
        for w in 0..width {
            let src = (t + w).saturating_sub(t_c).min(t_len - 1);
            for k in 0..d {
                out[(t, w * d + k)] = frames[(src, k)];
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stacks_neighbours_and_repeats_the_ends() {
        let a = DMatrix::from_row_slice(3, 1, &[1.0, 2.0, 3.0]);
        let s = stack_context(&a, 1);
        assert_eq!(
            s,
            DMatrix::from_row_slice(3, 3, &[1.0, 1.0, 2.0, 1.0, 2.0, 3.0, 2.0, 3.0, 3.0])
        );
        assert_eq!(stack_context(&a, 0), a);
    }
}
