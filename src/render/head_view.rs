//! The labelling view of a head: the mesh rendered shaded by the rasteriser, turned, framed
//! and zoomed as the head view says, and picking through its depth buffer: the point of the
//! surface under the cursor, then the labelable vertex nearest that point.
//!
//! Start with [`HeadShot::render`] and [`HeadShot::pick`]. View coordinates are "head
//! units": the framing sphere (centre, radius) turned by the view's rotation has radius 1,
//! y up; [`HeadViewport`] says which of them the image shows.

use super::camera::Camera;
use super::raster::{RenderError, RenderOptions, Rendered, render_mesh_with_depth};
use crate::fit::OrthoPose;
use crate::math::{Matrix3, Point2, Point3, Real};

/// Which part of the turned head an image shows.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HeadViewport {
    /// Model → view rotation.
    pub rotation: Matrix3,
    /// The framing sphere (model units).
    pub centre: Point3,
    pub radius: Real,
    /// Half the image's height in head units (1.05 at zoom 1: the sphere with a margin).
    pub half_height: Real,
    /// The head-unit point at the image's centre.
    pub look_at: (Real, Real),
}

impl HeadViewport {
    /// The camera that shows this viewport in a `width × height` px image (square pixels).
    pub fn camera(&self, width: u32, height: u32) -> Camera {
        let radius = self.radius.max(1e-12);
        let px_per_unit = 0.5 * Real::from(height.max(1)) / self.half_height.max(1e-12);
        let s = px_per_unit / radius;
        let c = self.rotation * self.centre.coords;
        let tx = 0.5 * Real::from(width) / s - (c.x + self.look_at.0 * radius);
        let ty = 0.5 * Real::from(height) / s - (c.y + self.look_at.1 * radius);
        Camera { pose: OrthoPose { r: self.rotation, s, tx, ty }, width, height }
    }
}

/// A rendered view of a head and what it needs to pick on it.
#[derive(Clone, Debug)]
pub struct HeadShot {
    pub rendered: Rendered,
    pub camera: Camera,
}

/// Skin colour of the labelling view: light, so the landmark markers stand out.
const SKIN: [u8; 3] = [214, 184, 160];

impl HeadShot {
    /// Renders `triangles` of `vertices` shaded through `viewport` into `width × height` px.
    ///
    /// # Errors
    /// As [`render_mesh_with_depth`].
    pub fn render(
        vertices: &[Point3],
        triangles: &[[u32; 3]],
        viewport: &HeadViewport,
        width: u32,
        height: u32,
    ) -> Result<Self, RenderError> {
        let camera = viewport.camera(width, height);
        let options = RenderOptions { background: [24, 24, 28], ..RenderOptions::default() };
        let rendered = render_mesh_with_depth(vertices, triangles, &[SKIN], &camera, &options)?;
        Ok(Self { rendered, camera })
    }

    /// Image position (px, continuous) of a head-unit point of the viewport.
    pub fn pixel_of(&self, viewport: &HeadViewport, head: (Real, Real)) -> Point2 {
        let s = self.camera.pose.s * viewport.radius;
        Point2::new(
            0.5 * Real::from(self.camera.width) + (head.0 - viewport.look_at.0) * s,
            0.5 * Real::from(self.camera.height) - (head.1 - viewport.look_at.1) * s,
        )
    }

    /// Whether vertex `p` is seen: at its pixel or one beside it, no surface lies in front of
    /// it by more than `tolerance` model units. The neighbours count because a vertex in a
    /// crease (a mouth corner, an eye corner) shares its pixel with the bulge beside it when
    /// a pixel spans millimetres.
    pub fn sees(&self, p: &Point3, tolerance: Real) -> bool {
        let (q, z) = self.camera.project_with_depth(p);
        let (w, h) = (i64::from(self.camera.width), i64::from(self.camera.height));
        let (x, y) = (q.x.round(), q.y.round());
        if !(x >= 0.0 && y >= 0.0 && x < w as Real && y < h as Real) {
            return false;
        }
        let (x, y) = (x as i64, y as i64);
        (-1..=1).flat_map(|dy| (-1..=1).map(move |dx| (x + dx, y + dy))).any(|(u, v)| {
            if u < 0 || v < 0 || u >= w || v >= h {
                return false;
            }
            let d = self.rendered.depth[(v * w + u) as usize];
            !d.is_finite() || z >= Real::from(d) - tolerance
        })
    }

    /// The vertex under image point `at` (px): where the surface covers `at`, the eligible
    /// vertex nearest (in 3D) the surface point there; elsewhere (a hole such as an eye
    /// socket, or just off the silhouette), the seen eligible vertex whose projection is
    /// nearest `at` within `reach_px`. `None` when nothing is within reach.
    pub fn pick(
        &self,
        vertices: &[Point3],
        eligible: Option<&[bool]>,
        at: Point2,
        reach_px: Real,
    ) -> Option<usize> {
        let ok = |v: usize| eligible.is_none_or(|e| e.get(v) == Some(&true));
        let (w, h) = (self.camera.width, self.camera.height);
        let (x, y) = (at.x.round(), at.y.round());
        let depth = (x >= 0.0 && y >= 0.0 && x < Real::from(w) && y < Real::from(h))
            .then(|| self.rendered.depth[y as usize * w as usize + x as usize])
            .filter(|d| d.is_finite());
        let pose = &self.camera.pose;
        if let Some(z) = depth {
            // The surface point in camera space, back to the model.
            let cam = crate::math::Vector3::new(
                at.x / pose.s - pose.tx,
                (Real::from(h) - at.y) / pose.s - pose.ty,
                Real::from(z),
            );
            let surface = Point3::from(pose.r.transpose() * cam);
            let reach_model = reach_px / pose.s;
            let nearest = vertices
                .iter()
                .enumerate()
                .filter(|(v, _)| ok(*v))
                .map(|(v, p)| (v, (p - surface).norm()))
                .min_by(|a, b| a.1.total_cmp(&b.1));
            if let Some((v, d)) = nearest
                && d <= reach_model
            {
                return Some(v);
            }
        }
        let tolerance = 2.0 / pose.s;
        vertices
            .iter()
            .enumerate()
            .filter(|(v, _)| ok(*v))
            .filter(|(_, p)| self.sees(p, tolerance))
            .map(|(v, p)| {
                let (q, z) = self.camera.project_with_depth(p);
                (v, (q - at).norm(), z)
            })
            .filter(|(_, d, _)| *d <= reach_px)
            // Of vertices that project alike, the nearer the viewer.
            .min_by(|a, b| a.1.total_cmp(&b.1).then(b.2.total_cmp(&a.2)))
            .map(|(v, _, _)| v)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A closed box (-1..1)³ of 12 triangles plus a vertex grid on its front face (z = 1).
    fn boxed() -> (Vec<Point3>, Vec<[u32; 3]>) {
        let mut v: Vec<Point3> = (0..8)
            .map(|i| {
                let c = |b: usize| if i & b != 0 { 1.0 } else { -1.0 };
                Point3::new(c(1), c(2), c(4))
            })
            .collect();
        let t = vec![
            [4, 5, 7],
            [4, 7, 6],
            [0, 2, 3],
            [0, 3, 1],
            [0, 1, 5],
            [0, 5, 4],
            [2, 6, 7],
            [2, 7, 3],
            [1, 3, 7],
            [1, 7, 5],
            [0, 4, 6],
            [0, 6, 2],
        ];
        for i in 0..5 {
            for j in 0..5 {
                v.push(Point3::new(-0.8 + 0.4 * i as Real, -0.8 + 0.4 * j as Real, 1.0));
            }
        }
        (v, t)
    }

    fn viewport(yaw: Real, zoom: Real) -> HeadViewport {
        HeadViewport {
            rotation: *nalgebra::Rotation3::from_axis_angle(
                &crate::math::Vector3::y_axis(),
                yaw.to_radians(),
            )
            .matrix(),
            centre: Point3::origin(),
            radius: 2.0,
            half_height: 1.05 / zoom,
            look_at: (0.0, 0.0),
        }
    }

    #[test]
    fn picks_the_front_vertex_under_the_cursor_and_not_the_back() {
        let (v, t) = boxed();
        let vp = viewport(0.0, 1.0);
        let shot = HeadShot::render(&v, &t, &vp, 120, 80).unwrap();
        // Head units: the grid point (0.4, 0.4) model is (0.2, 0.2) head units.
        let target = 8 + 3 * 5 + 3;
        assert!((v[target] - Point3::new(0.4, 0.4, 1.0)).norm() < 1e-12);
        let at = shot.pixel_of(&vp, (0.2, 0.2));
        assert_eq!(shot.pick(&v, None, at, 6.0), Some(target));
        // The box's back corners project onto the front ones; the front wins.
        let corner = shot.pixel_of(&vp, (0.48, 0.48));
        assert_eq!(shot.pick(&v, None, corner, 6.0), Some(7));
        assert!(!shot.sees(&Point3::new(0.4, 0.4, -1.0), 0.01), "the back is hidden");
        assert!(shot.sees(&v[target], 0.01));
        // Turned around, the back corner is in front.
        let back = viewport(180.0, 1.0);
        let shot = HeadShot::render(&v, &t, &back, 120, 80).unwrap();
        let at = shot.pixel_of(&back, (-0.48, 0.48));
        assert_eq!(shot.pick(&v, None, at, 6.0), Some(3));
    }

    #[test]
    fn zooming_in_separates_close_vertices_and_eligibility_is_kept() {
        let (v, t) = boxed();
        // Two grid points 0.2 head units apart: at zoom 8 the cursor between them, nearer
        // one, picks that one.
        let mut vp = viewport(0.0, 8.0);
        vp.look_at = (0.0, 0.0);
        let shot = HeadShot::render(&v, &t, &vp, 120, 80).unwrap();
        let centre = 8 + 2 * 5 + 2;
        let right = 8 + 3 * 5 + 2;
        assert_eq!(shot.pick(&v, None, shot.pixel_of(&vp, (0.04, 0.0)), 200.0), Some(centre));
        assert_eq!(shot.pick(&v, None, shot.pixel_of(&vp, (0.16, 0.0)), 200.0), Some(right));
        let mut eligible = vec![true; v.len()];
        eligible[centre] = false;
        let p = shot.pick(&v, Some(&eligible), shot.pixel_of(&vp, (0.04, 0.0)), 200.0);
        assert_ne!(p, Some(centre));
        // Off the head, nothing within reach.
        assert_eq!(shot.pick(&v, None, shot.pixel_of(&vp, (3.0, 3.0)), 4.0), None);
    }
}
