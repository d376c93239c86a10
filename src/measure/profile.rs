//! Lip protrusion P from side-view frames: silhouette segmentation (Otsu), the lip profile,
//! the upper lip's foremost point, its distance to a reference line, nose-length normalisation.
//!
//! Start at [`measure_frame`] (one frame) or [`extract_protrusion`] (a clip); [`propose_setup`]
//! finds a crop, reference line and nose length from one frame so no clicking is needed.
//!
//! Coordinates are image pixels, x right, y down, pixel centres on integers (pixel `i` covers
//! `[i − 0.5, i + 0.5)`). Internally a crop is read in *forward* coordinates: column `u` grows
//! in the direction the face looks (the crop is mirrored when the face looks left), so one code
//! path serves both facings. The same extraction runs on rendered side views of a fitted head
//! ([`measure_render`]), so video and head are measured the same way.

use crate::landmarks::PointSource;
use crate::math::{Point2, Real, Vector2};
use image::{GrayImage, RgbImage};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;

/// An axis-aligned pixel rectangle: columns `x..x + width`, rows `y..y + height`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct Rect {
    pub x: u32,
    pub y: u32,
    pub width: u32,
    pub height: u32,
}

impl Rect {
    pub fn new(x: u32, y: u32, width: u32, height: u32) -> Self {
        Self { x, y, width, height }
    }

    /// The whole of a `width` × `height` image.
    pub fn full(width: u32, height: u32) -> Self {
        Self { x: 0, y: 0, width, height }
    }

    /// This rectangle cut to a `width` × `height` image; `None` when nothing is left.
    pub fn clamped_to(&self, width: u32, height: u32) -> Option<Rect> {
        let x0 = self.x.min(width);
        let y0 = self.y.min(height);
        let x1 = self.x.saturating_add(self.width).min(width);
        let y1 = self.y.saturating_add(self.height).min(height);
        (x1 > x0 && y1 > y0).then(|| Rect::new(x0, y0, x1 - x0, y1 - y0))
    }
}

/// Which way the face looks in the side image.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Facing {
    /// The nose points toward −x.
    Left,
    /// The nose points toward +x.
    Right,
}

impl Facing {
    /// +1 when forward is +x, −1 when it is −x.
    pub fn sign(self) -> Real {
        match self {
            Facing::Left => -1.0,
            Facing::Right => 1.0,
        }
    }
}

/// A line parallel to the frontal plane, through image points `a` and `b` (px). P is measured
/// from it along its normal, positive in front of it (the way the face looks).
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct ReferenceLine {
    pub a: Point2,
    pub b: Point2,
}

impl ReferenceLine {
    /// The vertical line `x = x_px`.
    pub fn vertical(x_px: Real) -> Self {
        Self { a: Point2::new(x_px, 0.0), b: Point2::new(x_px, 1.0) }
    }

    /// The line through `point` leaning `tilt_deg` from vertical; positive tilt moves its
    /// lower end toward +x (direction `(sin θ, cos θ)`, y down).
    pub fn through(point: Point2, tilt_deg: Real) -> Self {
        let t = tilt_deg.to_radians();
        Self { a: point, b: point + Vector2::new(t.sin(), t.cos()) }
    }

    /// The unit normal pointing the way the face looks. `None` when the points coincide or
    /// the line lies within 30° of horizontal: a "frontal" line that flat cannot be meant, and
    /// per-row profiles stop being a function of the row there.
    pub fn forward_normal(&self, facing: Facing) -> Option<Vector2> {
        let d = self.b - self.a;
        let len = d.norm();
        if !(len.is_finite() && len > 1e-9) {
            return None;
        }
        let d = d / len;
        let mut n = Vector2::new(d.y, -d.x);
        if n.x * facing.sign() < 0.0 {
            n = -n;
        }
        (n.x.abs() >= 0.5).then_some(n)
    }

    /// Signed distance (px) of `p` from the line along the forward normal.
    pub fn signed_distance(&self, p: Point2, facing: Facing) -> Option<Real> {
        self.forward_normal(facing).map(|n| (p - self.a).dot(&n))
    }
}

/// How foreground (face) and background are separated.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Threshold {
    /// Otsu's threshold over the crop's histogram.
    #[default]
    Otsu,
    /// Fixed gray level: pixels `<= t` form one class, `> t` the other.
    Manual(u8),
}

/// The length P is divided by: the nose root (nasion) to nose tip distance.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum NoseLength {
    /// Not set: only `p_px` is reported.
    #[default]
    Unset,
    /// A length in px.
    Px(Real),
    /// Nose root and nose tip clicked once (image px).
    Points { root: Point2, tip: Point2 },
    /// Found once on the first usable frame's full-frame profile ([`find_nose_on_profile`]).
    FromProfile,
}

/// Everything set once per clip. Stored in sessions (serde), defaults for the tuning fields.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ProfileSetup {
    /// The mouth crop (px); its rear edge must lie inside the face and its front edge in the
    /// background, and it should start below the nose tip.
    pub crop: Rect,
    pub reference_line: ReferenceLine,
    pub facing: Facing,
    #[serde(default)]
    pub threshold: Threshold,
    /// Silhouettes smaller than this (px) are not a face.
    #[serde(default = "default_min_component_px")]
    pub min_component_px: usize,
    #[serde(default)]
    pub nose: NoseLength,
    /// Remove isolated salt-and-pepper impulses (switching 3×3 median) before thresholding,
    /// so specks do not stick to the silhouette's edge.
    #[serde(default = "default_true")]
    pub denoise: bool,
    /// A profile bump must stand out by this much (px) to count as a lip.
    #[serde(default = "default_min_prominence_px")]
    pub min_prominence_px: Real,
    /// Follow head motion: the reference line is fixed to the head, not the image, by
    /// registering each frame's upper-face profile to this one ([`capture_anchor`]).
    /// `None` measures from the line as drawn (the published method, for a still head).
    #[serde(default)]
    pub anchor: Option<Anchor>,
}

/// The rigid upper-face profile (forehead, nasion, nose ridge to the tip) of the frame the
/// reference line was set on. Articulation does not move it, so registering a frame's
/// profile to it gives the head's in-plane motion (translation and pitch) in the side view.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct Anchor {
    /// The region holding that profile (px); like the crop, its rear edge lies inside the
    /// face and its front edge in the background, with a few px of margin for motion.
    pub region: Rect,
    /// The profile's forward edge, one point per row, top to bottom (image px).
    pub profile: Vec<Point2>,
}

/// A 2D rigid motion in image px: rotation about the origin, then translation.
pub type Rigid2 = nalgebra::Isometry2<Real>;

fn default_min_component_px() -> usize {
    50
}

fn default_true() -> bool {
    true
}

fn default_min_prominence_px() -> Real {
    0.5
}

impl ProfileSetup {
    /// A setup with default tuning (Otsu, median denoising, 50 px components, 0.5 px bumps).
    pub fn new(crop: Rect, reference_line: ReferenceLine, facing: Facing) -> Self {
        Self {
            crop,
            reference_line,
            facing,
            threshold: Threshold::Otsu,
            min_component_px: default_min_component_px(),
            nose: NoseLength::Unset,
            denoise: true,
            min_prominence_px: default_min_prominence_px(),
            anchor: None,
        }
    }
}

/// Why a frame could not be measured.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ProfileError {
    #[error("the crop {0:?} lies outside the {1}×{2} frame")]
    CropOutside(Rect, u32, u32),
    #[error("the crop is one gray level: no silhouette to threshold")]
    Uniform,
    #[error("the reference line is degenerate or within 30° of horizontal")]
    BadReferenceLine,
    #[error("no face silhouette of at least {0} px in the crop")]
    NoSilhouette(usize),
    #[error("no upper lip: the profile has no bump standing out by {0} px")]
    NoUpperLip(Real),
    #[error("the upper lip touches the crop's front edge: widen the crop forward")]
    LipAtCropEdge,
    #[error("the nose tip or root was not found above the crop")]
    NoseNotFound,
    #[error("the nose length is not positive")]
    BadNoseLength,
    #[error("the upper-face profile could not be registered to the anchor frame's: {0}")]
    Registration(&'static str),
}

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

/// Gray levels by which an impulse must stand outside all 8 neighbours to be removed.
const IMPULSE_MARGIN: u8 = 16;

/// Switching 3×3 median (edges replicate): a pixel is replaced by its window's median only
/// when it lies more than [`IMPULSE_MARGIN`] outside the range of all 8 neighbours, i.e. it
/// is an isolated salt-and-pepper impulse. Unlike a plain median this leaves edges and the
/// sharp corners of a silhouette (nose tip, lip) exactly as they were.
fn remove_impulses(values: &[u8], width: usize, height: usize) -> Vec<u8> {
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

/// 3-sample running median (ends kept): a single-row spike (a speck stuck to the edge) is
/// replaced, while monotone runs pass unchanged.
fn median_of_three(y: &[Real]) -> Vec<Real> {
    (0..y.len())
        .map(|i| {
            if i == 0 || i + 1 == y.len() {
                return y[i];
            }
            let (a, b, c) = (y[i - 1], y[i], y[i + 1]);
            a.max(b).min(a.min(b).max(c))
        })
        .collect()
}

/// Smallest share of the region a second tone on the background's side must have to count
/// as face. A small lip in a wide crop can be as little as 2 % (seen on demo frames, where a
/// 2 % floor lost the lip on some frames and not on their neighbours); anti-aliased edge
/// pixels are kept out by the compactness test instead.
const SECOND_MODE_MIN_SHARE: f64 = 0.01;

/// Smallest share of the region the background itself must have: the crop's front part is
/// background by construction, so a few stray pixels beyond the background's level are not it.
const BACKGROUND_MIN_SHARE: f64 = 0.05;

/// A second tone must be peaked: its σ at most this fraction of the σ of a uniform spread
/// over its gray interval (`width/√12`). Anti-aliased edge pixels spread about uniformly
/// between the tones (ratio near 1); a shaded lip is a mode (about 0.45 on the demo).
const SECOND_MODE_MAX_SPREAD: f64 = 0.75;

/// Otsu splits the histogram's two strongest tones, which in a mouth crop on a dark
/// background can be the lips and the skin rather than face and background (the background
/// is often the minority). So while the background's side of `t` still holds a compact second
/// tone — at least [`SECOND_MODE_MIN_SHARE`] of the pixels, clearly apart from the background
/// (mean more than 4 σ + 8 levels away) and not a smear (σ below a fifth of the side's span
/// and below [`SECOND_MODE_MAX_SPREAD`] of a uniform spread), with the part left beyond it
/// holding at least [`BACKGROUND_MIN_SHARE`] (a handful of stray pixels is no background) —
/// that side is split again by Otsu, moving `t` toward the background.
fn refine_toward_background(hist: &[u64; 256], mut t: u8, background_bright: bool) -> u8 {
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
    for _ in 0..3 {
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
        let distinct = (mean - bg_mean).abs() > 4.0 * bg_sd + 8.0;
        // The split-off extreme must itself be a real tone: a few stray pixels darker (or
        // brighter) than the background would otherwise be taken for it, and the whole
        // background for a second face tone.
        let shares = n / total >= SECOND_MODE_MIN_SHARE && bg_n / total >= BACKGROUND_MIN_SHARE;
        let width = (other_range.end() - other_range.start() + 1) as f64;
        let compact = sd < 0.2 * span && sd < SECOND_MODE_MAX_SPREAD * width / 12f64.sqrt();
        if shares && distinct && compact {
            t = t2 as u8;
        } else {
            break;
        }
    }
    t
}

/// A segmented region in forward coordinates (`u` = column counted in the facing direction).
struct Silhouette {
    region: Rect,
    facing: Facing,
    width: usize,
    height: usize,
    /// Gray levels (median-filtered when asked), forward coordinates, row-major.
    values: Vec<u8>,
    mask: Vec<bool>,
    /// Typical face and background levels (class medians), for sub-pixel edges.
    fg_level: Real,
    bg_level: Real,
    threshold: u8,
}

/// Segments the face silhouette inside `region`.
///
/// Polarity: the background is the class holding most of the region's front column (the
/// face looks toward it), or, if that column is evenly split, the class missing from the rear
/// column. Cleanup: only the largest component touching the rear edge is kept (the largest
/// overall if none touches, e.g. a rendered head floating in the frame), and background
/// pockets that do not reach the region's border are filled.
fn segment(
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

    let (labels, sizes) = connected_components(&mask, w);
    let mut rear_touch = vec![false; sizes.len()];
    for r in 0..h {
        if let Some(&l) = labels.get(r * w).filter(|&&l| l != u32::MAX) {
            rear_touch[l as usize] = true;
        }
    }
    let pick = |touching: bool| {
        (0..sizes.len())
            .filter(|&l| !touching || rear_touch[l])
            .max_by_key(|&l| sizes[l])
            .filter(|&l| sizes[l] >= min_component_px.max(1))
    };
    let face =
        pick(true).or_else(|| pick(false)).ok_or(ProfileError::NoSilhouette(min_component_px))?;
    for (m, &l) in mask.iter_mut().zip(&labels) {
        *m = l == face as u32;
    }
    // Fill enclosed background pockets (specks inside the face, a dark nostril).
    let inverse: Vec<bool> = mask.iter().map(|&m| !m).collect();
    let (holes, hole_sizes) = connected_components(&inverse, w);
    let mut open = vec![false; hole_sizes.len()];
    for r in 0..h {
        for u in 0..w {
            let on_border = r == 0 || r + 1 == h || u == 0 || u + 1 == w;
            let l = holes[r * w + u];
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
    fn forward_edges(&self) -> Vec<Option<(Real, bool)>> {
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
                if ((f - b) / global).is_nan() || (f - b).abs() < 0.5 * global.abs() {
                    f = self.fg_level;
                    b = self.bg_level;
                }
                let k = |i: usize| {
                    if i >= w || (f - b).abs() < 1.0 {
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
    fn antialiased_share(&self) -> Real {
        let w = self.width;
        let span = self.fg_level - self.bg_level;
        if span.abs() < 1.0 {
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
                    (0.15..=0.85).contains(&k)
                }
            };
            if mid(c + 1) {
                soft += 1;
            }
        }
        if rows == 0 { 0.0 } else { soft as Real / rows as Real }
    }

    /// Forward coordinate `u` (may be fractional) of row `r` as an image point.
    fn to_image(&self, u: Real, r: Real) -> Point2 {
        let x = match self.facing {
            Facing::Right => u,
            Facing::Left => self.width as Real - 1.0 - u,
        };
        Point2::new(self.region.x as Real + x, self.region.y as Real + r)
    }
}

/// A local maximum of a sampled curve and its topographic prominence (the height above the
/// higher of the two lowest points reached before the curve climbs above the peak or ends).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Peak {
    pub index: usize,
    pub prominence: Real,
}

/// Interior local maxima of `y` (plateaus reported at their middle) with their prominence,
/// in index order. The ends are never peaks: a curve still rising at the crop edge belongs to
/// something outside it (the nose underside).
pub fn find_peaks(y: &[Real]) -> Vec<Peak> {
    let n = y.len();
    let mut peaks = Vec::new();
    let mut i = 1;
    while i + 1 < n {
        if y[i] > y[i - 1] {
            let mut j = i;
            while j + 1 < n && y[j + 1] == y[i] {
                j += 1;
            }
            if j + 1 < n && y[j + 1] < y[i] {
                let mid = (i + j) / 2;
                let left = y[..i]
                    .iter()
                    .rev()
                    .take_while(|&&v| v <= y[i])
                    .fold(Real::INFINITY, |m, &v| m.min(v));
                let right = y[j + 1..]
                    .iter()
                    .take_while(|&&v| v <= y[i])
                    .fold(Real::INFINITY, |m, &v| m.min(v));
                peaks.push(Peak { index: mid, prominence: y[i] - left.max(right) });
            }
            i = j + 1;
        } else {
            i += 1;
        }
    }
    peaks
}

/// Binomial [1 4 6 4 1]/16 smoothing (≈ Gaussian σ = 1 sample), ends replicated: removes
/// pixel-level ripple before peaks are judged, without moving a lip-sized bump.
fn smooth(y: &[Real]) -> Vec<Real> {
    let n = y.len();
    let at = |i: isize| y[i.clamp(0, n as isize - 1) as usize];
    (0..n as isize)
        .map(|i| (at(i - 2) + 4.0 * at(i - 1) + 6.0 * at(i) + 4.0 * at(i + 1) + at(i + 2)) / 16.0)
        .collect()
}

/// The parabola window around a maximum: rows either side, and depth (px) below it.
#[derive(Clone, Copy, Debug, PartialEq)]
struct ApexWindow {
    rows: usize,
    drop_px: Real,
}

/// For anti-aliased edges (sub-pixel per row): a few rows, so a sharp corner is not cut.
const APEX_SOFT: ApexWindow = ApexWindow { rows: 6, drop_px: 1.5 };
/// For hard-edged renders, where each row's edge is quantised to ±½ px: a dozen rows, which
/// average the quantisation out while a lip is still near a parabola over them. Chosen on
/// the demo speakers' side frames: windows 4/1 px, 6/1.5 px, 10/3 px gave RMSE 0.016,
/// 0.015, 0.011 against the vermilion-vertex truth, 14/5 px worse.
const APEX_HARD: ApexWindow = ApexWindow { rows: 10, drop_px: 3.0 };

/// Refines a maximum of `y` near `index`: the vertex of a least-squares parabola through the
/// contiguous samples within `window.rows` of the raw maximum and within `window.drop_px`
/// of its value. Falls back to the raw maximum when the fit is flat or its vertex leaves
/// the window.
fn refine_maximum(y: &[Real], index: usize, window: ApexWindow) -> (Real, Real) {
    let n = y.len();
    let lo = index.saturating_sub(3);
    let hi = (index + 3).min(n - 1);
    let m = (lo..=hi).max_by(|&a, &b| y[a].total_cmp(&y[b])).unwrap_or(index);
    let (apex_rows, apex_drop) = (window.rows, window.drop_px);
    let keep = |i: usize| y[i] >= y[m] - apex_drop;
    let first =
        (m.saturating_sub(apex_rows)..=m).rev().take_while(|&i| keep(i)).last().unwrap_or(m);
    let last = (m..=(m + apex_rows).min(n - 1)).take_while(|&i| keep(i)).last().unwrap_or(m);
    let window: Vec<usize> = (first..=last).collect();
    if window.len() >= 3 {
        // Fit y = c0 + c1 t + c2 t² with t = i − m.
        let mut ata = nalgebra::Matrix3::<Real>::zeros();
        let mut atb = nalgebra::Vector3::<Real>::zeros();
        for &i in &window {
            let t = i as Real - m as Real;
            let row = nalgebra::Vector3::new(1.0, t, t * t);
            ata += row * row.transpose();
            atb += row * y[i];
        }
        if let Some(c) = ata.lu().solve(&atb) {
            let (t0, t1) =
                (window[0] as Real - m as Real, *window.last().unwrap() as Real - m as Real);
            if c[2] < -1e-9 {
                let t = -c[1] / (2.0 * c[2]);
                if t >= t0 && t <= t1 {
                    return (m as Real + t, c[0] + c[1] * t + c[2] * t * t);
                }
            }
        }
    }
    (m as Real, y[m])
}

/// One frame's profile measurement, with what the TUI may draw.
#[derive(Clone, Debug, PartialEq)]
pub struct LipProfile {
    /// The silhouette's forward edge per crop row (image px), `None` where the row has no face.
    pub edge: Vec<Option<Point2>>,
    /// The upper lip's foremost point (image px).
    pub upper_lip_px: Point2,
    /// Signed distance of `upper_lip_px` from the reference line, forward positive (px).
    pub p_px: Real,
    /// The subnasale and stomion concavities bracketing the upper lip, when inside the crop.
    pub subnasale_px: Option<Point2>,
    pub stomion_px: Option<Point2>,
    /// The gray threshold used.
    pub threshold: u8,
    /// This frame → anchor frame, when the setup follows head motion.
    pub motion: Option<Rigid2>,
}

/// Measures the upper lip's protrusion in one frame.
///
/// The rule for the upper lip: along the crop's rows (top to bottom) the profile's forward
/// distance `s(row)` from the reference line, smoothed, has interior peaks; the upper lip is
/// the first peak (from the top) whose prominence is at least `setup.min_prominence_px`. The
/// curve above it falls to the subnasale concavity (or climbs out of the crop into the nose
/// underside), the curve below it falls to the stomion before the lower lip. Its value is
/// refined to sub-pixel by a parabola through the raw samples around it.
///
/// # Errors
/// [`ProfileError`] when the crop is outside the frame, uniform, holds no face, the line is
/// degenerate, no lip bump stands out, or the lip touches the crop's front edge.
pub fn measure_lip_profile(
    image: &GrayImage,
    setup: &ProfileSetup,
) -> Result<LipProfile, ProfileError> {
    let line = &setup.reference_line;
    let normal = line.forward_normal(setup.facing).ok_or(ProfileError::BadReferenceLine)?;
    let motion = match &setup.anchor {
        Some(anchor) => Some(register_to_anchor(image, setup, anchor)?),
        None => None,
    };
    let to_reference = motion.unwrap_or_else(Rigid2::identity);
    let sil = segment(
        image,
        setup.crop,
        setup.facing,
        setup.threshold,
        setup.denoise,
        setup.min_component_px,
    )?;
    let edges = sil.forward_edges();
    let edge: Vec<Option<Point2>> =
        edges.iter().enumerate().map(|(r, e)| e.map(|(u, _)| sil.to_image(u, r as Real))).collect();
    // Distances are taken in the anchor frame: the line is fixed to the head.
    let dist = |p: Point2| (to_reference * p - line.a).dot(&normal);
    // Rows without face act as deep concavities: the distance of the crop's rear edge.
    let floor = (0..sil.height)
        .map(|r| dist(sil.to_image(-0.5, r as Real)))
        .fold(Real::INFINITY, Real::min);
    let s: Vec<Real> = edge.iter().map(|p| p.map_or(floor, dist)).collect();
    if s.len() < 3 {
        return Err(ProfileError::NoUpperLip(setup.min_prominence_px));
    }
    // Structure from a despiked, smoothed copy; the value from the raw samples, except rows
    // more than 1 px off the despiked curve (specks), which take the despiked value.
    let despiked = median_of_three(&s);
    let s: Vec<Real> =
        s.iter().zip(&despiked).map(|(&v, &d)| if (v - d).abs() > 1.0 { d } else { v }).collect();
    let smoothed = smooth(&despiked);
    let peaks = find_peaks(&smoothed);
    let lip = peaks
        .iter()
        .find(|p| p.prominence >= setup.min_prominence_px)
        .copied()
        .ok_or(ProfileError::NoUpperLip(setup.min_prominence_px))?;
    // Hard-edged frames need the wider window (see APEX_HARD).
    let window = if sil.antialiased_share() >= 0.15 { APEX_SOFT } else { APEX_HARD };
    let (row, p_px) = refine_maximum(&s, lip.index, window);
    let near = row.round() as usize;
    if (near.saturating_sub(1)..=(near + 1).min(sil.height - 1))
        .any(|r| edges[r].is_some_and(|e| e.1))
    {
        return Err(ProfileError::LipAtCropEdge);
    }
    // The image point on the refined row whose distance is the refined maximum: distance is
    // linear in x, with slope n·R·e_x.
    let y = sil.region.y as Real + row;
    let at_zero = dist(Point2::new(0.0, y));
    let slope = normal.dot(&(to_reference.rotation * Vector2::x()));
    if slope.abs() < 0.5 {
        return Err(ProfileError::BadReferenceLine);
    }
    let x = (p_px - at_zero) / slope;
    let concavity = |range: std::ops::Range<usize>| {
        let r = range.clone().min_by(|&a, &b| smoothed[a].total_cmp(&smoothed[b]))?;
        // A concavity at the crop edge is only where the curve left the crop.
        (r > 0 && r + 1 < sil.height).then_some(())?;
        edge[r]
    };
    let subnasale_px = concavity(0..lip.index);
    let next = peaks.iter().find(|p| p.index > lip.index).map_or(sil.height, |p| p.index);
    let stomion_px = concavity(lip.index + 1..next);
    Ok(LipProfile {
        edge,
        upper_lip_px: Point2::new(x, y),
        p_px,
        subnasale_px,
        stomion_px,
        threshold: sil.threshold,
        motion,
    })
}

/// Row σ of the Gaussian that smooths registration profiles, and its reach.
const PROFILE_SIGMA_ROWS: Real = 2.5;
const PROFILE_RADIUS_ROWS: usize = 7;

/// The forward edge of `region` in `image`, one point per row (image px), leaving out rows
/// whose face reaches the region's front edge (clipped, not an edge).
///
/// The x values are smoothed along each run of consecutive rows by a Gaussian of
/// [`PROFILE_SIGMA_ROWS`], and each run loses [`PROFILE_RADIUS_ROWS`] rows at both ends
/// (where the kernel would be cut). On hard-edged frames a slanted edge is a staircase whose
/// steps sit on whole pixels; registering staircases locks onto whole-pixel shifts, while
/// their smoothed ramps carry the sub-pixel position.
fn region_profile(
    image: &GrayImage,
    setup: &ProfileSetup,
    region: Rect,
) -> Result<Vec<Point2>, ProfileError> {
    let sil = segment(
        image,
        region,
        setup.facing,
        setup.threshold,
        setup.denoise,
        setup.min_component_px,
    )?;
    let raw: Vec<Option<Point2>> = sil
        .forward_edges()
        .into_iter()
        .enumerate()
        .map(|(r, e)| e.filter(|e| !e.1).map(|(u, _)| sil.to_image(u, r as Real)))
        .collect();
    let kernel: Vec<Real> = (0..=PROFILE_RADIUS_ROWS)
        .map(|d| (-0.5 * (d as Real / PROFILE_SIGMA_ROWS).powi(2)).exp())
        .collect();
    let norm = kernel[0] + 2.0 * kernel[1..].iter().sum::<Real>();
    let k = PROFILE_RADIUS_ROWS;
    Ok((k..raw.len().saturating_sub(k))
        .filter_map(|r| {
            let p = raw[r]?;
            let mut x = kernel[0] * p.x;
            for d in 1..=k {
                x += kernel[d] * (raw[r - d]?.x + raw[r + d]?.x);
            }
            Some(Point2::new(x / norm, p.y))
        })
        .collect())
}

/// Records the upper-face profile inside `region` of `image` (the frame the reference line
/// is drawn on) as the anchor that later frames are registered to.
///
/// # Errors
/// Segmentation errors, or [`ProfileError::Registration`] when fewer than
/// [`MIN_REGISTRATION_ROWS`] rows hold an edge.
pub fn capture_anchor(
    image: &GrayImage,
    setup: &ProfileSetup,
    region: Rect,
) -> Result<Anchor, ProfileError> {
    let profile = region_profile(image, setup, region)?;
    if profile.len() < MIN_REGISTRATION_ROWS {
        return Err(ProfileError::Registration("too few profile rows in the anchor region"));
    }
    Ok(Anchor { region, profile })
}

/// Cap on ICP steps; each costs one pass over the rows.
const MAX_ICP_STEPS: usize = 50;

/// Widest two-state oscillation (px at the profile's farthest point) that ICP may end in and
/// still count as registered, at its middle: a tenth of this moves P by under 1/1000 of a
/// typical nose length.
const MAX_OSCILLATION_PX: Real = 0.25;

/// Fewest profile rows a registration uses (three parameters, and noise to average).
pub const MIN_REGISTRATION_ROWS: usize = 12;

/// The closest point to `p` on the polyline `line` (consecutive points one row apart),
/// searched among segments starting within 4 rows of `p`; with the segment's unit normal.
/// Points beyond either end of the polyline have none: they would pull sideways.
fn closest_on_profile(line: &[Point2], p: Point2) -> Option<(Point2, Vector2)> {
    let y0 = line.first()?.y;
    let k = ((p.y - y0).round() as isize).clamp(0, line.len() as isize - 1) as usize;
    let mut best: Option<(Real, Point2, Vector2)> = None;
    for i in k.saturating_sub(4)..(k + 4).min(line.len().saturating_sub(1)) {
        let (a, b) = (line[i], line[i + 1]);
        let d = b - a;
        let len2 = d.norm_squared();
        if len2.is_nan() || len2 <= 1e-12 || d.y.abs() > 1.5 {
            continue; // a gap in the rows, not a segment
        }
        let t = ((p - a).dot(&d) / len2).clamp(0.0, 1.0);
        if (i == 0 && t == 0.0) || (i + 2 == line.len() && t == 1.0) {
            continue;
        }
        let q = a + d * t;
        let dist = (p - q).norm();
        if best.is_none_or(|b| dist < b.0) {
            let n = Vector2::new(d.y, -d.x) / len2.sqrt();
            best = Some((dist, q, n));
        }
    }
    best.map(|(_, q, n)| (q, n))
}

/// The rigid motion taking this frame's upper-face profile onto the anchor's: point-to-line
/// ICP (Chen & Medioni 1992) over the profile rows, each step a linearised least-squares fit
/// of a small rotation (about the points' centroid) and a translation, pairs farther than
/// 4 px (2 px after three steps) left out.
///
/// # Errors
/// Segmentation errors; [`ProfileError::Registration`] with too few rows or paired points,
/// a profile without enough shape to fix all three parameters, or no convergence.
pub fn register_to_anchor(
    image: &GrayImage,
    setup: &ProfileSetup,
    anchor: &Anchor,
) -> Result<Rigid2, ProfileError> {
    let points = region_profile(image, setup, anchor.region)?;
    if points.len() < MIN_REGISTRATION_ROWS || anchor.profile.len() < MIN_REGISTRATION_ROWS {
        return Err(ProfileError::Registration("too few profile rows"));
    }
    let mut motion = Rigid2::identity();
    let mut previous = motion;
    let mut last_step = Real::INFINITY;
    for iteration in 0..MAX_ICP_STEPS {
        let gate = if iteration < 3 { 4.0 } else { 2.0 };
        let moved: Vec<Point2> = points.iter().map(|p| motion * p).collect();
        let pairs: Vec<(Point2, Point2, Vector2)> = moved
            .iter()
            .filter_map(|&p| {
                let (q, n) = closest_on_profile(&anchor.profile, p)?;
                ((p - q).norm() <= gate).then_some((p, q, n))
            })
            .collect();
        if pairs.len() < MIN_REGISTRATION_ROWS {
            return Err(ProfileError::Registration("too few paired profile points"));
        }
        let c = pairs.iter().fold(Vector2::zeros(), |acc, (p, _, _)| acc + p.coords)
            / pairs.len() as Real;
        let mut ata = nalgebra::Matrix3::<Real>::zeros();
        let mut atb = nalgebra::Vector3::<Real>::zeros();
        for (p, q, n) in &pairs {
            let r = p.coords - c;
            let row = nalgebra::Vector3::new(n.dot(&Vector2::new(-r.y, r.x)), n.x, n.y);
            ata += row * row.transpose();
            atb -= row * n.dot(&(p - q));
        }
        // A straight profile leaves sliding along it free: refuse rather than guess.
        let eig = ata.symmetric_eigenvalues();
        let floor = 1e-6 * eig.max().max(1e-12);
        if eig.min().is_nan() || eig.min() <= floor {
            return Err(ProfileError::Registration("the profile is too straight"));
        }
        let delta = ata.cholesky().ok_or(ProfileError::Registration("singular"))?.solve(&atb);
        let rot = nalgebra::Rotation2::new(delta[0]);
        let step = Rigid2::new(c - rot * c + Vector2::new(delta[1], delta[2]), delta[0]);
        previous = motion;
        motion = step * motion;
        // Movement of the profile's farthest point, px.
        let reach = pairs.iter().map(|(p, _, _)| (p.coords - c).norm()).fold(0.0, Real::max);
        last_step = delta[0].abs() * reach + delta[1].hypot(delta[2]);
        if last_step < 1e-4 {
            return Ok(motion);
        }
    }
    // Pairs may keep switching segments by a hair: a last step this small is converged.
    if last_step < 1e-2 {
        return Ok(motion);
    }
    // Or a few rows' pairs flip between two segments and the motion jumps between two
    // states a fraction of a pixel apart (seen at 0.06 px on a demo frame): the middle of
    // the two is as good as the data fixes it. Anything wider is a failure.
    if last_step < MAX_OSCILLATION_PX {
        let angle = 0.5 * (motion.rotation.angle() + previous.rotation.angle());
        let t = 0.5 * (motion.translation.vector + previous.translation.vector);
        return Ok(Rigid2::new(t, angle));
    }
    Err(ProfileError::Registration("no convergence"))
}

/// The nose root and tip found on the full frame's profile.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct NosePoints {
    pub root: Point2,
    pub tip: Point2,
}

impl NosePoints {
    pub fn length_px(&self) -> Real {
        (self.tip - self.root).norm()
    }
}

/// Upper hull of the points `(i, y[i])`: the least concave function at or above the curve,
/// evaluated at every index; the gap under it is the depth of each concavity.
fn upper_hull(y: &[(usize, Real)]) -> Vec<Real> {
    let mut hull: Vec<(Real, Real)> = Vec::new();
    for &(i, v) in y {
        let p = (i as Real, v);
        while hull.len() >= 2 {
            let (a, b) = (hull[hull.len() - 2], hull[hull.len() - 1]);
            // Drop b when it lies on or below the chord a–p.
            if (b.0 - a.0) * (p.1 - a.1) - (b.1 - a.1) * (p.0 - a.0) >= 0.0 {
                hull.pop();
            } else {
                break;
            }
        }
        hull.push(p);
    }
    y.iter()
        .map(|&(i, _)| {
            let x = i as Real;
            let k = hull.partition_point(|h| h.0 < x).min(hull.len() - 1);
            if k == 0 || hull[k].0 == x {
                hull[k].1
            } else {
                let (a, b) = (hull[k - 1], hull[k]);
                a.1 + (b.1 - a.1) * (x - a.0) / (b.0 - a.0)
            }
        })
        .collect()
}

/// Forward profile of the whole frame: per row, the silhouette's sub-pixel forward edge
/// (image px) and its forward coordinate `u` (px from the rear image edge).
fn full_frame_profile(
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

/// Finds the nose tip and root on the full frame's profile: the tip is the foremost profile
/// point above the crop's top row, the root (nasion) the point above
/// the tip lying deepest under the profile's forward convex hull (the concavity between
/// forehead and nose). Forward is along the reference line's normal.
///
/// # Errors
/// [`ProfileError::NoseNotFound`] when the tip is not above the crop (the foremost point sits
/// on the crop's top row) or no concavity lies above it; segmentation errors as for frames.
pub fn find_nose_on_profile(
    image: &GrayImage,
    setup: &ProfileSetup,
) -> Result<NosePoints, ProfileError> {
    let normal =
        setup.reference_line.forward_normal(setup.facing).ok_or(ProfileError::BadReferenceLine)?;
    let profile = full_frame_profile(
        image,
        setup.facing,
        setup.threshold,
        setup.denoise,
        setup.min_component_px,
    )?;
    let top = (setup.crop.y as usize).min(profile.len());
    let s: Vec<(usize, Real)> = profile[..top]
        .iter()
        .enumerate()
        .filter_map(|(r, p)| p.map(|(q, _)| (r, (q - setup.reference_line.a).dot(&normal))))
        .collect();
    nose_from_samples(&s, &profile, top, normal).ok_or(ProfileError::NoseNotFound)
}

/// Tip = foremost of the samples `(row, distance along normal)` (not on the last row
/// `top − 1`), refined by a parabola as the lip is; root = deepest under the hull of the
/// samples above the tip.
fn nose_from_samples(
    s: &[(usize, Real)],
    profile: &[Option<(Point2, Real)>],
    top: usize,
    normal: Vector2,
) -> Option<NosePoints> {
    let k = (0..s.len()).max_by(|&a, &b| s[a].1.total_cmp(&s[b].1))?;
    if s[k].0 + 1 >= top || k < 2 {
        return None;
    }
    let values: Vec<Real> = s.iter().map(|p| p.1).collect();
    let (t, v) = refine_maximum(&values, k, APEX_SOFT);
    // Move the tip's sample point by the refinement: along the rows and along the normal.
    let tip = profile[s[k].0]?.0 + Vector2::new(0.0, t - k as Real) + normal * (v - s[k].1);
    let above = &s[..=k];
    let hull = upper_hull(above);
    let (j, depth) = above
        .iter()
        .zip(&hull)
        .enumerate()
        .map(|(j, (p, h))| (j, h - p.1))
        .max_by(|a, b| a.1.total_cmp(&b.1))?;
    (depth >= 1.0).then_some(())?;
    let root = profile[above[j].0]?.0;
    Some(NosePoints { root, tip })
}

/// Resolves the setup's nose length (px) from `frame` when it must be found on the profile.
///
/// # Errors
/// As [`find_nose_on_profile`], and [`ProfileError::BadNoseLength`] for a non-positive length.
pub fn resolve_nose_length(
    setup: &ProfileSetup,
    frame: &GrayImage,
) -> Result<Option<Real>, ProfileError> {
    let len = match setup.nose {
        NoseLength::Unset => return Ok(None),
        NoseLength::Px(l) => l,
        NoseLength::Points { root, tip } => (tip - root).norm(),
        NoseLength::FromProfile => find_nose_on_profile(frame, setup)?.length_px(),
    };
    if len.is_finite() && len > 0.0 { Ok(Some(len)) } else { Err(ProfileError::BadNoseLength) }
}

/// One frame's protrusion, as stored per frame.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct ProfilePoint {
    pub frame: usize,
    /// The upper lip's foremost point (image px); `None` when the frame failed.
    pub upper_lip_px: Option<Point2>,
    /// Signed distance from the reference line, forward positive (px).
    pub p_px: Option<Real>,
    /// `p_px` / nose length; `None` without a nose length.
    pub p_norm: Option<Real>,
    #[serde(default)]
    pub source: PointSource,
    /// This frame → anchor frame (head motion), when the setup follows the head; a
    /// corrected point of this frame is measured through it too.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub motion: Option<Rigid2>,
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub failed: Option<String>,
}

impl ProfilePoint {
    /// A measurement at `point` (image px): P from the setup's line (after `motion` into the
    /// anchor frame, when given), normalised by `nose_px`.
    pub fn at(
        frame: usize,
        point: Point2,
        setup: &ProfileSetup,
        nose_px: Option<Real>,
        source: PointSource,
        motion: Option<Rigid2>,
    ) -> Self {
        let moved = motion.map_or(point, |m| m * point);
        match setup.reference_line.signed_distance(moved, setup.facing) {
            Some(p) => Self {
                frame,
                upper_lip_px: Some(point),
                p_px: Some(p),
                p_norm: nose_px.map(|l| p / l),
                source,
                motion,
                failed: None,
            },
            None => Self::failure(frame, &ProfileError::BadReferenceLine),
        }
    }

    /// A failed frame, saying why.
    pub fn failure(frame: usize, error: &ProfileError) -> Self {
        Self {
            frame,
            upper_lip_px: None,
            p_px: None,
            p_norm: None,
            source: PointSource::Tracked,
            motion: None,
            failed: Some(error.to_string()),
        }
    }

    fn measured(frame: usize, m: &LipProfile, nose_px: Option<Real>) -> Self {
        Self {
            frame,
            upper_lip_px: Some(m.upper_lip_px),
            p_px: Some(m.p_px),
            p_norm: nose_px.map(|l| m.p_px / l),
            source: PointSource::Tracked,
            motion: m.motion,
            failed: None,
        }
    }
}

/// Measures frame number `frame`: never fails, a bad frame is flagged in `failed`.
pub fn measure_frame(
    frame: usize,
    image: &GrayImage,
    setup: &ProfileSetup,
    nose_px: Option<Real>,
) -> ProfilePoint {
    match measure_lip_profile(image, setup) {
        Ok(m) => ProfilePoint::measured(frame, &m, nose_px),
        Err(e) => ProfilePoint::failure(frame, &e),
    }
}

/// Measures the rendered side view of a fitted head exactly as a video frame, so head and
/// speaker are measured alike. A nose length `FromProfile` is found on the render itself.
/// Give it a setup made on a render of the head (e.g. [`propose_setup`] on the neutral
/// render): an anchor captured on the speaker's video would register the head's profile to
/// the speaker's.
///
/// # Errors
/// As [`measure_lip_profile`] and [`resolve_nose_length`].
pub fn measure_render(
    render: &RgbImage,
    setup: &ProfileSetup,
) -> Result<ProfilePoint, ProfileError> {
    let gray = image::imageops::grayscale(render);
    let nose = resolve_nose_length(setup, &gray)?;
    let m = measure_lip_profile(&gray, setup)?;
    Ok(ProfilePoint::measured(0, &m, nose))
}

/// Measures a clip's frames (numbered from 0 in iteration order) in parallel. A nose length
/// `FromProfile` is found once, on the first frame; if that fails, every point says why and
/// `p_norm` stays `None`.
pub fn extract_protrusion<I>(frames: I, setup: &ProfileSetup) -> Vec<ProfilePoint>
where
    I: Iterator<Item = GrayImage> + Send,
{
    let mut frames = frames.enumerate().peekable();
    let nose = match frames.peek() {
        Some((_, first)) => resolve_nose_length(setup, first),
        None => return Vec::new(),
    };
    let mut out: Vec<ProfilePoint> =
        frames.par_bridge().map(|(i, img)| measure_with_nose(i, &img, setup, &nose)).collect();
    out.sort_by_key(|p| p.frame);
    out
}

/// Measures frames `0..n_frames` fetched by `fetch` (e.g. decoding from disk) in parallel;
/// a frame that cannot be fetched is flagged with the fetch error.
pub fn extract_protrusion_with<F>(
    n_frames: usize,
    fetch: F,
    setup: &ProfileSetup,
) -> Vec<ProfilePoint>
where
    F: Fn(usize) -> Result<GrayImage, String> + Sync,
{
    let nose = match setup.nose {
        NoseLength::FromProfile => (0..n_frames)
            .find_map(|i| fetch(i).ok())
            .map_or(Err(ProfileError::NoseNotFound), |img| resolve_nose_length(setup, &img)),
        _ => resolve_nose_length(setup, &GrayImage::new(1, 1)),
    };
    (0..n_frames)
        .into_par_iter()
        .map(|i| match fetch(i) {
            Ok(img) => measure_with_nose(i, &img, setup, &nose),
            Err(e) => ProfilePoint {
                failed: Some(e),
                ..ProfilePoint::failure(i, &ProfileError::NoseNotFound)
            },
        })
        .collect()
}

fn measure_with_nose(
    frame: usize,
    image: &GrayImage,
    setup: &ProfileSetup,
    nose: &Result<Option<Real>, ProfileError>,
) -> ProfilePoint {
    let mut p = measure_frame(frame, image, setup, nose.clone().ok().flatten());
    if let (Err(e), None) = (nose, &p.failed) {
        p.failed = Some(format!("nose length: {e}"));
    }
    p
}

/// A clip's automatic measurements and the user's corrections, kept apart so every edit can
/// be undone (the model of landmark corrections).
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
pub struct ProfileTrack {
    /// As measured, one per frame, ascending by frame.
    pub automatic: Vec<ProfilePoint>,
    /// Frame → the upper lip point the user set (image px).
    #[serde(default)]
    pub corrected: BTreeMap<usize, Point2>,
    /// The nose length used for `p_norm` (px), resolved once.
    #[serde(default)]
    pub nose_length_px: Option<Real>,
}

impl ProfileTrack {
    pub fn new(automatic: Vec<ProfilePoint>, nose_length_px: Option<Real>) -> Self {
        let mut automatic = automatic;
        automatic.sort_by_key(|p| p.frame);
        Self { automatic, corrected: BTreeMap::new(), nose_length_px }
    }

    /// Sets the user's point for `frame` (image px).
    pub fn correct(&mut self, frame: usize, point: Point2) {
        self.corrected.insert(frame, point);
    }

    /// Drops the user's point for `frame`; returns it if there was one.
    pub fn clear_correction(&mut self, frame: usize) -> Option<Point2> {
        self.corrected.remove(&frame)
    }

    /// The automatic point of `frame`, if measured.
    pub fn automatic(&self, frame: usize) -> Option<&ProfilePoint> {
        self.automatic.binary_search_by_key(&frame, |p| p.frame).ok().map(|i| &self.automatic[i])
    }

    /// The point in force for `frame`: the correction (P recomputed from the setup's line)
    /// when there is one, else the automatic point.
    pub fn effective(&self, frame: usize, setup: &ProfileSetup) -> Option<ProfilePoint> {
        match self.corrected.get(&frame) {
            Some(&p) => Some(ProfilePoint::at(
                frame,
                p,
                setup,
                self.nose_length_px,
                PointSource::Corrected,
                self.automatic(frame).and_then(|a| a.motion),
            )),
            None => self.automatic(frame).cloned(),
        }
    }

    /// Every frame's effective point (automatic frames plus frames only corrected).
    pub fn effective_all(&self, setup: &ProfileSetup) -> Vec<ProfilePoint> {
        let mut frames: Vec<usize> = self.automatic.iter().map(|p| p.frame).collect();
        frames.extend(self.corrected.keys().copied());
        frames.sort_unstable();
        frames.dedup();
        frames.into_iter().filter_map(|f| self.effective(f, setup)).collect()
    }
}

/// Proposes a setup from one frame, so the CLI can run without clicks.
///
/// On the full frame's profile: the nose tip is the foremost point within the silhouette's
/// upper three quarters; the nasion the deepest hull concavity above it; below it, the first
/// bump standing out by 2 % of the nose length is the upper lip and the lowest point between
/// tip and lip the subnasale. Then, with L the nose length:
/// - crop rows from halfway between tip and subnasale down to subnasale + 0.9 L (lips and
///   labiomental fold), columns from 0.5 L behind the subnasale (inside the face) to 0.25 L
///   beyond the nose tip (background), clipped to the frame;
/// - reference line: vertical through the subnasale (the frontal plane seen with the camera
///   level; tilt it by hand when the camera is pitched);
/// - nose length: the two points found, fixed once;
/// - anchor: the profile from 0.8 nose heights above the nasion down to just under the tip,
///   so the line follows the head ([`ProfileSetup::anchor`]; set it to `None` to measure
///   from the line as drawn, as the published method did).
///
/// # Errors
/// Segmentation errors, [`ProfileError::NoseNotFound`] or [`ProfileError::NoUpperLip`] when
/// the profile lacks that structure.
pub fn propose_setup(frame: &GrayImage, facing: Facing) -> Result<ProfileSetup, ProfileError> {
    let min_component = default_min_component_px();
    let profile = full_frame_profile(frame, facing, Threshold::Otsu, true, min_component)?;
    let rows: Vec<usize> = (0..profile.len()).filter(|&r| profile[r].is_some()).collect();
    let (&first, &last) = (rows.first().ok_or(ProfileError::NoseNotFound)?, rows.last().unwrap());
    let limit = first + (3 * (last - first)) / 4;
    let s: Vec<(usize, Real)> =
        rows.iter().filter(|&&r| r <= limit).map(|&r| (r, profile[r].unwrap().1)).collect();
    let nose = nose_from_samples(&s, &profile, limit + 1, Vector2::new(facing.sign(), 0.0))
        .ok_or(ProfileError::NoseNotFound)?;
    let len = nose.length_px();
    let tip_row = nose.tip.y.round() as usize;
    // Below the tip: forward position per row (rows without face sit far behind).
    let below: Vec<Real> =
        (tip_row..profile.len()).map(|r| profile[r].map_or(-1e9, |p| p.1)).collect();
    let smoothed = smooth(&below);
    let lip = find_peaks(&smoothed)
        .into_iter()
        .find(|p| p.prominence >= 0.02 * len)
        .ok_or(ProfileError::NoUpperLip(0.02 * len))?;
    let sn_smooth =
        (0..lip.index).min_by(|&a, &b| smoothed[a].total_cmp(&smoothed[b])).unwrap_or(0);
    // Smoothing moves a sharp concavity's minimum by a row; the raw minimum near it is exact.
    let sn_off = (sn_smooth.saturating_sub(2)..(sn_smooth + 3).min(lip.index))
        .min_by(|&a, &b| below[a].total_cmp(&below[b]))
        .unwrap_or(sn_smooth);
    let sn_row = tip_row + sn_off;
    let (sn_pt, sn_u) = profile[sn_row].ok_or(ProfileError::NoUpperLip(0.02 * len))?;
    let tip_u = profile[tip_row].map_or(sn_u + len, |p| p.1);
    let (w, h) = frame.dimensions();
    let top = tip_row + sn_off / 2;
    let bottom = ((sn_row as Real + 0.9 * len).round() as usize).min(h as usize);
    let u_rear = sn_u - 0.5 * len;
    let u_front = tip_u + 0.25 * len;
    if bottom <= top + 2 || u_front <= u_rear.max(0.0) + 2.0 {
        return Err(ProfileError::NoUpperLip(0.02 * len));
    }
    // Forward-coordinate columns [u0, u1] and rows [r0, r1) as an image rectangle.
    let rect = |u0: Real, u1: Real, r0: usize, r1: usize| {
        let (u0, u1) = (u0.floor().max(0.0) as u32, u1.ceil().min(w as Real - 1.0) as u32);
        let x = match facing {
            Facing::Right => u0,
            Facing::Left => w - 1 - u1,
        };
        Rect::new(x, r0 as u32, u1 - u0 + 1, (r1 - r0) as u32)
    };
    let mut setup = ProfileSetup::new(
        rect(u_rear, u_front, top, bottom),
        ReferenceLine::vertical(sn_pt.x),
        facing,
    );
    setup.nose = NoseLength::Points { root: nose.root, tip: nose.tip };
    // The anchor: forehead above the nasion down to just under the nose tip, rigid parts.
    let root_row = nose.root.y.round() as usize;
    let root_u = profile[root_row].map_or(tip_u - len, |p| p.1);
    let a_top = root_row.saturating_sub((0.8 * (tip_row - root_row) as Real) as usize);
    let a_bottom = (tip_row + sn_off / 4 + 1).min(top);
    if a_bottom > a_top + MIN_REGISTRATION_ROWS {
        let region = rect(root_u.min(tip_u) - 0.4 * len, u_front, a_top, a_bottom);
        setup.anchor = Some(capture_anchor(frame, &setup, region)?);
    }
    Ok(setup)
}
