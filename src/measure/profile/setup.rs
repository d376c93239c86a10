//! What is set once per clip: the mouth crop, the reference line P is measured from, which
//! way the face looks, the threshold, the nose length P is divided by and the optional
//! head-following anchor. Sessions store [`ProfileSetup`]; its tuning fields have serde
//! defaults so older sessions load.

use crate::math::{Point2, Real, Vector2};
use serde::{Deserialize, Serialize};

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

/// Two points closer than this (px) do not define a line.
const MIN_LINE_LENGTH_PX: Real = 1e-9;

/// Smallest x component of a reference line's unit normal: sin 30°, so the line is at least
/// 30° from horizontal.
const MIN_NORMAL_X: Real = 0.5;

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
        if !(len.is_finite() && len > MIN_LINE_LENGTH_PX) {
            return None;
        }
        let d = d / len;
        let mut n = Vector2::new(d.y, -d.x);
        if n.x * facing.sign() < 0.0 {
            n = -n;
        }
        (n.x.abs() >= MIN_NORMAL_X).then_some(n)
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

pub(super) fn default_min_component_px() -> usize {
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
