//! Jaw-line suggestions (iBUG 1–17) on a head, placed as human annotators of 3D scans place
//! them: on the jaw's silhouette seen from the front of the face, symmetric about its
//! midline, not on whatever surface happens to lie under the tracked 2D point.
//!
//! A tracked jaw point lies on the speaker's silhouette *as the camera saw it*: with the head
//! turned, the far side's silhouette is the cheek, tens of millimetres from the jaw line, and
//! the vertex under it in 2D is somewhere on the cheek or the neck. So the tracked points
//! only say *where along* the jaw each landmark is: each (carried onto the head's
//! proportions by the labels' warp) is taken into the face's frontal plane, its direction
//! from the nose tip is averaged with its mirror partner's (left–right symmetry), and along
//! that direction the head's frontal depth map is followed outward from the face to its
//! silhouette (the first drop steeper than [`SILHOUETTE_SLOPE`]). The jaw's ends (1 and 17)
//! are put at the height of the outer eye corners, as 3D annotators put them (a 2D
//! tracker's ends, warped from the labels' hull, fell 20 mm lower on a scan), and the other
//! directions are stretched from the chin in proportion, keeping the tracker's spacing. The landmark takes the
//! free vertex nearest that point, set [`BEHIND_SILHOUETTE`] behind the silhouette's front
//! edge (the side of the jaw is seen edge-on there, and annotators click on it, not on its
//! front rim).

use super::camera::OrthoPose;
use super::suggest::SuggestHead;
use crate::math::{Point2, Point3, Real, Vector2, Vector3};
use crate::model::LandmarkMap;
use crate::render::{Camera, RenderOptions, render_mesh_with_depth};
use crate::transfer::HeadFrame;
use nalgebra::Matrix2;
use std::collections::BTreeSet;

/// Depth-map cells per outer eye-corner distance.
const CELLS_PER_EYE_SPAN: Real = 200.0;
/// A drop in depth of more than this many cells over one cell ends the face (≈ 80°).
pub const SILHOUETTE_SLOPE: Real = 6.0;
/// How far behind the silhouette's front edge a jaw landmark on the side of the face sits,
/// in eye spans, scaled by sin² of its direction's angle from straight down: the side of the
/// jaw is seen edge-on, and on two faces with human 3D landmarks (menpo3d's scan and
/// template) the annotators' points lie 10–20 mm behind that edge on the sides and on or
/// in front of it around the chin, where the jaw turns under.
pub const BEHIND_SILHOUETTE: Real = 0.2;

/// One jaw landmark placed on the contour.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct JawPlacement {
    pub landmark: usize,
    pub vertex: usize,
    /// Pixels (in the frame) by which the symmetric direction moved the tracked one along
    /// the jaw: how much the two sides disagreed.
    pub asymmetry_px: Real,
}

/// The head in the face's frontal view: a depth map over the lower face.
struct FrontalView {
    frame: HeadFrame,
    camera: Camera,
    depth: Vec<f32>,
    /// Depth-map cell size (head units).
    cell: Real,
}

impl FrontalView {
    fn new(
        vertices: &[Point3],
        triangles: &[[u32; 3]],
        frame: HeadFrame,
        nose: Vector3,
        span: Real,
    ) -> Option<Self> {
        let cell = span / CELLS_PER_EYE_SPAN;
        let (lo, hi) = (
            Vector2::new(nose.x - 1.6 * span, nose.y - 1.6 * span),
            Vector2::new(nose.x + 1.6 * span, nose.y + 0.6 * span),
        );
        let width = ((hi.x - lo.x) / cell).ceil() as u32;
        let height = ((hi.y - lo.y) / cell).ceil() as u32;
        let pose = OrthoPose { r: frame.axes, s: 1.0 / cell, tx: -lo.x, ty: -lo.y };
        let camera = Camera { pose, width, height };
        let rendered = render_mesh_with_depth(
            vertices,
            triangles,
            &[[0, 0, 0]],
            &camera,
            &RenderOptions::default(),
        )
        .ok()?;
        Some(Self { frame, camera, depth: rendered.depth, cell })
    }

    /// Front-most depth (face axes) at face-plane point `p`; −∞ where no surface is.
    fn depth_at(&self, p: Vector2) -> Real {
        let s = self.camera.pose.s;
        let u = (s * (p.x + self.camera.pose.tx)).round();
        let v = (self.camera.height as Real - s * (p.y + self.camera.pose.ty)).round();
        if u < 0.0 || v < 0.0 || u >= self.camera.width as Real || v >= self.camera.height as Real {
            return Real::NEG_INFINITY;
        }
        Real::from(self.depth[v as usize * self.camera.width as usize + u as usize])
    }

    /// From `centre + r0·dir` outward, the last point of the face before its silhouette: a
    /// drop steeper than [`SILHOUETTE_SLOPE`] or the end of the surface. `None` when the walk
    /// starts off the surface or leaves the map without reaching the silhouette.
    fn silhouette(
        &self,
        centre: Vector2,
        dir: Vector2,
        r0: Real,
        r_max: Real,
    ) -> Option<(Real, Real)> {
        let mut r = r0;
        let mut z = self.depth_at(centre + r * dir);
        if !z.is_finite() {
            return None;
        }
        while r < r_max {
            let next = self.depth_at(centre + (r + self.cell) * dir);
            if !next.is_finite() || z - next > SILHOUETTE_SLOPE * self.cell {
                return Some((r, z));
            }
            r += self.cell;
            z = next;
        }
        None
    }
}

/// Places the jaw landmarks `wanted` (landmark, image point already carried onto the head's
/// proportions) on the head's frontal jaw silhouette. `map` holds the landmarks known so far
/// (hand labels and accepted suggestions: the face's axes, nose tip 31 and outer eye
/// corners 37/46 must be among them, else nothing is placed); `taken` vertices are never
/// used, nor is one vertex used twice, nor a vertex the head does not offer.
/// Landmarks that cannot be placed are absent from the result.
pub fn place_jaw(
    head: &SuggestHead,
    map: &LandmarkMap,
    pose: &OrthoPose,
    image_height: Real,
    wanted: &[(usize, Point2)],
    taken: &BTreeSet<usize>,
) -> Vec<JawPlacement> {
    let (vertices, eligible) = (head.vertices, head.eligible);
    let at = |l: usize| map.vertex(l).and_then(|v| vertices.get(v).copied());
    let (Some(frame), Some(nose), Some(eye_r), Some(eye_l)) =
        (HeadFrame::from_landmarks(map, vertices), at(30), at(36), at(45))
    else {
        return Vec::new();
    };
    let span = (eye_l - eye_r).norm();
    if !span.is_finite() || span <= 0.0 {
        return Vec::new();
    }
    let nose_local = frame.local(&nose);
    let Some(view) = FrontalView::new(vertices, head.triangles, frame, nose_local, span) else {
        return Vec::new();
    };
    // Image displacement per unit of the face's x and y: the frame's camera, linear.
    let at_image = |p: &Point3| pose.project(p, image_height);
    let o = at_image(&nose);
    let jac = Matrix2::from_columns(&[
        at_image(&(nose + frame.left())) - o,
        at_image(&(nose + frame.up())) - o,
    ]);
    let Some(to_face) = jac.try_inverse() else { return Vec::new() };
    let centre = nose_local.xy();
    let offsets: Vec<(usize, Vector2)> =
        wanted.iter().filter(|(l, _)| *l < 17).map(|&(l, p)| (l, to_face * (p - o))).collect();
    // Angle from straight down, positive towards the subject's left.
    let angle = |q: Vector2| q.x.atan2(-q.y);
    let angle_of = |l: usize| {
        offsets
            .iter()
            .find(|(k, _)| *k == l)
            .map(|(_, q)| angle(*q))
            .or_else(|| at(l).map(|p| angle(frame.local(&p).xy() - centre)))
    };
    // The ends' direction: where the silhouette reaches the eye corners' height.
    let eye_height = 0.5 * (frame.local(&eye_r).y + frame.local(&eye_l).y) - centre.y;
    let symmetric = |l: usize, own: Real| angle_of(16 - l).map_or(own, |m| 0.5 * (own - m));
    let end_tracked = offsets
        .iter()
        .find(|(l, _)| *l == 0 || *l == 16)
        .map(|&(l, q)| symmetric(l, angle(q)).abs());
    let end = end_angle(&view, centre, eye_height, span);
    let stretch = match (end, end_tracked) {
        (Some(e), Some(t)) if t > 0.0 => e / t,
        _ => 1.0,
    };
    let mut used = taken.clone();
    let mut placed = Vec::new();
    for &(l, q) in &offsets {
        let own = angle(q);
        let theta = stretch * symmetric(l, own);
        let dir = Vector2::new(theta.sin(), -theta.cos());
        let reach = q.norm();
        let Some((r, z)) = view.silhouette(centre, dir, 0.5 * reach, 2.0 * span) else {
            continue;
        };
        let local = centre + r * dir;
        let target = Point3::from(
            view.frame.axes.transpose()
                * Vector3::new(
                    local.x,
                    local.y,
                    z - BEHIND_SILHOUETTE * span * theta.sin().powi(2),
                ),
        );
        let vertex = (0..vertices.len())
            .filter(|&v| !used.contains(&v) && eligible.is_none_or(|e| e.get(v) == Some(&true)))
            .min_by(|&a, &b| {
                (vertices[a] - target)
                    .norm_squared()
                    .total_cmp(&(vertices[b] - target).norm_squared())
            });
        let Some(vertex) = vertex else { continue };
        used.insert(vertex);
        let asymmetry_px = pose.s * r * (own - theta).abs();
        placed.push(JawPlacement { landmark: l, vertex, asymmetry_px });
    }
    placed
}

/// The angle (from straight down, unsigned) of the direction from `centre` along which the
/// face's silhouette lies at `height` above it: the mean over the two sides of the first
/// silhouette point at or above that height, scanning from the chin upward. `None` when
/// neither side reaches it.
fn end_angle(view: &FrontalView, centre: Vector2, height: Real, span: Real) -> Option<Real> {
    let steps = 180;
    let mut ends = Vec::new();
    for side in [-1.0, 1.0] {
        let found = (1..steps).find_map(|k| {
            let theta = side * std::f64::consts::PI * k as Real / steps as Real;
            let dir = Vector2::new(theta.sin(), -theta.cos());
            let (r, _) = view.silhouette(centre, dir, 0.3 * span, 2.0 * span)?;
            (r * dir.y >= height).then_some(theta.abs())
        });
        ends.extend(found);
    }
    (!ends.is_empty()).then(|| ends.iter().sum::<Real>() / ends.len() as Real)
}
