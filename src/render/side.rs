//! Side (profile) renders of a fitted head for measuring its lip protrusion the way a side
//! video is measured: one fixed virtual camera per clip, with a user-set pitch.
//!
//! The published method rendered the animated head from the side and measured P on the
//! render as on the video, tuning the virtual camera's pitch by eye until the head's profile
//! sat like the speaker's. [`SideRenderer::new`] fixes the camera on a clip's first shape
//! (so every frame is seen from the same place and a profile setup made on the first render
//! stays valid), [`SideRenderer::render`] draws a shape: a plain skin tone on a dark
//! background, so only the silhouette carries information, mirrored when the face should
//! look left.

use super::camera::{Camera, View};
use super::raster::{RenderError, RenderOptions, render_mesh};
use crate::math::{Point2, Point3, Real, Vector3};
use crate::measure::profile::{Facing, NoseLength, ProfileSetup, Rect, ReferenceLine};
use crate::model::LandmarkMap;
use image::RgbImage;

/// Background of side renders: dark and plain, as the demo's side video.
pub const SIDE_RENDER_BACKGROUND: [u8; 3] = [22, 26, 34];
/// The one colour of a side-rendered head (a mid skin tone).
pub const SIDE_RENDER_SKIN: [u8; 3] = [224, 176, 146];

/// A fixed side camera for rendering one clip's shapes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SideRenderer {
    pub camera: Camera,
    pub facing: Facing,
    pub pitch_deg: Real,
    pub options: RenderOptions,
}

impl SideRenderer {
    /// A camera looking at the head's right cheek, nodded by `pitch_deg` (about model x, as
    /// [`Camera::looking_at`]), fitting `first` (a model-space shape) into a `width`×`height`
    /// image with 5 % margins. `None` for an empty or degenerate shape or image.
    pub fn new(
        first: &[Point3],
        pitch_deg: Real,
        facing: Facing,
        width: u32,
        height: u32,
    ) -> Option<Self> {
        if !pitch_deg.is_finite() {
            return None;
        }
        let camera = Camera::fit_to_points(View::Side, pitch_deg, first, 0.05, width, height)?;
        let options = RenderOptions {
            background: SIDE_RENDER_BACKGROUND,
            light: Vector3::new(0.2, 0.3, 1.0),
            ambient: 0.6,
        };
        Some(Self { camera, facing, pitch_deg, options })
    }

    /// Renders `vertices` (model space) over `triangles` from the side; the image is mirrored
    /// for [`Facing::Left`] so the face looks the way the clip's side video does.
    ///
    /// # Errors
    /// As [`render_mesh`] (bad triangle indices, empty image).
    pub fn render(
        &self,
        vertices: &[Point3],
        triangles: &[[u32; 3]],
    ) -> Result<RgbImage, RenderError> {
        let img =
            render_mesh(vertices, triangles, &[SIDE_RENDER_SKIN], &self.camera, &self.options)?;
        Ok(match self.facing {
            Facing::Right => img,
            Facing::Left => image::imageops::flip_horizontal(&img),
        })
    }
}

impl SideRenderer {
    /// Image position of a model-space point in this renderer's (possibly mirrored) image.
    pub fn project(&self, p: &Point3) -> Point2 {
        let q = self.camera.project(p);
        match self.facing {
            Facing::Right => q,
            Facing::Left => Point2::new(self.camera.width as Real - 1.0 - q.x, q.y),
        }
    }

    /// The side-view profile setup of `shape`'s render, read off its geometry rather than
    /// the image: nose root and tip at the projected nasion (27) and nose tip (30) vertices,
    /// the reference line vertical through the projected subnasale (33), and the mouth crop
    /// laid out from them as [`crate::measure::profile::propose_setup`] lays out a video's
    /// (from halfway between tip and subnasale to 0.9 nose lengths below the subnasale; from
    /// half a nose length behind the subnasale to a quarter beyond the foremost of nose tip
    /// and upper lip). Unlike a search on the image this holds at any pitch, even when a
    /// cut-off forehead or the chin stands further forward than the nose. No anchor: the
    /// shapes are in model space, so the head does not move between renders. `None` when
    /// those landmarks are unmapped or the layout leaves the image.
    pub fn profile_setup(&self, shape: &[Point3], map: &LandmarkMap) -> Option<ProfileSetup> {
        use crate::landmarks::ibug::point::{NASION, NOSE_TIP, SUBNASALE};
        let at = |l: usize| shape.get(map.vertex(l)?).map(|p| self.project(p));
        let (root, tip, sn) = (at(NASION)?, at(NOSE_TIP)?, at(SUBNASALE)?);
        let len = (tip - root).norm();
        if !(len.is_finite() && len > 1.0) {
            return None;
        }
        let (w, h) = (self.camera.width as Real, self.camera.height as Real);
        let s = self.facing.sign();
        // Forward coordinate: px counted in the direction the face looks.
        let forward = |x: Real| if s > 0.0 { x } else { w - 1.0 - x };
        let lip_front = crate::measure::mesh::UPPER_LIP_LANDMARKS
            .iter()
            .filter_map(|&l| at(l))
            .map(|p| forward(p.x))
            .fold(forward(tip.x), Real::max);
        let top = 0.5 * (tip.y + sn.y);
        let bottom = (sn.y + 0.9 * len).min(h);
        let (u0, u1) =
            ((forward(sn.x) - 0.5 * len).max(0.0), (lip_front + 0.25 * len).min(w - 1.0));
        if !(bottom > top + 2.0 && u1 > u0 + 2.0 && top >= 0.0) {
            return None;
        }
        let (u0, u1) = (u0.floor() as u32, u1.ceil() as u32);
        let x = if s > 0.0 { u0 } else { self.camera.width - 1 - u1 };
        let (r0, r1) = (top.round() as u32, bottom.round() as u32);
        let crop = Rect::new(x, r0, u1 - u0 + 1, r1 - r0);
        let mut setup = ProfileSetup::new(crop, ReferenceLine::vertical(sn.x), self.facing);
        setup.nose = NoseLength::Points { root, tip };
        Some(setup)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A wedge "nose" pointing along +z.
    fn wedge() -> (Vec<Point3>, Vec<[u32; 3]>) {
        let v = vec![
            Point3::new(-10.0, -20.0, 0.0),
            Point3::new(10.0, -20.0, 0.0),
            Point3::new(10.0, 20.0, 0.0),
            Point3::new(-10.0, 20.0, 0.0),
            Point3::new(0.0, 0.0, 30.0),
        ];
        (v, vec![[0, 1, 4], [1, 2, 4], [2, 3, 4], [3, 0, 4]])
    }

    fn foremost_column(img: &RgbImage, facing: Facing) -> u32 {
        let cols: Vec<u32> = (0..img.width())
            .filter(|&x| (0..img.height()).any(|y| img.get_pixel(x, y).0 != SIDE_RENDER_BACKGROUND))
            .collect();
        match facing {
            Facing::Right => *cols.last().unwrap(),
            Facing::Left => *cols.first().unwrap(),
        }
    }

    #[test]
    fn the_tip_points_the_way_the_face_looks() {
        let (v, t) = wedge();
        let right = SideRenderer::new(&v, 0.0, Facing::Right, 120, 100).unwrap();
        let left = SideRenderer { facing: Facing::Left, ..right };
        let (a, b) = (right.render(&v, &t).unwrap(), left.render(&v, &t).unwrap());
        assert!(foremost_column(&a, Facing::Right) > 90);
        assert!(foremost_column(&b, Facing::Left) < 30);
        assert_eq!(foremost_column(&a, Facing::Right), 119 - foremost_column(&b, Facing::Left));
    }

    #[test]
    fn pitch_moves_the_tip_and_bad_input_is_refused() {
        let (v, t) = wedge();
        let level = SideRenderer::new(&v, 0.0, Facing::Right, 120, 100).unwrap();
        let nod = SideRenderer::new(&v, 20.0, Facing::Right, 120, 100).unwrap();
        let tip = |r: &SideRenderer| r.camera.project(&v[4]);
        assert!((tip(&level).y - tip(&nod).y).abs() > 3.0);
        assert!(nod.render(&v, &t).is_ok());
        assert!(SideRenderer::new(&[], 0.0, Facing::Right, 10, 10).is_none());
        assert!(SideRenderer::new(&v, Real::NAN, Facing::Right, 10, 10).is_none());
        assert!(level.render(&v, &[[0, 1, 9]]).is_err());
    }
}
