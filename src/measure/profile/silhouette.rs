//! Segmentation of a region into the face silhouette (denoise, threshold, polarity, component
//! cleanup) and the silhouette's sub-pixel forward edge per row. Start at [`segment`].

use super::components::{fill_enclosed_holes, keep_face_component};
use super::denoise::remove_impulses;
use super::threshold::{histogram, otsu_threshold, refine_toward_background};
use super::{Facing, ProfileError, Rect, Threshold};
use crate::math::{Point2, Real};
use image::GrayImage;

/// Local face/background levels read beside an edge are used only when their contrast is at
/// least this share of the class medians' contrast; less means shading or a neighbouring
/// edge spoils them.
const MIN_LOCAL_CONTRAST: Real = 0.5;

/// Face and background levels closer than one gray level give no coverage to interpolate.
const MIN_LEVEL_SPAN: Real = 1.0;

/// A background pixel whose coverage lies in this band holds part of an edge; outside it,
/// noise on a clean pixel.
const MIXED_COVERAGE: (Real, Real) = (0.15, 0.85);

/// Share of rows with a mixed first background pixel at and above which a silhouette is
/// anti-aliased (about a third on optical or anti-aliased images, zero on hard-edged ones).
pub(super) const ANTIALIASED_MIN_SHARE: Real = 0.15;

/// A segmented region in forward coordinates (`u` = column counted in the facing direction).
pub(super) struct Silhouette {
    pub(super) region: Rect,
    pub(super) facing: Facing,
    pub(super) width: usize,
    pub(super) height: usize,
    /// Gray levels (median-filtered when asked), forward coordinates, row-major.
    pub(super) values: Vec<u8>,
    pub(super) mask: Vec<bool>,
    /// Typical face and background levels (class medians), for sub-pixel edges.
    pub(super) fg_level: Real,
    pub(super) bg_level: Real,
    pub(super) threshold: u8,
}

/// Segments the face silhouette inside `region`.
///
/// Polarity: the background is the class holding most of the region's front column (the
/// face looks toward it), or, if that column is evenly split, the class missing from the rear
/// column. Cleanup: only the largest component touching the rear edge is kept (the largest
/// overall if none touches, e.g. a rendered head floating in the frame), and background
/// pockets that do not reach the region's border are filled.
pub(super) fn segment(
    image: &GrayImage,
    region: Rect,
    facing: Facing,
    threshold: Threshold,
    denoise: bool,
    min_component_px: usize,
) -> Result<Silhouette, ProfileError> {
    let (iw, ih) = image.dimensions();
    let region = match region.clamped_to(iw, ih) {
        Some(r) if r == region => r,
        _ => return Err(ProfileError::CropOutside(region, iw, ih)),
    };
    let (w, h) = (region.width as usize, region.height as usize);
    let mut values = vec![0u8; w * h];
    for r in 0..h {
        for u in 0..w {
            let c = match facing {
                Facing::Right => u,
                Facing::Left => w - 1 - u,
            };
            values[r * w + u] = image.get_pixel(region.x + c as u32, region.y + r as u32).0[0];
        }
    }
    if denoise && w >= 3 && h >= 3 {
        values = remove_impulses(&values, w, h);
    }
    let hist = histogram(&values);
    let t0 = match threshold {
        Threshold::Otsu => otsu_threshold(&hist).ok_or(ProfileError::Uniform)?,
        Threshold::Manual(t) => t,
    };
    let front_bright = (0..h).filter(|&r| values[r * w + w - 1] > t0).count();
    let rear_bright = (0..h).filter(|&r| values[r * w] > t0).count();
    let background_bright =
        if 2 * front_bright != h { 2 * front_bright > h } else { 2 * rear_bright < h };
    let t = match threshold {
        Threshold::Otsu => refine_toward_background(&hist, t0, background_bright),
        Threshold::Manual(t) => t,
    };
    let bright = |v: u8| v > t;
    let mut mask: Vec<bool> = values.iter().map(|&v| bright(v) != background_bright).collect();

    if !keep_face_component(&mut mask, w, min_component_px) {
        return Err(ProfileError::NoSilhouette(min_component_px));
    }
    fill_enclosed_holes(&mut mask, w);
    let class_median = |fg: bool| {
        let mut hist = [0u64; 256];
        let mut n = 0u64;
        for &v in values.iter().filter(|&&v| (bright(v) != background_bright) == fg) {
            hist[v as usize] += 1;
            n += 1;
        }
        if n == 0 {
            return None;
        }
        let mut acc = 0u64;
        hist.iter().position(|&c| {
            acc += c;
            2 * acc >= n
        })
    };
    let fg_level = class_median(true).unwrap_or(if background_bright { 0 } else { 255 }) as Real;
    let bg_level = class_median(false).unwrap_or(if background_bright { 255 } else { 0 }) as Real;
    Ok(Silhouette {
        region,
        facing,
        width: w,
        height: h,
        values,
        mask,
        fg_level,
        bg_level,
        threshold: t,
    })
}

impl Silhouette {
    /// Sub-pixel forward edge per row, in forward coordinates (`None` for rows without face),
    /// and whether the face reaches the front edge there.
    ///
    /// With `c` the foremost face pixel and coverage `k(v) = (v − B)/(F − B)` clamped to
    /// [0, 1], the edge is at `c − ½ + k(c) + k(c + 1)`: exact for an anti-aliased straight
    /// edge whichever of the two pixels holds it. `F`, `B` are read two pixels inside and
    /// outside the edge when those are clean, else the class medians (shaded renders).
    pub(super) fn forward_edges(&self) -> Vec<Option<(Real, bool)>> {
        let w = self.width;
        (0..self.height)
            .map(|r| {
                let row = &self.mask[r * w..(r + 1) * w];
                let vals = &self.values[r * w..(r + 1) * w];
                let c = row.iter().rposition(|&m| m)?;
                let global = self.fg_level - self.bg_level;
                let mut f = self.fg_level;
                let mut b = self.bg_level;
                if c >= 2 && row[c - 2] {
                    f = vals[c - 2] as Real;
                }
                if c + 2 < w && !row[c + 2] {
                    b = vals[c + 2] as Real;
                }
                if ((f - b) / global).is_nan() || (f - b).abs() < MIN_LOCAL_CONTRAST * global.abs()
                {
                    f = self.fg_level;
                    b = self.bg_level;
                }
                let k = |i: usize| {
                    if i >= w || (f - b).abs() < MIN_LEVEL_SPAN {
                        0.0
                    } else {
                        ((vals[i] as Real - b) / (f - b)).clamp(0.0, 1.0)
                    }
                };
                let e = c as Real - 0.5 + k(c) + k(c + 1);
                Some((e.clamp(c as Real - 0.5, c as Real + 1.5), c + 1 == w))
            })
            .collect()
    }

    /// Share of edge rows whose first background pixel holds an intermediate gray level
    /// (15–85 % of the way from background to face): about a third on anti-aliased or
    /// optical images (wherever the edge falls in that pixel), zero on hard-edged renders.
    /// Only the background side is looked at: shading darkens the face's own edge pixels.
    pub(super) fn antialiased_share(&self) -> Real {
        let w = self.width;
        let span = self.fg_level - self.bg_level;
        if span.abs() < MIN_LEVEL_SPAN {
            return 0.0;
        }
        let (mut rows, mut soft) = (0usize, 0usize);
        for r in 0..self.height {
            let row = &self.mask[r * w..(r + 1) * w];
            let Some(c) = row.iter().rposition(|&m| m) else { continue };
            rows += 1;
            let mid = |i: usize| {
                i < w && {
                    let k = (self.values[r * w + i] as Real - self.bg_level) / span;
                    (MIXED_COVERAGE.0..=MIXED_COVERAGE.1).contains(&k)
                }
            };
            if mid(c + 1) {
                soft += 1;
            }
        }
        if rows == 0 { 0.0 } else { soft as Real / rows as Real }
    }

    /// Forward coordinate `u` (may be fractional) of row `r` as an image point.
    pub(super) fn to_image(&self, u: Real, r: Real) -> Point2 {
        let x = match self.facing {
            Facing::Right => u,
            Facing::Left => self.width as Real - 1.0 - u,
        };
        Point2::new(self.region.x as Real + x, self.region.y as Real + r)
    }
}

/// Forward profile of the whole frame: per row, the silhouette's sub-pixel forward edge
/// (image px) and its forward coordinate `u` (px from the rear image edge).
pub(super) fn full_frame_profile(
    image: &GrayImage,
    facing: Facing,
    threshold: Threshold,
    denoise: bool,
    min_component_px: usize,
) -> Result<Vec<Option<(Point2, Real)>>, ProfileError> {
    let (w, h) = image.dimensions();
    let sil = segment(image, Rect::full(w, h), facing, threshold, denoise, min_component_px)?;
    Ok(sil
        .forward_edges()
        .into_iter()
        .enumerate()
        .map(|(r, e)| e.map(|(u, _)| (sil.to_image(u, r as Real), u)))
        .collect())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::measure::profile::synthetic::{BACKGROUND, FACE, HEIGHT, WIDTH, draw};

    fn straight(x: f64) -> impl Fn(f64) -> f64 {
        move |_| x
    }

    #[test]
    fn a_straight_anti_aliased_edge_is_found_to_a_hundredth_of_a_pixel() {
        for x0 in [80.0, 80.3, 80.5, 80.85] {
            let img = draw(straight(x0), Facing::Right, FACE, BACKGROUND);
            let region = Rect::new(40, 10, 100, 50);
            let sil = segment(&img, region, Facing::Right, Threshold::Otsu, true, 50).unwrap();
            for (r, e) in sil.forward_edges().into_iter().enumerate() {
                let (u, at_front) = e.unwrap();
                let p = sil.to_image(u, r as Real);
                assert!((p.x - x0).abs() < 0.01 && !at_front, "{x0}: {}", p.x);
            }
        }
    }

    #[test]
    fn facing_left_and_a_dark_face_give_the_mirrored_edge() {
        let img = draw(straight(80.3), Facing::Left, BACKGROUND, FACE);
        let region = Rect::new(WIDTH - 140, 10, 100, 50);
        let sil = segment(&img, region, Facing::Left, Threshold::Otsu, true, 50).unwrap();
        let (u, _) = sil.forward_edges()[7].unwrap();
        let p = sil.to_image(u, 7.0);
        assert!((p.x - (WIDTH as Real - 1.0 - 80.3)).abs() < 0.01, "{}", p.x);
        assert!((p.y - 17.0).abs() < 1e-12);
    }

    #[test]
    fn bad_regions_are_errors() {
        let img = draw(straight(80.0), Facing::Right, FACE, BACKGROUND);
        let outside = Rect::new(WIDTH - 10, 0, 20, 10);
        assert!(matches!(
            segment(&img, outside, Facing::Right, Threshold::Otsu, true, 50),
            Err(ProfileError::CropOutside(..))
        ));
        let uniform = Rect::new(0, 0, 50, HEIGHT);
        assert!(matches!(
            segment(&img, uniform, Facing::Right, Threshold::Otsu, true, 50),
            Err(ProfileError::Uniform)
        ));
        let sliver = Rect::new(79, 0, 10, 3);
        assert!(matches!(
            segment(&img, sliver, Facing::Right, Threshold::Otsu, true, 50),
            Err(ProfileError::NoSilhouette(50))
        ));
    }
}
