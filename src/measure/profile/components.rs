//! Component cleanup of a thresholded mask: 4-connected labelling, the face taken as the
//! largest component touching the region's rear edge, and enclosed background pockets filled.

/// Labels the 4-connected components of `mask` (row-major, `width` wide). Returns the label
/// per pixel (`u32::MAX` off the mask) and each component's size.
pub fn connected_components(mask: &[bool], width: usize) -> (Vec<u32>, Vec<usize>) {
    let height = mask.len().checked_div(width).unwrap_or(0);
    let mut labels = vec![u32::MAX; mask.len()];
    let mut sizes = Vec::new();
    let mut stack = Vec::new();
    for start in 0..width * height {
        if !mask[start] || labels[start] != u32::MAX {
            continue;
        }
        let label = sizes.len() as u32;
        let mut size = 0;
        labels[start] = label;
        stack.push(start);
        while let Some(i) = stack.pop() {
            size += 1;
            let (r, c) = (i / width, i % width);
            let mut visit = |j: usize| {
                if mask[j] && labels[j] == u32::MAX {
                    labels[j] = label;
                    stack.push(j);
                }
            };
            if c > 0 {
                visit(i - 1);
            }
            if c + 1 < width {
                visit(i + 1);
            }
            if r > 0 {
                visit(i - width);
            }
            if r + 1 < height {
                visit(i + width);
            }
        }
        sizes.push(size);
    }
    (labels, sizes)
}

/// Keeps only the face in `mask` (row-major, `width` wide, column 0 the rear edge): the
/// largest component touching the rear edge, or the largest overall when none does (a
/// rendered head floating in the frame). Returns `false`, leaving `mask` as it was, when
/// that component has fewer than `min_component_px` pixels.
pub(super) fn keep_face_component(
    mask: &mut [bool],
    width: usize,
    min_component_px: usize,
) -> bool {
    let height = mask.len().checked_div(width).unwrap_or(0);
    let (labels, sizes) = connected_components(mask, width);
    let mut rear_touch = vec![false; sizes.len()];
    for r in 0..height {
        if let Some(&l) = labels.get(r * width).filter(|&&l| l != u32::MAX) {
            rear_touch[l as usize] = true;
        }
    }
    let pick = |touching: bool| {
        (0..sizes.len())
            .filter(|&l| !touching || rear_touch[l])
            .max_by_key(|&l| sizes[l])
            .filter(|&l| sizes[l] >= min_component_px.max(1))
    };
    let Some(face) = pick(true).or_else(|| pick(false)) else { return false };
    for (m, &l) in mask.iter_mut().zip(&labels) {
        *m = l == face as u32;
    }
    true
}

/// Fills the background pockets of `mask` that do not reach the region's border (specks
/// inside the face, a dark nostril): they are not background the profile could look into.
pub(super) fn fill_enclosed_holes(mask: &mut [bool], width: usize) {
    let height = mask.len().checked_div(width).unwrap_or(0);
    let inverse: Vec<bool> = mask.iter().map(|&m| !m).collect();
    let (holes, hole_sizes) = connected_components(&inverse, width);
    let mut open = vec![false; hole_sizes.len()];
    for r in 0..height {
        for u in 0..width {
            let on_border = r == 0 || r + 1 == height || u == 0 || u + 1 == width;
            let l = holes[r * width + u];
            if on_border && l != u32::MAX {
                open[l as usize] = true;
            }
        }
    }
    for (m, &l) in mask.iter_mut().zip(&holes) {
        if l != u32::MAX && !open[l as usize] {
            *m = true;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A `width`-wide mask from rows of `#` (on) and `.` (off).
    fn mask(rows: &[&str]) -> (Vec<bool>, usize) {
        (rows.iter().flat_map(|r| r.chars().map(|c| c == '#')).collect(), rows[0].len())
    }

    #[test]
    fn the_rear_touching_component_is_kept_even_when_smaller() {
        let (mut m, w) = mask(&["##....####", "##....####", "##....####", "......####"]);
        assert!(keep_face_component(&mut m, w, 1));
        assert_eq!(m, mask(&["##........", "##........", "##........", ".........."]).0);
    }

    #[test]
    fn without_a_rear_touching_component_the_largest_is_kept() {
        let (mut m, w) = mask(&["..##...###", "..##...###", ".......###"]);
        assert!(keep_face_component(&mut m, w, 1));
        assert_eq!(m, mask(&[".......###", ".......###", ".......###"]).0);
    }

    #[test]
    fn too_small_a_face_is_refused_and_the_mask_untouched() {
        let (mut m, w) = mask(&["##..", "#..."]);
        let before = m.clone();
        assert!(!keep_face_component(&mut m, w, 4));
        assert_eq!(m, before);
    }

    #[test]
    fn enclosed_pockets_are_filled_and_open_bays_are_not() {
        let (mut m, w) = mask(&["#####.", "#.#...", "#####.", "##..#.", "#####."]);
        fill_enclosed_holes(&mut m, w);
        assert_eq!(m, mask(&["#####.", "###...", "#####.", "#####.", "#####."]).0);
    }
}
