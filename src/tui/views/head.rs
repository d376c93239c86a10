//! Head view: the head mesh as a braille wireframe, rotatable, with the landmark map's
//! vertices, the 2D labelling cursor and the vertex it picks (the 3D cursor).
//!
//! Projection: R = Ry(yaw)·Rx(pitch) about the mesh's bounding-box centre, orthographic
//! along −z, scaled so the bounding sphere has radius 1 ("head units"; y up on screen).

use crate::landmarks::landmark_name;
use crate::math::{Matrix3, Point3, Vector3};
use crate::model::Mesh;
use crate::tui::app::{App, HeadView};
use ratatui::Frame;
use ratatui::layout::Rect;
use ratatui::style::{Color, Stylize};
use ratatui::symbols::Marker;
use ratatui::text::Line;
use ratatui::widgets::canvas::{Canvas, Line as CLine, Points};
use ratatui::widgets::{Block, Borders, Paragraph};

/// Pick radius around the cursor, in head units at zoom 1.
const PICK_RADIUS: f64 = 0.06;
/// Vertices this far (head units) behind the frontmost candidate count as hidden.
const DEPTH_TOLERANCE: f64 = 0.08;

/// Rotation matrix for yaw (about y) then pitch (about x), degrees.
pub fn rotation(yaw_deg: f64, pitch_deg: f64) -> Matrix3 {
    let ry = nalgebra::Rotation3::from_axis_angle(&Vector3::y_axis(), yaw_deg.to_radians());
    let rx = nalgebra::Rotation3::from_axis_angle(&Vector3::x_axis(), pitch_deg.to_radians());
    (ry * rx).into_inner()
}

/// Projects every vertex to (x, y, depth) in head units; depth grows towards the viewer.
pub fn project(mesh: &Mesh, rot: &Matrix3) -> Vec<(f64, f64, f64)> {
    if mesh.vertices.is_empty() {
        return Vec::new();
    }
    let (mut lo, mut hi) = (mesh.vertices[0].coords, mesh.vertices[0].coords);
    for v in &mesh.vertices {
        lo = lo.inf(&v.coords);
        hi = hi.sup(&v.coords);
    }
    let c = Point3::from((lo + hi) / 2.0);
    let r = ((hi - lo).norm() / 2.0).max(1e-12);
    mesh.vertices
        .iter()
        .map(|v| {
            let p = rot * (v - c) / r;
            (p.x, p.y, p.z)
        })
        .collect()
}

/// The vertex under the 2D cursor: among vertices within the pick radius, those near the
/// frontmost depth are visible; of these the nearest to the cursor. `None` when none is near.
pub fn pick_vertex(mesh: &Mesh, view: &HeadView) -> Option<usize> {
    let pts = project(mesh, &rotation(view.yaw, view.pitch));
    let (cx, cy) = (view.cursor.0, -view.cursor.1);
    let radius = PICK_RADIUS / view.zoom;
    let near: Vec<(usize, f64, f64)> = pts
        .iter()
        .enumerate()
        .map(|(i, p)| (i, (p.0 - cx).hypot(p.1 - cy), p.2))
        .filter(|c| c.1 <= radius)
        .collect();
    let front = near.iter().map(|c| c.2).fold(f64::NEG_INFINITY, f64::max);
    near.into_iter()
        .filter(|c| c.2 >= front - DEPTH_TOLERANCE)
        .min_by(|a, b| a.1.total_cmp(&b.1))
        .map(|c| c.0)
}

/// Draws a wireframe of `mesh` rotated by `rot` into `area` with extra point layers.
pub fn draw_wireframe(
    frame: &mut Frame,
    area: Rect,
    mesh: &Mesh,
    edges: &[[u32; 2]],
    rot: &Matrix3,
    zoom: f64,
    overlay: impl Fn(&mut ratatui::widgets::canvas::Context, &[(f64, f64, f64)]),
) {
    if area.width == 0 || area.height == 0 {
        return;
    }
    let pts = project(mesh, rot);
    // Braille dots are about square: 2×4 per cell of aspect 1:2.
    let aspect = f64::from(area.width) / (2.0 * f64::from(area.height));
    let (hy, hx) = (1.05 / zoom, 1.05 / zoom * aspect);
    let canvas = Canvas::default()
        .marker(Marker::Braille)
        .x_bounds([-hx, hx])
        .y_bounds([-hy, hy])
        .paint(|ctx| {
            for e in edges {
                let (Some(a), Some(b)) = (pts.get(e[0] as usize), pts.get(e[1] as usize)) else {
                    continue;
                };
                // Back-facing edges are dimmed by drawing only the front half in depth.
                let colour = if a.2 + b.2 < 0.0 { Color::DarkGray } else { Color::Gray };
                ctx.draw(&CLine { x1: a.0, y1: a.1, x2: b.0, y2: b.1, color: colour });
            }
            ctx.layer();
            overlay(ctx, &pts);
        });
    frame.render_widget(canvas, area);
}

pub fn draw(app: &App, frame: &mut Frame, area: Rect) {
    let side_w = if area.width >= 50 { 26.min(area.width / 3) } else { 0 };
    let canvas_area = Rect::new(area.x, area.y, area.width - side_w, area.height);
    let side = Rect::new(area.x + canvas_area.width, area.y, side_w, area.height);
    let h = &app.head;
    let picked = app.mesh.as_ref().and_then(|m| pick_vertex(m, h));
    match &app.mesh {
        Some(mesh) => {
            let map = app.map.clone().unwrap_or_default();
            let label = h.label;
            let cursor = (h.cursor.0, -h.cursor.1);
            let zoom = h.zoom;
            draw_wireframe(
                frame,
                canvas_area,
                mesh,
                &app.mesh_edges,
                &rotation(h.yaw, h.pitch),
                h.zoom,
                |ctx, pts| {
                    let mapped: Vec<(f64, f64)> = map
                        .to_vertex
                        .iter()
                        .filter(|(l, _)| **l != label)
                        .filter_map(|(_, v)| pts.get(*v).filter(|p| p.2 > -0.2).map(|p| (p.0, p.1)))
                        .collect();
                    ctx.draw(&Points { coords: &mapped, color: Color::LightGreen });
                    if let Some(p) = map.vertex(label).and_then(|v| pts.get(v)) {
                        ctx.draw(&Points { coords: &[(p.0, p.1)], color: Color::Yellow });
                    }
                    if let Some(p) = picked.and_then(|v| pts.get(v)) {
                        ctx.draw(&Points { coords: &[(p.0, p.1)], color: Color::LightRed });
                    }
                    let d = 0.04 / zoom;
                    let (x, y) = cursor;
                    ctx.draw(&CLine {
                        x1: x - d,
                        y1: y,
                        x2: x + d,
                        y2: y,
                        color: Color::LightMagenta,
                    });
                    ctx.draw(&CLine {
                        x1: x,
                        y1: y - d,
                        x2: x,
                        y2: y + d,
                        color: Color::LightMagenta,
                    });
                },
            );
        }
        None => frame.render_widget(
            Paragraph::new("No head mesh in this session (lipmap import --mesh …).")
                .fg(Color::Gray),
            canvas_area,
        ),
    }
    if side.width == 0 {
        return;
    }
    let mapped = app.map.as_ref().map_or(0, |m| m.len());
    let current = app.map.as_ref().and_then(|m| m.vertex(h.label));
    let mut lines = vec![
        Line::from("labelling").bold(),
        Line::from(format!("{} {}", h.label, landmark_name(h.label))).fg(Color::Yellow),
        Line::from(match current {
            Some(v) => format!("now vertex {v}"),
            None => "not mapped".into(),
        }),
        Line::from(match picked {
            Some(v) => format!("cursor on vertex {v}"),
            None => "cursor on no vertex".into(),
        })
        .fg(Color::LightRed),
        Line::from(""),
        Line::from(format!("{mapped}/68 landmarks mapped")),
        Line::from(format!("yaw {:.0}° pitch {:.0}°", h.yaw, h.pitch)),
        Line::from(format!("zoom {:.1}×", h.zoom)),
    ];
    if let Some(m) = &app.mesh {
        lines.push(Line::from(format!("{} vertices", m.vertices.len())).fg(Color::DarkGray));
    }
    frame.render_widget(
        Paragraph::new(lines)
            .block(Block::new().borders(Borders::LEFT).border_style(Color::DarkGray)),
        side,
    );
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn picks_the_front_vertex_under_the_cursor() {
        // Two vertices at the same x, y: one in front (z = +1), one behind (z = −1),
        // and a far one to set the bounding box.
        let mesh = Mesh {
            vertices: vec![
                Point3::new(0.0, 0.0, 1.0),
                Point3::new(0.0, 0.0, -1.0),
                Point3::new(1.0, 1.0, 0.0),
                Point3::new(-1.0, -1.0, 0.0),
            ],
            faces: vec![],
        };
        let view = HeadView::default();
        assert_eq!(pick_vertex(&mesh, &view), Some(0));
        // Turned around, the other one is in front.
        let back = HeadView { yaw: 180.0, ..view };
        assert_eq!(pick_vertex(&mesh, &back), Some(1));
        let away = HeadView { cursor: (0.3, 0.0), ..view };
        assert_eq!(pick_vertex(&mesh, &away), None);
    }
}
