//! Image evidence for the flags: what the frame itself shows where the tracker put a point.
//!
//! Two edges of the lower lip are read along the mouth's own vertical (perpendicular to the
//! corner line 49→55, so a rolled head is measured in its mouth's frame):
//! - its **upper edge on an open mouth**. The inner lower lip borders the mouth's interior;
//!   a tracker that rides the lower lip up onto the tongue (dlib on carphone's wide
//!   openings) leaves the points above the steepest rise of redness that marks where the
//!   lip proper begins ([`lower_lip_edge_offset`]);
//! - its **lower edge, on every frame**, open or closed. The outer lower lip points belong
//!   on the steepest fall of redness from the lip down to the chin's skin; a tracker whose
//!   lower lip slides down onto the chin (rolled closed lips, a last frame after a slip)
//!   leaves them below it ([`outer_lower_lip_edge_offset`]).
//!
//! Each is judged beyond the clip's own registration (the median offset of its frames: a
//! tracker's sub-pixel convention moves every frame alike). Start at [`image_flags`];
//! `docs/flags.md` has the calibration on carphone.

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

/// The least change of [`smoothed_redness`] per pixel read as a lip's edge (the lower
/// lip's rise under the open mouth, its fall onto the chin). On carphone the steepest fall
/// under the outer lower lip is never under 0.038 per px and the rise under the open mouth
/// is under 0.004 per px in fewer than one reading in twenty; a face drawn without red lips
/// (the TUI's test fixture) changes by under 0.0004 per px, where the steepest change is
/// noise and its place says nothing.
const MIN_LIP_EDGE_STEP_PER_PX: f64 = 0.001;

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
    // A face whose lip is not redder than what lies above it shows no edge to read.
    (r[k] - r[k + 1] >= MIN_LIP_EDGE_STEP_PER_PX * STEP_PX).then(|| 0.5 * (t(k) + t(k + 1)))
}

/// How far a frame's lip points sit from a lip edge in the image, in the direction the
/// check looks for a mistake (px; negative the other way).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EdgeOffset {
    /// The median over the points.
    pub median_px: f64,
    /// The point (0-based iBUG id) furthest off, and its distance (px).
    pub furthest: (usize, f64),
}

impl EdgeOffset {
    /// The median and the furthest of `offsets` (point, px); `None` for fewer than two.
    fn of(offsets: Vec<(usize, f64)>) -> Option<Self> {
        if offsets.len() < 2 {
            return None;
        }
        let mut d: Vec<f64> = offsets.iter().map(|o| o.1).collect();
        d.sort_by(f64::total_cmp);
        let furthest = offsets.into_iter().max_by(|a, b| a.1.total_cmp(&b.1))?;
        Some(Self { median_px: median_of_sorted(&d), furthest })
    }
}

/// One frame's image evidence on its lower lip.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LipEdgeOffset {
    /// How far the inner lower lip sits above the lip's upper edge (an open mouth only;
    /// [`lower_lip_edge_offset`]).
    pub inner: Option<EdgeOffset>,
    /// How far the outer lower lip sits below the lip's lower edge
    /// ([`outer_lower_lip_edge_offset`]).
    pub outer: Option<EdgeOffset>,
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
) -> Option<EdgeOffset> {
    let pos = |i: usize| frame.points.get(i).filter(|p| p.visible).map(|p| p.pos());
    let up = mouth_up(frame, face_size)?;
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
    EdgeOffset::of(offsets)
}

/// The mouth's vertical in the image, towards the upper lip: the corner line 49→55 turned
/// by −90° (image y points down), so a rolled head is read in its mouth's own frame; `None`
/// without both corners or a face size.
fn mouth_up(frame: &FrameLandmarks, face_size: f64) -> Option<Vector2> {
    let pos = |i: usize| frame.points.get(i).filter(|p| p.visible).map(|p| p.pos());
    let across = pos(54)? - pos(48)?;
    if across.norm() <= 1e-9 || face_size <= 0.0 {
        return None;
    }
    Some(Vector2::new(across.y, -across.x).normalize())
}

/// Outer lower lip points whose lower edge is read, with the inner lower point above each
/// (0-based iBUG ids): 58 ↔ 67, 57 ↔ 66, 56 ↔ 65.
pub const OUTER_LOWER_LIP_COLUMNS: [(usize, usize); 3] = [(58, 67), (57, 66), (56, 65)];

/// How far below the outer lower lip point the lip's lower edge is sought, in face sizes:
/// 3 px on carphone's 31-px face, as far as a tracker's slide onto the chin goes.
const OUTER_EDGE_REACH_FACE_FRACTION: f64 = 0.1;

/// Along the mouth's vertical through each outer lower lip point of `frame` (56, 57, 58),
/// how far the point sits below the lower lip's lower edge in the image: the steepest fall
/// of [`smoothed_redness`] going down from the lip to the chin's skin, sought from half way
/// up to the inner lower point (above that lies the gap between the lips, whose own edges
/// are not the lip's) down to `OUTER_EDGE_REACH_FACE_FRACTION` of `face_size` below. Read
/// on every frame, open or closed. `None` without the corners, or with fewer than two
/// points measured.
pub fn outer_lower_lip_edge_offset(
    frame: &FrameLandmarks,
    img: &FrameRgb<'_>,
    face_size: f64,
) -> Option<EdgeOffset> {
    let pos = |i: usize| frame.points.get(i).filter(|p| p.visible).map(|p| p.pos());
    let up = mouth_up(frame, face_size)?;
    let mut offsets: Vec<(usize, f64)> = Vec::new();
    for (outer, inner) in OUTER_LOWER_LIP_COLUMNS {
        let (Some(o), Some(q)) = (pos(outer), pos(inner)) else { continue };
        let (from, to) = (-OUTER_EDGE_REACH_FACE_FRACTION * face_size, 0.5 * (q - o).dot(&up));
        if to - from < 2.0 * STEP_PX {
            continue;
        }
        let steps = ((to - from) / STEP_PX).floor() as usize;
        let t = |k: usize| from + k as f64 * STEP_PX;
        let Some(r) =
            (0..=steps).map(|k| smoothed_redness(img, o + up * t(k))).collect::<Option<Vec<_>>>()
        else {
            continue;
        };
        // Going down is going to smaller t: the fall is r(t + step) − r(t).
        let Some(k) = (0..steps).max_by(|&a, &b| (r[a + 1] - r[a]).total_cmp(&(r[b + 1] - r[b])))
        else {
            continue;
        };
        // A face whose lip is not redder than its chin shows no edge to read.
        if r[k + 1] - r[k] < MIN_LIP_EDGE_STEP_PER_PX * STEP_PX {
            continue;
        }
        offsets.push((outer, 0.5 * (t(k) + t(k + 1))));
    }
    EdgeOffset::of(offsets)
}

fn median_of_sorted(d: &[f64]) -> f64 {
    let n = d.len();
    if n % 2 == 1 { d[n / 2] } else { 0.5 * (d[n / 2 - 1] + d[n / 2]) }
}

/// Fewest measured frames from which a clip's registration is estimated; below it none is
/// taken off.
const MIN_REGISTRATION_FRAMES: usize = 5;

/// The clip's registration between its points and its frames for one edge, in face sizes:
/// the median of the frames' offsets from it ([`EdgeOffset::median_px`], `edge` picks which
/// of a frame's offsets) over their face sizes. A tracker's points can sit a fraction of a
/// pixel off the image (a file convention, a resize, the tracker's own bias), which shifts
/// every frame's distance from a lip's edge alike; the median frame is taken as placed
/// right. 0 for fewer than [`MIN_REGISTRATION_FRAMES`] frames measured.
pub fn lip_edge_registration(
    offsets: &[(usize, f64, LipEdgeOffset)],
    edge: impl Fn(&LipEdgeOffset) -> Option<EdgeOffset>,
) -> f64 {
    let mut d: Vec<f64> =
        offsets.iter().filter_map(|(_, size, o)| edge(o).map(|e| e.median_px / size)).collect();
    if d.len() < MIN_REGISTRATION_FRAMES {
        return 0.0;
    }
    d.sort_by(f64::total_cmp);
    median_of_sorted(&d)
}

/// How far `offset`'s points lie off their edge beyond the clip's `registration` (face
/// sizes) when their median does by more than `limit` (face sizes) of `face_size`: the
/// point furthest off and its distance (px) beyond the registration. One point astray is
/// the shape checks' business, so the median over the points must pass the limit.
fn beyond_registration(
    offset: &EdgeOffset,
    face_size: f64,
    registration: f64,
    limit: f64,
) -> Option<(usize, f64)> {
    let excess = |px: f64| px - registration * face_size;
    (excess(offset.median_px) > limit * face_size)
        .then(|| (offset.furthest.0, excess(offset.furthest.1)))
}

/// The flag of one open frame whose inner lower lip sits above the lower lip's edge in the
/// image by more than `lower_lip_edge_face_fraction` of `face_size` beyond the clip's
/// `registration` (face sizes; [`lip_edge_registration`]): the points ride on the tongue
/// (the band between the open mouth's dark and the lip proper). The point furthest above
/// the edge is named, with its distance beyond the registration.
pub fn lower_lip_off_opening(
    offset: &EdgeOffset,
    face_size: f64,
    registration: f64,
    th: &FlagThresholds,
) -> Option<FlagReason> {
    let (point, px) =
        beyond_registration(offset, face_size, registration, th.lower_lip_edge_face_fraction)?;
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

/// The lip-edge offsets of a clip, on every frame that `image_of` gives an image for (frame
/// number → its pixels; frames it has none for are skipped): [`outer_lower_lip_edge_offset`]
/// on each, [`lower_lip_edge_offset`] on those whose mouth is open enough to be checked
/// ([`mouth_open_enough`]); each as (frame number, face size, offsets), frames with neither
/// left out.
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
            let img = image_of(f.frame)?;
            let img = img.frame_rgb();
            let inner = mouth_open_enough(f, size, th)
                .then(|| lower_lip_edge_offset(f, &img, size, th))
                .flatten();
            let outer = outer_lower_lip_edge_offset(f, &img, size);
            (inner.is_some() || outer.is_some()).then_some((
                f.frame,
                size,
                LipEdgeOffset { inner, outer },
            ))
        })
        .collect()
}

/// The image flags of a clip: the lower lip on the tongue ([`lower_lip_off_opening`]) and
/// on the chin (`outer_lip_edge_face_fraction`) on each of its [`lip_edge_offsets`], beyond
/// the registrations they give ([`lip_edge_registration`]).
pub fn image_flags<T: RgbPixels>(
    track: &Track,
    image_of: impl Fn(usize) -> Option<T>,
    th: &FlagThresholds,
) -> Vec<(usize, FlagReason)> {
    flags_of_lip_edges(&lip_edge_offsets(track, image_of, th), th)
}

/// The flags of a clip's lip-edge offsets (frame number, face size, offsets), each edge
/// judged beyond the registration of all the frames measured on it.
pub fn flags_of_lip_edges(
    offsets: &[(usize, f64, LipEdgeOffset)],
    th: &FlagThresholds,
) -> Vec<(usize, FlagReason)> {
    let inner = lip_edge_registration(offsets, |o| o.inner);
    let outer = lip_edge_registration(offsets, |o| o.outer);
    offsets
        .iter()
        .flat_map(|(frame, size, o)| {
            let on_tongue = o.inner.and_then(|e| lower_lip_off_opening(&e, *size, inner, th));
            // Outer points slid below the lip's lower edge, onto the chin.
            let on_chin = o
                .outer
                .and_then(|e| {
                    beyond_registration(&e, *size, outer, th.outer_lip_edge_face_fraction)
                })
                .map(|(point, px)| FlagReason::OuterLowerLipOffEdge {
                    point,
                    px,
                    face_fraction: px / size,
                });
            on_tongue.into_iter().chain(on_chin).map(|r| (*frame, r))
        })
        .collect()
}

/// Whether the tracked inner lips of `frame` are far enough apart for the open-mouth check
/// to mean anything (the midline gap above the limit it tests).
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
        let registration = lip_edge_registration(&offsets, |o| o.inner);
        assert!((registration * 50.0 - 2.0).abs() < 0.5, "{registration}");
        let flagged: Vec<usize> =
            image_flags(&track, |_| Some(img.clone()), &th).into_iter().map(|f| f.0).collect();
        assert_eq!(flagged, vec![6]);
        // Too few frames to estimate it: none is taken off.
        assert_eq!(
            lip_edge_registration(&offsets[..MIN_REGISTRATION_FRAMES - 1], |o| o.inner),
            0.0
        );
    }

    #[test]
    fn a_lower_lip_slid_onto_the_chin_is_flagged_open_or_closed() {
        let th = FlagThresholds::default();
        let img = std::sync::Arc::new(image(22));
        // The lip's lower edge is between rows 40 and 41: outer points on it in six frames,
        // closed lips in two of them; the seventh frame's lower lip slid 4 px onto the chin.
        let mut frames: Vec<FrameLandmarks> =
            (0..6).map(|k| frame(if k < 2 { 9.0 } else { 30.0 })).collect();
        let mut slid = frame(30.0);
        for (lower, _, outer) in LOWER_LIP_COLUMNS {
            slid.points[outer].y += 4.0;
            slid.points[lower].y += 4.0;
        }
        frames.push(slid);
        for (k, f) in frames.iter_mut().enumerate() {
            f.frame = k;
        }
        let track = Track::new(frames);
        let offsets = lip_edge_offsets(&track, |_| Some(img.clone()), &th);
        assert!(offsets.iter().all(|(_, _, o)| o.outer.is_some()));
        assert!(offsets[0].2.inner.is_none(), "closed lips have no open-mouth evidence");
        let flags = image_flags(&track, |_| Some(img.clone()), &th);
        let on_chin: Vec<&(usize, FlagReason)> = flags
            .iter()
            .filter(|(_, r)| matches!(r, FlagReason::OuterLowerLipOffEdge { .. }))
            .collect();
        assert_eq!(on_chin.len(), 1, "{flags:?}");
        match on_chin[0] {
            (6, FlagReason::OuterLowerLipOffEdge { point, px, .. }) => {
                assert!(LOWER_LIP_COLUMNS.iter().any(|c| c.2 == *point));
                assert!((px - 4.0).abs() < 1.0, "{px}");
            }
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn a_face_without_red_lips_shows_no_lower_lip_edge() {
        // Skin everywhere: the steepest fall of redness is the smoothing's noise, not an edge.
        let skin = image::RgbImage::from_pixel(60, 60, image::Rgb([200, 160, 140]));
        let rgb = FrameRgb::of(&skin);
        assert_eq!(outer_lower_lip_edge_offset(&frame(30.0), &rgb, 50.0), None);
        // The same points on a face with a red lip are read.
        let lip = image(22);
        assert!(outer_lower_lip_edge_offset(&frame(30.0), &FrameRgb::of(&lip), 50.0).is_some());
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
