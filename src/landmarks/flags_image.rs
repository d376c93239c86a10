//! Image evidence for the flags: what the frame itself shows where the tracker put a point.
//!
//! An open mouth's inner lower lip borders the mouth's interior: directly above a correctly
//! placed point (towards the upper lip) the image turns to the dark of the open mouth, or to
//! teeth, within the blur of that edge. A tracker that rides the lower lip up onto the tongue
//! (dlib on carphone's wide openings) leaves a band of tongue — neither dark nor teeth —
//! between the point and the opening. [`lower_lip_off_opening`] measures that band along the
//! mouth's vertical through each inner lower lip point and names the point when it is wider
//! than `FlagThresholds::lower_lip_opening_face_fraction` of the face (the size of a real
//! mistake) beyond the edge's blur. Start at [`image_flags`]; `docs/flags.md` has the
//! calibration on carphone.

use super::flags::{FlagReason, FlagThresholds, face_sizes};
use super::track::{FrameLandmarks, Track};
use crate::math::{Point2, Vector2};

/// Inner lower lip points with the inner upper point across the mouth from each and the
/// outer lower point below it (0-based iBUG ids): 67 ↔ 61 / 58, 66 ↔ 62 / 57, 65 ↔ 63 / 56.
pub const LOWER_LIP_COLUMNS: [(usize, usize, usize); 3] =
    [(67, 61, 58), (66, 62, 57), (65, 63, 56)];

/// Step (px) of the samples along the mouth's vertical.
const STEP_PX: f64 = 0.25;

/// A frame's pixels as the image checks read them: RGB, 3 bytes a pixel, row-major.
#[derive(Clone, Copy, Debug)]
pub struct FrameRgb<'a> {
    pub width: u32,
    pub height: u32,
    pub rgb: &'a [u8],
}

impl<'a> FrameRgb<'a> {
    /// A view of `image`'s pixels.
    pub fn of(image: &'a image::RgbImage) -> Self {
        Self { width: image.width(), height: image.height(), rgb: image.as_raw() }
    }

    fn pixel(&self, x: i64, y: i64) -> [f64; 3] {
        let x = x.clamp(0, i64::from(self.width) - 1) as usize;
        let y = y.clamp(0, i64::from(self.height) - 1) as usize;
        let i = 3 * (y * self.width as usize + x);
        match self.rgb.get(i..i + 3) {
            Some(p) => [f64::from(p[0]), f64::from(p[1]), f64::from(p[2])],
            None => [0.0; 3],
        }
    }

    /// Bilinear colour at `p` (pixel centres at integer coordinates, as landmarks are given);
    /// `None` off the image or on an empty one.
    pub fn sample(&self, p: Point2) -> Option<[f64; 3]> {
        let inside = |v: f64, n: u32| v.is_finite() && v >= -0.5 && v <= f64::from(n) - 0.5;
        if self.width == 0 || !inside(p.x, self.width) || !inside(p.y, self.height) {
            return None;
        }
        let (x0, y0) = (p.x.floor(), p.y.floor());
        let (fx, fy) = (p.x - x0, p.y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let mut out = [0.0; 3];
        for (dx, dy, w) in [
            (0, 0, (1.0 - fx) * (1.0 - fy)),
            (1, 0, fx * (1.0 - fy)),
            (0, 1, (1.0 - fx) * fy),
            (1, 1, fx * fy),
        ] {
            let c = self.pixel(x0 + dx, y0 + dy);
            for k in 0..3 {
                out[k] += w * c[k];
            }
        }
        Some(out)
    }
}

/// Luma (Rec. 601 weights).
fn luma(c: [f64; 3]) -> f64 {
    0.299 * c[0] + 0.587 * c[1] + 0.114 * c[2]
}

/// Colourfulness (max − min channel over max): lips and tongue are red, teeth are not.
fn saturation(c: [f64; 3]) -> f64 {
    let (hi, lo) = (c[0].max(c[1]).max(c[2]), c[0].min(c[1]).min(c[2]));
    if hi <= 0.0 { 0.0 } else { (hi - lo) / hi }
}

/// Teeth: brighter than the lip and nearly grey.
const TEETH_SATURATION: f64 = 0.2;

/// How far (px) above inner lower lip point `q` the mouth's interior begins, along `up`
/// (unit, towards the upper lip), looking no further than `reach` px: the first sample
/// darker than halfway between the darkest sample up to `reach` and the lip below `q` (the
/// median of the samples from `q` down to the outer lip, `below` px), or one brighter than
/// that lip and nearly grey (teeth). `None` when the colours are off the image, or when
/// nothing up to `reach` is at most half as bright as the lip (no open interior to border).
fn interior_above(
    img: &FrameRgb<'_>,
    q: Point2,
    up: Vector2,
    reach: f64,
    below: f64,
) -> Option<f64> {
    let at = |t: f64| img.sample(q + up * t);
    let mut lip: Vec<f64> =
        (1..8).map(|k| at(-below * f64::from(k) / 8.0).map(luma)).collect::<Option<_>>()?;
    lip.sort_by(f64::total_cmp);
    let lip = lip[lip.len() / 2];
    let steps = (reach / STEP_PX).floor() as usize;
    let samples: Vec<[f64; 3]> =
        (0..=steps).map(|k| at(k as f64 * STEP_PX)).collect::<Option<_>>()?;
    let dark = samples.iter().map(|c| luma(*c)).fold(f64::INFINITY, f64::min);
    if dark > 0.5 * lip {
        return None;
    }
    let mid = 0.5 * (dark + lip);
    samples
        .iter()
        .position(|&c| luma(c) < mid || (luma(c) > lip && saturation(c) < TEETH_SATURATION))
        .map(|k| k as f64 * STEP_PX)
}

/// Redness, (R − G) / R: the lip is redder than the tongue and the mouth's dark interior
/// at any brightness.
fn redness(c: [f64; 3]) -> f64 {
    if c[0] <= 0.0 { 0.0 } else { (c[0] - c[1]) / c[0] }
}

/// Standard deviation (px) of the Gaussian that smooths the redness before its edge is
/// sought: a video frame's lip edge is a pixel or two wide, and a single pixel's colour is
/// noise at that scale.
const REDNESS_SIGMA_PX: f64 = 0.7;

/// [`redness`] at `p`, Gaussian-weighted (σ [`REDNESS_SIGMA_PX`]) over a 5×5 grid of
/// bilinear samples half a pixel apart; `None` off the image.
fn smoothed_redness(img: &FrameRgb<'_>, p: Point2) -> Option<f64> {
    let (mut sum, mut weights) = (0.0, 0.0);
    for i in -2..=2_i32 {
        for j in -2..=2_i32 {
            let (dx, dy) = (0.5 * f64::from(i), 0.5 * f64::from(j));
            let w = (-(dx * dx + dy * dy) / (2.0 * REDNESS_SIGMA_PX * REDNESS_SIGMA_PX)).exp();
            sum += w * redness(img.sample(Point2::new(p.x + dx, p.y + dy))?);
            weights += w;
        }
    }
    Some(sum / weights)
}

/// Where (px along `up` from inner lower lip point `q`; negative below it) the lower lip's
/// own edge lies in the image: the steepest rise of [`smoothed_redness`] going down, between
/// a pixel under the mouth's interior (`interior` px above `q`; the interior's own edge,
/// dark to red, is blurred that far by the smoothing) and half a pixel inside the outer lip
/// (`below` px under `q`). `None` when that span holds fewer than three samples.
fn lip_edge(img: &FrameRgb<'_>, q: Point2, up: Vector2, interior: f64, below: f64) -> Option<f64> {
    let (from, to) = (-below + 0.5, interior - 1.0);
    if to - from < 2.0 * STEP_PX {
        return None;
    }
    let steps = ((to - from) / STEP_PX).floor() as usize;
    let t = |k: usize| from + k as f64 * STEP_PX;
    let r: Vec<f64> =
        (0..=steps).map(|k| smoothed_redness(img, q + up * t(k))).collect::<Option<_>>()?;
    let k = (0..steps).max_by(|&a, &b| (r[a] - r[a + 1]).total_cmp(&(r[b] - r[b + 1])))?;
    Some(0.5 * (t(k) + t(k + 1)))
}

/// How far one open frame's inner lower lip sits above the lower lip's edge in the image.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LipEdgeOffset {
    /// The median over the inner lower points (px; negative below the edge).
    pub median_px: f64,
    /// The point (0-based iBUG id) furthest above the edge, and its distance (px).
    pub furthest: (usize, f64),
}

/// Along the mouth's vertical through each inner lower point of `frame`, the distance from
/// the lower lip's edge in the image up to the point: the lip's edge is the steepest rise
/// of redness going down from just under the dark interior to the outer lip
/// ([`lip_edge`]). `None` for lips too close to hold more than the edge of the interior
/// (`lower_lip_opening_face_fraction` of `face_size` plus `lower_lip_edge_px`), an opening
/// with no dark interior, or fewer than two points measured.
pub fn lower_lip_edge_offset(
    frame: &FrameLandmarks,
    img: &FrameRgb<'_>,
    face_size: f64,
    th: &FlagThresholds,
) -> Option<LipEdgeOffset> {
    let pos = |i: usize| frame.points.get(i).filter(|p| p.visible).map(|p| p.pos());
    let across = pos(54)? - pos(48)?;
    if across.norm() <= 1e-9 || face_size <= 0.0 {
        return None;
    }
    // Image y points down: the corner line turned by −90° points up the face.
    let up = Vector2::new(across.y, -across.x).normalize();
    let open = th.lower_lip_opening_face_fraction * face_size + th.lower_lip_edge_px;
    let mut offsets: Vec<(usize, f64)> = Vec::new();
    for (lower, upper, outer) in LOWER_LIP_COLUMNS {
        let (Some(q), Some(u), Some(o)) = (pos(lower), pos(upper), pos(outer)) else { continue };
        let (reach, below) = ((u - q).dot(&up), (q - o).dot(&up));
        // An opening too narrow to hold more than the edge itself cannot show the mistake.
        if reach <= open || below <= 0.0 {
            continue;
        }
        let edge = interior_above(img, q, up, reach, below)
            .and_then(|interior| lip_edge(img, q, up, interior, below));
        if let Some(edge) = edge {
            offsets.push((lower, -edge));
        }
    }
    if offsets.len() < 2 {
        return None;
    }
    let mut d: Vec<f64> = offsets.iter().map(|o| o.1).collect();
    d.sort_by(f64::total_cmp);
    let furthest = offsets.into_iter().max_by(|a, b| a.1.total_cmp(&b.1))?;
    Some(LipEdgeOffset { median_px: median_of_sorted(&d), furthest })
}

fn median_of_sorted(d: &[f64]) -> f64 {
    let n = d.len();
    if n % 2 == 1 { d[n / 2] } else { 0.5 * (d[n / 2 - 1] + d[n / 2]) }
}

/// Fewest measured frames from which a clip's registration is estimated; below it none is
/// taken off.
const MIN_REGISTRATION_FRAMES: usize = 5;

/// The clip's registration between its points and its frames, in face sizes: the median of
/// the frames' [`LipEdgeOffset::median_px`] over their face sizes. A tracker's points can
/// sit a fraction of a pixel off the image (a file convention, a resize, the tracker's own
/// bias), which shifts every frame's distance from the lip's edge alike; the median frame is
/// taken as placed right. 0 for fewer than [`MIN_REGISTRATION_FRAMES`] frames.
pub fn lip_edge_registration(offsets: &[(usize, f64, LipEdgeOffset)]) -> f64 {
    if offsets.len() < MIN_REGISTRATION_FRAMES {
        return 0.0;
    }
    let mut d: Vec<f64> = offsets.iter().map(|(_, size, o)| o.median_px / size).collect();
    d.sort_by(f64::total_cmp);
    median_of_sorted(&d)
}

/// The flag of one open frame whose inner lower lip sits above the lower lip's edge in the
/// image by more than `lower_lip_edge_face_fraction` of `face_size` beyond the clip's
/// `registration` (face sizes; [`lip_edge_registration`]): the points ride on the tongue
/// (the band between the open mouth's dark and the lip proper). The median over the points
/// must exceed the limit (one point astray is the shape checks' business); the point
/// furthest above the edge is named, with its distance beyond the registration.
pub fn lower_lip_off_opening(
    offset: &LipEdgeOffset,
    face_size: f64,
    registration: f64,
    th: &FlagThresholds,
) -> Option<FlagReason> {
    let excess = |px: f64| px - registration * face_size;
    if excess(offset.median_px) <= th.lower_lip_edge_face_fraction * face_size {
        return None;
    }
    let (point, px) = (offset.furthest.0, excess(offset.furthest.1));
    Some(FlagReason::LowerLipOffOpening { point, px, face_fraction: px / face_size })
}

/// Pixels the image checks can read as a [`FrameRgb`]: a decoded frame of any owner.
pub trait RgbPixels {
    fn frame_rgb(&self) -> FrameRgb<'_>;
}

impl RgbPixels for image::RgbImage {
    fn frame_rgb(&self) -> FrameRgb<'_> {
        FrameRgb::of(self)
    }
}

impl<T: RgbPixels + ?Sized> RgbPixels for std::sync::Arc<T> {
    fn frame_rgb(&self) -> FrameRgb<'_> {
        (**self).frame_rgb()
    }
}

/// The lip-edge offsets of a clip: [`lower_lip_edge_offset`] on every frame whose mouth is
/// open enough to be checked ([`mouth_open_enough`]) and that `image_of` gives an image for
/// (frame number → its pixels; frames it has none for are skipped, and frames too closed to
/// check are never asked for), each as (frame number, face size, offset).
pub fn lip_edge_offsets<T: RgbPixels>(
    track: &Track,
    image_of: impl Fn(usize) -> Option<T>,
    th: &FlagThresholds,
) -> Vec<(usize, f64, LipEdgeOffset)> {
    let sizes = face_sizes(track);
    track
        .frames
        .iter()
        .zip(sizes)
        .filter_map(|(f, size)| {
            let size = size?;
            if !mouth_open_enough(f, size, th) {
                return None;
            }
            let img = image_of(f.frame)?;
            lower_lip_edge_offset(f, &img.frame_rgb(), size, th).map(|o| (f.frame, size, o))
        })
        .collect()
}

/// The image flags of a clip: [`lower_lip_off_opening`] on each of its
/// [`lip_edge_offsets`], beyond the registration they give ([`lip_edge_registration`]).
pub fn image_flags<T: RgbPixels>(
    track: &Track,
    image_of: impl Fn(usize) -> Option<T>,
    th: &FlagThresholds,
) -> Vec<(usize, FlagReason)> {
    flags_of_lip_edges(&lip_edge_offsets(track, image_of, th), th)
}

/// The flags of a clip's lip-edge offsets (frame number, face size, offset), each judged
/// beyond the registration of them all.
pub fn flags_of_lip_edges(
    offsets: &[(usize, f64, LipEdgeOffset)],
    th: &FlagThresholds,
) -> Vec<(usize, FlagReason)> {
    let registration = lip_edge_registration(offsets);
    offsets
        .iter()
        .filter_map(|(frame, size, o)| {
            lower_lip_off_opening(o, *size, registration, th).map(|r| (*frame, r))
        })
        .collect()
}

/// Whether the tracked inner lips of `frame` are far enough apart for the check to mean
/// anything (the midline gap above the limit it tests): frames that cannot be flagged are
/// not decoded.
pub fn mouth_open_enough(frame: &FrameLandmarks, face_size: f64, th: &FlagThresholds) -> bool {
    let pos = |i: usize| frame.points.get(i).filter(|p| p.visible).map(|p| p.pos());
    let (Some(u), Some(q)) = (pos(62), pos(66)) else { return false };
    (q - u).norm() > th.lower_lip_opening_face_fraction * face_size + th.lower_lip_edge_px
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::landmarks::LandmarkPoint;

    /// A 60×60 mouth: skin, a dark interior from row 10 to `interior_end`, tongue pink from
    /// there to row 30, a red lower lip from row 30 to 40 (the outer lower lip at 40).
    fn image(interior_end: u32) -> image::RgbImage {
        image::RgbImage::from_fn(60, 60, |_, y| {
            image::Rgb(if (10..interior_end).contains(&y) {
                [20, 18, 25]
            } else if (interior_end..30).contains(&y) {
                [170, 120, 115]
            } else if (30..=40).contains(&y) {
                [150, 80, 80]
            } else {
                [200, 160, 140]
            })
        })
    }

    /// Mouth corners at y 20, inner upper lip at y 8, inner lower lip at `lower_y`, outer
    /// lower lip at 40; eye corners 50 px apart.
    fn frame(lower_y: f64) -> FrameLandmarks {
        let mut pts = vec![LandmarkPoint::tracked(30.0, 0.0); 68];
        pts[36] = LandmarkPoint::tracked(5.0, 0.0);
        pts[45] = LandmarkPoint::tracked(55.0, 0.0);
        pts[48] = LandmarkPoint::tracked(10.0, 20.0);
        pts[54] = LandmarkPoint::tracked(50.0, 20.0);
        for (k, (lower, upper, outer)) in LOWER_LIP_COLUMNS.into_iter().enumerate() {
            let x = 25.0 + 5.0 * k as f64;
            pts[lower] = LandmarkPoint::tracked(x, lower_y);
            pts[upper] = LandmarkPoint::tracked(x, 8.0);
            pts[outer] = LandmarkPoint::tracked(x, 40.0);
        }
        FrameLandmarks::new(0, pts)
    }

    /// The one frame's flag against no registration.
    fn flag_of(f: &FrameLandmarks, img: &image::RgbImage) -> Option<FlagReason> {
        let th = FlagThresholds::default();
        let offset = lower_lip_edge_offset(f, &FrameRgb::of(img), 50.0, &th)?;
        lower_lip_off_opening(&offset, 50.0, 0.0, &th)
    }

    #[test]
    fn a_lower_lip_on_the_tongue_is_flagged_and_one_on_the_lip_edge_is_not() {
        // The tongue from the interior's end (row 22) to the lip's edge (row 30).
        let img = image(22);
        let on_edge = frame(30.0);
        let offset =
            lower_lip_edge_offset(&on_edge, &FrameRgb::of(&img), 50.0, &FlagThresholds::default())
                .unwrap();
        assert!(offset.median_px.abs() < 1.0, "{offset:?}");
        assert_eq!(flag_of(&on_edge, &img), None);
        // Points 5 px up the tongue.
        let flag = flag_of(&frame(25.0), &img).unwrap();
        match flag {
            FlagReason::LowerLipOffOpening { point, px, face_fraction } => {
                assert!(LOWER_LIP_COLUMNS.iter().any(|c| c.0 == point));
                assert!((px - 5.0).abs() < 1.0, "{px}");
                assert!((face_fraction - px / 50.0).abs() < 1e-12);
            }
            other => panic!("{other:?}"),
        }
        // A point no further up than the limit (0.025 · 50 = 1.25 px) is not flagged.
        assert_eq!(flag_of(&frame(29.0), &img), None);
    }

    #[test]
    fn the_clips_registration_is_taken_off_every_frame() {
        let th = FlagThresholds::default();
        let img = std::sync::Arc::new(image(22));
        // Every frame's points 2 px up the tongue, as a tracker whose points sit 2 px off
        // the image places them: the clip's registration takes it off, and nothing is
        // flagged; one frame 7 px up is.
        let mut frames: Vec<FrameLandmarks> = (0..6).map(|_| frame(28.0)).collect();
        frames.push(frame(23.0));
        for (k, f) in frames.iter_mut().enumerate() {
            f.frame = k;
        }
        let track = Track::new(frames);
        let offsets = lip_edge_offsets(&track, |_| Some(img.clone()), &th);
        assert_eq!(offsets.len(), 7);
        let registration = lip_edge_registration(&offsets);
        assert!((registration * 50.0 - 2.0).abs() < 0.5, "{registration}");
        let flagged: Vec<usize> =
            image_flags(&track, |_| Some(img.clone()), &th).into_iter().map(|f| f.0).collect();
        assert_eq!(flagged, vec![6]);
        // Too few frames to estimate it: none is taken off.
        assert_eq!(lip_edge_registration(&offsets[..MIN_REGISTRATION_FRAMES - 1]), 0.0);
    }

    #[test]
    fn closed_lips_and_missing_images_give_nothing() {
        let th = FlagThresholds::default();
        let closed = frame(9.0);
        assert!(!mouth_open_enough(&closed, 50.0, &th));
        let track = Track::new(vec![closed, frame(25.0)]);
        let tongue = std::sync::Arc::new(image(22));
        let all = |_: usize| Some(tongue.clone());
        // Only the open frame is looked at; both frames are number 0 here, so the one flag
        // comes from the open one.
        assert_eq!(image_flags(&track, all, &th).len(), 1);
        let none = |_: usize| None::<image::RgbImage>;
        assert!(image_flags(&track, none, &th).is_empty());
        // Off the image: no evidence either way.
        let tiny = image::RgbImage::new(4, 4);
        assert_eq!(lower_lip_edge_offset(&frame(30.0), &FrameRgb::of(&tiny), 50.0, &th), None);
    }
}
