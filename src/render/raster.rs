//! The triangle rasteriser: z-buffered, per-vertex colours, Gouraud-interpolated two-sided
//! Lambert shading, into an `image::RgbImage`. Used by the demo, the TUI head view and the
//! side-view protrusion analysis, so it takes plain vertices and triangles, not a model.
//!
//! Pixel centres sit at integer coordinates: pixel (i, j) shows the scene at u = i, v = j in
//! the fitter's projection, so a projected landmark at (u, v) lands on pixel (round u, round v).

use super::camera::Camera;
use crate::math::{Point3, Real, Vector3};
use image::{Rgb, RgbImage};

/// How a mesh is lit and what lies behind it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RenderOptions {
    /// Colour of pixels no triangle covers.
    pub background: [u8; 3],
    /// Direction towards the light in camera space (x right, y up, z towards the viewer);
    /// need not be unit length.
    pub light: Vector3,
    /// Fraction of the colour kept on surfaces facing away from the light, in [0, 1].
    pub ambient: Real,
}

impl Default for RenderOptions {
    fn default() -> Self {
        Self { background: [236, 236, 232], light: Vector3::new(-0.3, 0.4, 1.0), ambient: 0.45 }
    }
}

/// Why a mesh could not be rendered.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum RenderError {
    #[error("{colours} colours for {vertices} vertices (need one per vertex, or exactly one)")]
    ColourCount { colours: usize, vertices: usize },
    #[error("triangle {triangle} refers to vertex {vertex}, but the mesh has {vertices}")]
    VertexOutOfRange { triangle: usize, vertex: u32, vertices: usize },
    #[error("image size {0}×{1} is empty")]
    EmptyImage(u32, u32),
}

/// A rendered image and its depth buffer (camera depth, larger = nearer; `-inf` where
/// nothing was drawn), row-major, `width × height`.
#[derive(Clone, Debug)]
pub struct Rendered {
    pub image: RgbImage,
    pub depth: Vec<f32>,
}

impl Rendered {
    /// Whether a triangle covers pixel (x, y).
    pub fn covered(&self, x: u32, y: u32) -> bool {
        let w = self.image.width();
        self.depth.get((y * w + x) as usize).is_some_and(|d| d.is_finite())
    }
}

/// Area-weighted vertex normals (unit length; zero for vertices in no triangle). Triangles
/// with out-of-range indices are ignored.
pub fn vertex_normals(vertices: &[Point3], triangles: &[[u32; 3]]) -> Vec<Vector3> {
    let mut normals = vec![Vector3::zeros(); vertices.len()];
    for t in triangles {
        let [a, b, c] = t.map(|i| i as usize);
        if a >= vertices.len() || b >= vertices.len() || c >= vertices.len() {
            continue;
        }
        // The cross product's length is twice the area: the weighting comes for free.
        let n = (vertices[b] - vertices[a]).cross(&(vertices[c] - vertices[a]));
        for i in [a, b, c] {
            normals[i] += n;
        }
    }
    for n in &mut normals {
        let len = n.norm();
        if len > 0.0 && len.is_finite() {
            *n /= len;
        } else {
            *n = Vector3::zeros();
        }
    }
    normals
}

/// Renders `triangles` over `vertices` (model space) seen by `camera` into a new image of the
/// camera's size.
///
/// `colours` holds one RGB per vertex, or a single colour for the whole mesh. Triangles are
/// drawn from both sides (shading uses |n·l|), so open sheets such as a face mask look solid.
///
/// # Errors
/// `ColourCount` when `colours` fits neither rule, `VertexOutOfRange` for a bad index,
/// `EmptyImage` for a zero-sized camera image.
///
/// ```
/// use lipmap::math::Point3;
/// use lipmap::render::{Camera, RenderOptions, View, render_mesh};
/// let v = [Point3::new(-1.0, -1.0, 0.0), Point3::new(1.0, -1.0, 0.0), Point3::new(0.0, 1.0, 0.0)];
/// let cam = Camera::fit_to_points(View::Front, 0.0, &v, 0.1, 64, 64).unwrap();
/// let img = render_mesh(&v, &[[0, 1, 2]], &[[200, 50, 50]], &cam, &RenderOptions::default()).unwrap();
/// assert_ne!(img.get_pixel(32, 40).0, RenderOptions::default().background);
/// ```
pub fn render_mesh(
    vertices: &[Point3],
    triangles: &[[u32; 3]],
    colours: &[[u8; 3]],
    camera: &Camera,
    options: &RenderOptions,
) -> Result<RgbImage, RenderError> {
    render_mesh_with_depth(vertices, triangles, colours, camera, options).map(|r| r.image)
}

/// As [`render_mesh`], also returning the depth buffer (for silhouettes and masks).
///
/// # Errors
/// As [`render_mesh`].
pub fn render_mesh_with_depth(
    vertices: &[Point3],
    triangles: &[[u32; 3]],
    colours: &[[u8; 3]],
    camera: &Camera,
    options: &RenderOptions,
) -> Result<Rendered, RenderError> {
    let (width, height) = (camera.width, camera.height);
    if width == 0 || height == 0 {
        return Err(RenderError::EmptyImage(width, height));
    }
    if colours.len() != vertices.len() && colours.len() != 1 {
        return Err(RenderError::ColourCount { colours: colours.len(), vertices: vertices.len() });
    }
    for (k, t) in triangles.iter().enumerate() {
        if let Some(&v) = t.iter().find(|&&i| i as usize >= vertices.len()) {
            return Err(RenderError::VertexOutOfRange {
                triangle: k,
                vertex: v,
                vertices: vertices.len(),
            });
        }
    }

    let normals = vertex_normals(vertices, triangles);
    let light = {
        let n = options.light.norm();
        if n > 0.0 && n.is_finite() { options.light / n } else { Vector3::z() }
    };
    let ambient = options.ambient.clamp(0.0, 1.0);
    let r = &camera.pose.r;
    // Per vertex: screen position, depth and shaded colour, computed once.
    let mut screen = Vec::with_capacity(vertices.len());
    let mut shaded = Vec::with_capacity(vertices.len());
    for (i, p) in vertices.iter().enumerate() {
        let (uv, d) = camera.project_with_depth(p);
        screen.push([uv.x as f32, uv.y as f32, d as f32]);
        let n_cam = r * normals[i];
        let lambert = n_cam.dot(&light).abs();
        let k = (ambient + (1.0 - ambient) * lambert) as f32;
        let c = if colours.len() == 1 { colours[0] } else { colours[i] };
        shaded.push([c[0] as f32 * k, c[1] as f32 * k, c[2] as f32 * k]);
    }

    let mut image = RgbImage::from_pixel(width, height, Rgb(options.background));
    let mut depth = vec![f32::NEG_INFINITY; (width * height) as usize];
    let (wf, hf) = ((width - 1) as f32, (height - 1) as f32);
    for t in triangles {
        let [a, b, c] = t.map(|i| i as usize);
        let (pa, pb, pc) = (screen[a], screen[b], screen[c]);
        if !(pa.iter().chain(&pb).chain(&pc)).all(|v| v.is_finite()) {
            continue;
        }
        // Signed doubled area; its sign depends on winding, which we ignore (two-sided).
        let area = (pb[0] - pa[0]) * (pc[1] - pa[1]) - (pb[1] - pa[1]) * (pc[0] - pa[0]);
        if area.abs() < 1e-12 {
            continue;
        }
        let x0 = pa[0].min(pb[0]).min(pc[0]).ceil().max(0.0);
        let x1 = pa[0].max(pb[0]).max(pc[0]).floor().min(wf);
        let y0 = pa[1].min(pb[1]).min(pc[1]).ceil().max(0.0);
        let y1 = pa[1].max(pb[1]).max(pc[1]).floor().min(hf);
        if x0 > x1 || y0 > y1 {
            continue;
        }
        let inv = 1.0 / area;
        let (ca, cb, cc) = (shaded[a], shaded[b], shaded[c]);
        for y in y0 as u32..=y1 as u32 {
            let py = y as f32;
            for x in x0 as u32..=x1 as u32 {
                let px = x as f32;
                // Barycentric weights from edge functions, normalised by the area.
                let wa = ((pb[0] - px) * (pc[1] - py) - (pb[1] - py) * (pc[0] - px)) * inv;
                let wb = ((pc[0] - px) * (pa[1] - py) - (pc[1] - py) * (pa[0] - px)) * inv;
                let wc = 1.0 - wa - wb;
                // A small tolerance closes hairline cracks between neighbouring triangles.
                const EPS: f32 = -1e-5;
                if wa < EPS || wb < EPS || wc < EPS {
                    continue;
                }
                let z = wa * pa[2] + wb * pb[2] + wc * pc[2];
                let k = (y * width + x) as usize;
                if z <= depth[k] {
                    continue;
                }
                depth[k] = z;
                let mix =
                    |ch: usize| (wa * ca[ch] + wb * cb[ch] + wc * cc[ch]).clamp(0.0, 255.0) as u8;
                image.put_pixel(x, y, Rgb([mix(0), mix(1), mix(2)]));
            }
        }
    }
    Ok(Rendered { image, depth })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::render::camera::View;

    fn quad(z: Real) -> Vec<Point3> {
        vec![
            Point3::new(-1.0, -1.0, z),
            Point3::new(1.0, -1.0, z),
            Point3::new(1.0, 1.0, z),
            Point3::new(-1.0, 1.0, z),
        ]
    }

    #[test]
    fn nearer_triangle_wins_whatever_the_draw_order() {
        let mut v = quad(0.0);
        v.extend(quad(1.0).into_iter().map(|p| Point3::new(p.x * 0.5, p.y * 0.5, p.z)));
        let tris = [[0, 1, 2], [0, 2, 3], [4, 5, 6], [4, 6, 7]];
        let mut colours = vec![[0, 0, 255]; 4];
        colours.extend([[255, 0, 0]; 4]);
        let cam = Camera::fit_to_points(View::Front, 0.0, &v, 0.1, 50, 50).unwrap();
        let opts = RenderOptions { ambient: 1.0, ..Default::default() };
        let a = render_mesh(&v, &tris, &colours, &cam, &opts).unwrap();
        let rev: Vec<[u32; 3]> = tris.iter().rev().copied().collect();
        let b = render_mesh(&v, &rev, &colours, &cam, &opts).unwrap();
        // Only the shared edge of coplanar triangles may differ (ties keep the first drawn).
        assert_eq!(b.get_pixel(25, 25).0, [255, 0, 0]);
        assert_eq!(a.get_pixel(25, 25).0, [255, 0, 0]);
        assert_eq!(a.get_pixel(8, 25).0, [0, 0, 255]);
        assert_eq!(a.get_pixel(0, 0).0, opts.background);
    }

    #[test]
    fn lambert_darkens_surfaces_turned_from_the_light() {
        let v = quad(0.0);
        let tris = [[0, 1, 2], [0, 2, 3]];
        let cam = Camera::fit_to_points(View::Front, 0.0, &v, 0.1, 40, 40).unwrap();
        let lit = RenderOptions { light: Vector3::z(), ambient: 0.2, ..Default::default() };
        let grazing = RenderOptions { light: Vector3::x(), ..lit };
        let a = render_mesh(&v, &tris, &[[200, 200, 200]], &cam, &lit).unwrap();
        let b = render_mesh(&v, &tris, &[[200, 200, 200]], &cam, &grazing).unwrap();
        assert_eq!(a.get_pixel(20, 20).0, [200, 200, 200]);
        assert_eq!(b.get_pixel(20, 20).0, [40, 40, 40]);
    }

    #[test]
    fn bad_input_is_an_error_not_a_panic() {
        let v = quad(0.0);
        let cam = Camera::fit_to_points(View::Front, 0.0, &v, 0.1, 10, 10).unwrap();
        let o = RenderOptions::default();
        assert!(matches!(
            render_mesh(&v, &[[0, 1, 9]], &[[1, 1, 1]], &cam, &o),
            Err(RenderError::VertexOutOfRange { vertex: 9, .. })
        ));
        assert!(matches!(
            render_mesh(&v, &[[0, 1, 2]], &[[1, 1, 1], [2, 2, 2]], &cam, &o),
            Err(RenderError::ColourCount { .. })
        ));
    }
}
