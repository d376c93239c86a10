//! lipmap's software renderer: a z-buffered triangle rasteriser with per-vertex colours and
//! Lambert shading, and the virtual orthographic camera (front and side views) it draws with.
//!
//! Start with [`render_mesh`] and [`Camera::looking_at`] / [`Camera::fit_to_points`]. The
//! projection is the fitter's (`u = s·(r1·X + tx)`, `v = H − s·(r2·X + ty)`), so landmarks
//! projected with [`Camera::project`] fall on the rendered vertices.

pub mod camera;
pub mod head_view;
pub mod raster;
pub mod side;

pub use camera::{Camera, View, project_points};
pub use head_view::{HeadShot, HeadViewport};
pub use raster::{
    RenderError, RenderOptions, Rendered, render_mesh, render_mesh_with_depth, vertex_normals,
};
pub use side::SideRenderer;
