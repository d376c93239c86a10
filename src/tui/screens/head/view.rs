//! Head view: the head mesh shaded in half-blocks (or as a braille wireframe, `W`),
//! rotatable and zoomable, with the landmark map's vertices, the 2D labelling cursor and the
//! vertex it picks through the depth buffer (the 3D cursor); or, cycled to with `CycleHead`,
//! a transferred head at the current frame, front and side (`draw_transferred`).
//!
//! Projection: R = Ry(yaw)·Rx(pitch) about the framing sphere's centre (the face),
//! orthographic along −z, scaled so the sphere has radius 1 ("head units"; y up on screen).
//! The drawing is in functions ([`draw_shaded_mesh`], [`draw_wireframe`]) that take the
//! mesh and the viewport, so another head (a transferred one) draws the same way.

use crate::math::{Matrix3, Vector3};
use crate::model::Mesh;
use crate::render::{HeadShot, HeadViewport};
use crate::tui::app::App;
use crate::tui::screens::head::{HeadFraming, HeadSetup, HeadView};
use ratatui::Frame;
use ratatui::layout::Rect;
use ratatui::style::{Color, Stylize};
use ratatui::symbols::Marker;
use ratatui::text::Line;
use ratatui::widgets::canvas::{Canvas, Line as CLine, Points};
use ratatui::widgets::{Block, Borders, Paragraph};

/// Pick radius around the cursor, in head units at zoom 1.
const PICK_RADIUS: f64 = 0.15;
/// A vertex this far (head units) behind the depth buffer is hidden.
const DEPTH_TOLERANCE: f64 = 0.03;
/// Depth buffer resolution over the head's bounding square.
const ZBUF: usize = 192;
const ZBUF_EXTENT: f64 = 1.05;

/// Rotation matrix for yaw (about y) then pitch (about x), degrees.
pub fn rotation(yaw_deg: f64, pitch_deg: f64) -> Matrix3 {
    let ry = nalgebra::Rotation3::from_axis_angle(&Vector3::y_axis(), yaw_deg.to_radians());
    let rx = nalgebra::Rotation3::from_axis_angle(&Vector3::x_axis(), pitch_deg.to_radians());
    (ry * rx).into_inner()
}

/// The view's whole rotation: the framing's (the face turned upright towards the viewer,
/// whichever way the mesh stands), then the user's yaw and pitch.
pub fn view_rotation(view: &HeadView, framing: &HeadFraming) -> Matrix3 {
    rotation(view.yaw, view.pitch) * framing.rotation
}

/// Projects every vertex to (x, y, depth) in head units (the framing sphere has radius 1);
/// depth grows towards the viewer.
pub fn project(mesh: &Mesh, rot: &Matrix3, framing: &HeadFraming) -> Vec<(f64, f64, f64)> {
    let (c, r) = (framing.centre, framing.radius.max(1e-12));
    mesh.vertices
        .iter()
        .map(|v| {
            let p = rot * (v - c) / r;
            (p.x, p.y, p.z)
        })
        .collect()
}

fn zcell(v: f64) -> usize {
    (((v + ZBUF_EXTENT) / (2.0 * ZBUF_EXTENT) * ZBUF as f64).floor().max(0.0) as usize)
        .min(ZBUF - 1)
}

/// Which projected vertices are visible: a coarse depth buffer of the faces (fan-triangulated),
/// then a vertex is visible when nothing covers it from closer. Without faces all are visible.
pub fn visible_vertices(mesh: &Mesh, pts: &[(f64, f64, f64)]) -> Vec<bool> {
    let mut zbuf = vec![f64::NEG_INFINITY; ZBUF * ZBUF];
    let centre = |c: usize| (c as f64 + 0.5) / ZBUF as f64 * 2.0 * ZBUF_EXTENT - ZBUF_EXTENT;
    for f in &mesh.faces {
        for k in 1..f.len().saturating_sub(1) {
            let tri = [f[0], f[k], f[k + 1]].map(|i| pts.get(i as usize).copied());
            let [Some(a), Some(b), Some(c)] = tri else { continue };
            let det = (b.1 - c.1) * (a.0 - c.0) + (c.0 - b.0) * (a.1 - c.1);
            if det.abs() < 1e-12 {
                continue;
            }
            let (x0, x1) = (zcell(a.0.min(b.0).min(c.0)), zcell(a.0.max(b.0).max(c.0)));
            let (y0, y1) = (zcell(a.1.min(b.1).min(c.1)), zcell(a.1.max(b.1).max(c.1)));
            for cy in y0..=y1 {
                let y = centre(cy);
                for cx in x0..=x1 {
                    let x = centre(cx);
                    let l1 = ((b.1 - c.1) * (x - c.0) + (c.0 - b.0) * (y - c.1)) / det;
                    let l2 = ((c.1 - a.1) * (x - c.0) + (a.0 - c.0) * (y - c.1)) / det;
                    let l3 = 1.0 - l1 - l2;
                    if l1 >= -1e-9 && l2 >= -1e-9 && l3 >= -1e-9 {
                        let z = l1 * a.2 + l2 * b.2 + l3 * c.2;
                        let cell = &mut zbuf[cy * ZBUF + cx];
                        *cell = cell.max(z);
                    }
                }
            }
        }
    }
    pts.iter()
        .map(|p| {
            let front = zbuf[zcell(p.1) * ZBUF + zcell(p.0)];
            !front.is_finite() || p.2 >= front - DEPTH_TOLERANCE
        })
        .collect()
}

/// The triangles a head is drawn and picked with: its faces fan-triangulated, without those
/// touching a vertex that is not `eligible` (a figure's helper and joint geometry).
pub fn label_triangles(mesh: &Mesh, eligible: Option<&[bool]>) -> Vec<[u32; 3]> {
    crate::fit::suggest::surface_triangles(&mesh.triangles(), eligible)
}

/// The viewport of the head view: its turn and framing, `half_height` head units above and
/// below `look_at`.
pub fn viewport(
    view: &HeadView,
    framing: &HeadFraming,
    half_height: f64,
    look_at: (f64, f64),
) -> HeadViewport {
    HeadViewport {
        rotation: view_rotation(view, framing),
        centre: framing.centre,
        radius: framing.radius,
        half_height,
        look_at,
    }
}

/// Side of the square image picking renders around the cursor, px.
const PICK_PX: u32 = 400;

/// The 3D cursor: the vertex of the surface under the 2D cursor (through a depth buffer of
/// `triangles`, the surface as drawn, rendered around the cursor, finer the more the view is
/// zoomed), or off the surface the visible vertex nearest it within the pick radius. Only
/// `eligible` vertices (when given) can be picked: under an eye's surface, the eyelid's
/// vertex nearest the point the cursor is on, not the socket behind the eye. `None` when no
/// vertex is near.
pub fn pick_vertex(
    mesh: &Mesh,
    triangles: &[[u32; 3]],
    framing: &HeadFraming,
    view: &HeadView,
    eligible: Option<&[bool]>,
) -> Option<usize> {
    let cursor = (view.cursor.0, -view.cursor.1);
    let radius = PICK_RADIUS / view.zoom;
    let vp = viewport(view, framing, 2.0 * radius, cursor);
    let shot = HeadShot::render(&mesh.vertices, triangles, &vp, PICK_PX, PICK_PX).ok()?;
    let reach_px = f64::from(PICK_PX) / 4.0;
    shot.pick(&mesh.vertices, eligible, shot.pixel_of(&vp, cursor), reach_px)
}

/// Fraction of the braille dots the wireframe may light before edges are thinned.
const INK_BUDGET: f64 = 0.3;

/// Every how many front edges to draw so a dense mesh lights about `INK_BUDGET` of the
/// dots instead of filling the silhouette (1 = all; zooming in brings every edge back).
fn edge_stride(
    front: &[&[u32; 2]],
    pts: &[(f64, f64, f64)],
    area: Rect,
    half_height: f64,
) -> usize {
    if front.is_empty() {
        return 1;
    }
    let dots_per_unit = 4.0 * f64::from(area.height) / (2.0 * half_height);
    let ink: f64 = front
        .iter()
        .filter_map(|e| Some((pts.get(e[0] as usize)?, pts.get(e[1] as usize)?)))
        .map(|(a, b)| ((a.0 - b.0).hypot(a.1 - b.1) * dots_per_unit).max(1.0))
        .sum();
    let budget = INK_BUDGET * 8.0 * f64::from(area.width) * f64::from(area.height);
    ((ink / budget.max(1.0)).ceil() as usize).max(1)
}

/// How a wireframe is seen: the framing sphere, the zoom, and the point (head units) at the
/// centre of the area.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WireView {
    pub framing: HeadFraming,
    pub zoom: f64,
    pub centre: (f64, f64),
}

impl WireView {
    /// The whole framing sphere, unzoomed.
    pub fn framed(framing: HeadFraming) -> Self {
        Self { framing, zoom: 1.0, centre: (0.0, 0.0) }
    }
}

/// Draws a wireframe of `mesh` rotated by `rot` into `area` with extra point layers.
pub fn draw_wireframe(
    frame: &mut Frame,
    area: Rect,
    mesh: &Mesh,
    edges: &[[u32; 2]],
    rot: &Matrix3,
    view: &WireView,
    overlay: impl Fn(&mut ratatui::widgets::canvas::Context, &[(f64, f64, f64)], &[bool]),
) {
    if area.width == 0 || area.height == 0 {
        return;
    }
    let zoom = view.zoom;
    let (cx, cy) = view.centre;
    let pts = project(mesh, rot, &view.framing);
    let visible = visible_vertices(mesh, &pts);
    // Braille dots are about square: 2×4 per cell of aspect 1:2.
    let aspect = f64::from(area.width) / (2.0 * f64::from(area.height));
    let (hy, hx) = (1.05 / zoom, 1.05 / zoom * aspect);
    // Only edges on screen count towards the ink budget: a full figure framed on its face
    // must not thin the face's edges for a body that is off screen.
    let on_screen = |p: &(f64, f64, f64)| (p.0 - cx).abs() <= hx && (p.1 - cy).abs() <= hy;
    let front: Vec<&[u32; 2]> = edges
        .iter()
        .filter(|e| visible[e[0] as usize] && visible[e[1] as usize])
        .filter(|e| on_screen(&pts[e[0] as usize]) || on_screen(&pts[e[1] as usize]))
        .collect();
    let stride = edge_stride(&front, &pts, area, hy);
    let canvas = Canvas::default()
        .marker(Marker::Braille)
        .x_bounds([cx - hx, cx + hx])
        .y_bounds([cy - hy, cy + hy])
        .paint(|ctx| {
            // Hidden-line removal by vertex visibility, and thinning, keep a dense mesh
            // readable.
            for e in front.iter().step_by(stride) {
                let (Some(a), Some(b)) = (pts.get(e[0] as usize), pts.get(e[1] as usize)) else {
                    continue;
                };
                ctx.draw(&CLine { x1: a.0, y1: a.1, x2: b.0, y2: b.1, color: Color::Gray });
            }
            ctx.layer();
            overlay(ctx, &pts, &visible);
        });
    frame.render_widget(canvas, area);
}

/// The head view's camera: zoomed in, it follows the cursor so the cursor stays on screen.
pub fn head_wire_view(app: &App) -> WireView {
    let h = &app.head.view;
    let centre = if h.zoom > 1.0 { (h.cursor.0, -h.cursor.1) } else { (0.0, 0.0) };
    WireView { framing: app.head.framing, zoom: h.zoom, centre }
}

/// What a shaded head view draws over the head: markers on vertices (vertex, symbol,
/// colour), and the cursor (head units) if any.
pub struct Overlay {
    pub vertices: Vec<(usize, &'static str, Color)>,
    pub cursor: Option<(f64, f64)>,
}

/// Draws `mesh` shaded in half-blocks into `area` as the head view sees it, with the
/// overlay's markers on the visible vertices and the cursor on top.
fn draw_shaded(app: &App, frame: &mut Frame, area: Rect, mesh: &Mesh, picked: Option<usize>) {
    let h = &app.head.view;
    let map = app.map.clone().unwrap_or_default();
    let mut vertices: Vec<(usize, &'static str, Color)> = map
        .pairs()
        .filter(|(l, _)| *l != h.label)
        .map(|(_, v)| (v, "•", Color::LightGreen))
        .collect();
    vertices.extend(map.vertex(h.label).map(|v| (v, "◆", Color::Yellow)));
    vertices.extend(picked.map(|v| (v, "◆", Color::LightRed)));
    let overlay = Overlay { vertices, cursor: Some((h.cursor.0, -h.cursor.1)) };
    let vp = viewport(h, &app.head.framing, 1.05 / h.zoom, head_wire_view(app).centre);
    draw_shaded_mesh(frame, area, mesh, &app.head.triangles, &vp, &overlay);
}

/// The shaded drawing itself: one image pixel per half cell, markers as cell symbols.
pub fn draw_shaded_mesh(
    frame: &mut Frame,
    area: Rect,
    mesh: &Mesh,
    triangles: &[[u32; 3]],
    vp: &HeadViewport,
    overlay: &Overlay,
) {
    if area.width == 0 || area.height == 0 {
        return;
    }
    let (w, hpx) = (u32::from(area.width), 2 * u32::from(area.height));
    let Ok(shot) = HeadShot::render(&mesh.vertices, triangles, vp, w, hpx) else { return };
    let buf = frame.buffer_mut();
    let rgb = |x: u32, y: u32| {
        let p = shot.rendered.image.get_pixel(x, y).0;
        Color::Rgb(p[0], p[1], p[2])
    };
    for row in 0..area.height {
        for col in 0..area.width {
            let (x, y) = (u32::from(col), 2 * u32::from(row));
            if let Some(cell) = buf.cell_mut((area.x + col, area.y + row)) {
                cell.set_symbol("▀").set_fg(rgb(x, y)).set_bg(rgb(x, y + 1));
            }
        }
    }
    let mut mark = |p: crate::math::Point2, symbol: &str, colour: Color| {
        let (col, row) = (p.x.round(), (p.y / 2.0).floor());
        if col < 0.0 || row < 0.0 || col >= f64::from(area.width) || row >= f64::from(area.height) {
            return;
        }
        if let Some(cell) = buf.cell_mut((area.x + col as u16, area.y + row as u16)) {
            cell.set_symbol(symbol).set_fg(colour);
        }
    };
    // Five hundredths of the framing radius (about 6 mm on a head): a landmark in a crease
    // (the mouth corners) is marked, one behind the nose or the cheek is not.
    let tolerance = 0.05 * vp.radius;
    for &(v, symbol, colour) in &overlay.vertices {
        if let Some(p) = mesh.vertices.get(v).filter(|p| shot.sees(p, tolerance)) {
            mark(shot.camera.project(p), symbol, colour);
        }
    }
    if let Some(c) = overlay.cursor {
        mark(shot.pixel_of(vp, c), "+", Color::LightMagenta);
    }
}

/// The wireframe's area and the side panel's (absent below 50 columns or when hidden).
fn split(app: &App, area: Rect) -> (Rect, Rect) {
    let side_w = if area.width >= 50 && app.side_panel { 26.min(area.width / 3) } else { 0 };
    let canvas_area = Rect::new(area.x, area.y, area.width - side_w, area.height);
    let side = Rect::new(area.x + canvas_area.width, area.y, side_w, area.height);
    (canvas_area, side)
}

pub fn draw(app: &App, frame: &mut Frame, area: Rect) {
    if let Some(index) = app.head.heads.shown {
        draw_transferred(app, index, frame, area);
        return;
    }
    let (canvas_area, side) = split(app, area);
    let h = &app.head.view;
    let picked = match h.suggested {
        Some((l, v)) if l == h.label => Some(v),
        _ => app.mesh.as_ref().and_then(|m| {
            pick_vertex(
                m,
                &app.head.triangles,
                &app.head.framing,
                h,
                app.head.label_candidates.as_deref().map(Vec::as_slice),
            )
        }),
    };
    match &app.mesh {
        Some(mesh) if !h.wireframe => draw_shaded(app, frame, canvas_area, mesh, picked),
        Some(mesh) => {
            let map = app.map.clone().unwrap_or_default();
            let label = h.label;
            let cursor = (h.cursor.0, -h.cursor.1);
            let zoom = h.zoom;
            draw_wireframe(
                frame,
                canvas_area,
                mesh,
                &app.head.edges,
                &view_rotation(h, &app.head.framing),
                &head_wire_view(app),
                |ctx, pts, visible| {
                    let mapped: Vec<(f64, f64)> = map
                        .to_vertex
                        .iter()
                        .filter(|(l, v)| **l != label && visible.get(**v) == Some(&true))
                        .filter_map(|(_, v)| pts.get(*v).map(|p| (p.0, p.1)))
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
            Paragraph::new("No head mesh in this session (lipmap import SESSION --head HEAD.obj).")
                .fg(Color::Gray),
            canvas_area,
        ),
    }
    if side.width == 0 {
        return;
    }
    let mapped = app.map.as_ref().map_or(0, |m| m.len());
    let current = app.map.as_ref().and_then(|m| m.vertex(h.label));
    let mut lines = map_selector(app, usize::from(side.width.saturating_sub(1)));
    lines.extend([
        Line::from(crate::reference::current().names.label(h.label)).fg(Color::Yellow),
        Line::from(match current {
            Some(v) => format!("now vertex {v}"),
            None => "not mapped".into(),
        }),
        Line::from(match (picked, h.suggested) {
            (Some(v), Some((l, s))) if l == h.label && s == v => format!("suggested vertex {v}"),
            (Some(v), _) => format!("cursor on vertex {v}"),
            (None, _) => "cursor on no vertex".into(),
        })
        .fg(Color::LightRed),
        Line::from(""),
        Line::from(format!("{mapped}/68 landmarks mapped")),
        Line::from(format!("yaw {:.0}° pitch {:.0}°", h.yaw, h.pitch)),
        Line::from(format!("zoom {:.1}×", h.zoom)),
    ]);
    if let Some(m) = &app.mesh {
        lines.push(Line::from(format!("{} vertices", m.vertices.len())).fg(Color::DarkGray));
    }
    frame.render_widget(
        Paragraph::new(lines)
            .block(Block::new().borders(Borders::LEFT).border_style(Color::DarkGray)),
        side,
    );
}

/// The panel's head: which map is being labelled, on which mesh. With two maps (the head is
/// another mesh than the model) both are listed, the labelled one marked (the status line
/// names the key that switches); `width` is the panel's text width.
fn map_selector(app: &App, width: usize) -> Vec<Line<'static>> {
    use crate::session::MapRole;
    let h = &app.head;
    let fit = |name: &str, room: usize| -> String {
        if name.chars().count() <= room {
            name.to_string()
        } else {
            let kept: String = name.chars().take(room.saturating_sub(1)).collect();
            format!("{kept}…")
        }
    };
    if !h.head_has_own_map {
        return vec![
            Line::from(format!("labelling the {} map", h.label_role.name().to_uppercase())).bold(),
            Line::from(format!("on {}", fit(&h.label_mesh_name, width.saturating_sub(3))))
                .fg(Color::Gray),
            Line::from("(one map: model = head)").fg(Color::DarkGray),
        ];
    }
    let entry = |role: MapRole| {
        let (mark, name) = if role == h.label_role {
            ("▸ ", h.label_mesh_name.as_str())
        } else {
            ("  ", h.other_mesh_name.as_str())
        };
        let text = format!("{mark}{:<6}{}", role.name(), fit(name, width.saturating_sub(8)));
        if role == h.label_role {
            Line::from(text).bold().fg(Color::Yellow)
        } else {
            Line::from(text).fg(Color::Gray)
        }
    };
    vec![
        Line::from("map to label:").bold(),
        entry(MapRole::Model),
        entry(MapRole::Head),
        Line::from(match h.label_role {
            MapRole::Model => "(what fit uses)",
            MapRole::Head => "(for transfer, indices)",
        })
        .fg(Color::DarkGray),
    ]
}

/// The shown transferred head at the current frame, front and side (the side turned 90° from
/// the front): the frame's shape when its job has it, the last frame's meanwhile, the
/// head at rest where the frame has no fit.
fn draw_transferred(app: &App, index: usize, frame: &mut Frame, area: Rect) {
    let (canvas_area, side) = split(app, area);
    let h = &app.head.view;
    let f = app.frame();
    let name = app.head.heads.names.get(index).cloned().unwrap_or_default();
    let mut lines =
        vec![Line::from("transferred head").bold(), Line::from(name).fg(Color::LightGreen)];
    match app.head.heads.setups.get(index) {
        Some(HeadSetup::Ready(p)) => {
            let fitted = app.fits.by_frame.get(&f).is_some_and(|x| x.is_usable());
            let current = app.head.heads.current.as_ref().filter(|c| c.head == index);
            let (shape, note) = match current.map(|c| (&c.shape, c.frame)) {
                Some((Err(e), _)) => (p.mesh.clone(), format!("frame {f}: {e}")),
                Some((Ok(m), cf)) if fitted && cf == f => (m.clone(), format!("frame {f}")),
                Some((Ok(m), cf)) if fitted => (m.clone(), format!("frame {cf} ({f} next)")),
                _ if fitted => (p.mesh.clone(), format!("frame {f}: transferring…")),
                _ => (p.mesh.clone(), format!("frame {f}: not fitted, at rest")),
            };
            let half = canvas_area.width / 2;
            let rot = view_rotation(h, &p.framing);
            let views = [
                (Rect::new(canvas_area.x, canvas_area.y, half, canvas_area.height), rot, "front"),
                (
                    Rect::new(
                        canvas_area.x + half,
                        canvas_area.y,
                        canvas_area.width - half,
                        canvas_area.height,
                    ),
                    rotation(90.0, 0.0) * rot,
                    "side",
                ),
            ];
            let view = WireView { framing: p.framing, zoom: h.zoom, centre: (0.0, 0.0) };
            for (r, rot, label) in views {
                let below = Rect::new(r.x, r.y + 1, r.width, r.height.saturating_sub(1));
                frame.render_widget(Paragraph::new(label).fg(Color::Gray), r);
                draw_wireframe(frame, below, &shape, &p.edges, &rot, &view, |_, _, _| {});
            }
            lines.extend([
                Line::from(format!("{} transfer", p.mode)),
                Line::from(note).fg(Color::Yellow),
                Line::from(""),
                Line::from(format!("yaw {:.0}° pitch {:.0}°", h.yaw, h.pitch)),
                Line::from(format!("zoom {:.1}×", h.zoom)),
                Line::from(format!("{} vertices", p.mesh.vertices.len())).fg(Color::DarkGray),
            ]);
        }
        Some(HeadSetup::Failed(e)) => {
            frame.render_widget(
                Paragraph::new(format!("This head cannot be shown: {e}"))
                    .wrap(ratatui::widgets::Wrap { trim: true })
                    .fg(Color::LightRed),
                canvas_area,
            );
        }
        _ => frame.render_widget(
            Paragraph::new("Setting up the transfer onto this head…").fg(Color::Gray),
            canvas_area,
        ),
    }
    if side.width > 0 {
        frame.render_widget(
            Paragraph::new(lines)
                .block(Block::new().borders(Borders::LEFT).border_style(Color::DarkGray)),
            side,
        );
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tui::fixtures::synthetic_mesh;

    #[test]
    fn picks_a_visible_vertex_under_the_cursor() {
        let mesh = synthetic_mesh();
        let tris = mesh.triangles();
        let view = HeadView::default();
        let framing = HeadFraming::around(&mesh.vertices).unwrap();
        let front = pick_vertex(&mesh, &tris, &framing, &view, None).unwrap();
        assert!(mesh.vertices[front].z > 0.0);
        // Turned around, the back of the head is in front.
        let back =
            pick_vertex(&mesh, &tris, &framing, &HeadView { yaw: 180.0, ..view }, None).unwrap();
        assert!(mesh.vertices[back].z < 0.0);
        // Far outside the head there is nothing to pick.
        assert_eq!(
            pick_vertex(&mesh, &tris, &framing, &HeadView { cursor: (1.4, 0.0), ..view }, None),
            None
        );
    }

    #[test]
    fn picking_lands_on_the_surface_in_front_not_in_the_socket_behind_it() {
        // A skin sheet at z = 0 with a square hole, a socket floor 28 units behind the hole,
        // and an "eyeball" filling the hole at z = -1 whose vertices cannot be labelled: the
        // cursor over the hole picks the skin vertex at the hole's rim, not the socket's.
        let mut vertices = Vec::new();
        let mut faces: Vec<Vec<u32>> = Vec::new();
        let grid = |vertices: &mut Vec<crate::math::Point3>, z: f64, lo: f64, step: f64| {
            let base = vertices.len() as u32;
            for j in 0..5 {
                for i in 0..5 {
                    vertices.push(crate::math::Point3::new(
                        lo + step * i as f64,
                        lo + step * j as f64,
                        z,
                    ));
                }
            }
            base
        };
        let skin = grid(&mut vertices, 0.0, -20.0, 10.0);
        for j in 0..4u32 {
            for i in 0..4u32 {
                if (1..3).contains(&i) && (1..3).contains(&j) {
                    continue; // the hole, −10..10 square
                }
                let v = skin + j * 5 + i;
                faces.push(vec![v, v + 1, v + 6, v + 5]);
            }
        }
        let socket = grid(&mut vertices, -28.0, -10.0, 5.0);
        let eye = grid(&mut vertices, -1.0, -10.0, 5.0);
        for base in [socket, eye] {
            for j in 0..4u32 {
                for i in 0..4u32 {
                    let v = base + j * 5 + i;
                    faces.push(vec![v, v + 1, v + 6, v + 5]);
                }
            }
        }
        let mesh = Mesh { vertices, faces };
        let n = mesh.vertices.len();
        // Labelable: skin and socket (a socket is skin too); the eyeball is not.
        let labelable: Vec<bool> = (0..n).map(|v| v < eye as usize).collect();
        let framing = HeadFraming {
            centre: crate::math::Point3::origin(),
            radius: 30.0,
            rotation: Matrix3::identity(),
        };
        // The cursor over the hole, near its corner (−10, −10) but inside: head units are
        // model units over the radius, y up (the cursor's y is down).
        let view = HeadView { cursor: (-8.0 / 30.0, 8.0 / 30.0), ..HeadView::default() };
        let with_eyes = label_triangles(&mesh, None);
        let picked = pick_vertex(&mesh, &with_eyes, &framing, &view, Some(&labelable)).unwrap();
        assert!(
            mesh.vertices[picked].z > -2.0,
            "the rim, not the socket: {:?}",
            mesh.vertices[picked]
        );
        // Without the eyeball's surface the socket floor behind the hole is what is seen.
        let holes = label_triangles(&mesh, Some(&labelable));
        let behind = pick_vertex(&mesh, &holes, &framing, &view, Some(&labelable)).unwrap();
        assert!(mesh.vertices[behind].z < -20.0, "{:?}", mesh.vertices[behind]);
    }

    #[test]
    fn about_half_of_a_closed_head_is_visible() {
        let mesh = synthetic_mesh();
        let framing = HeadFraming::around(&mesh.vertices).unwrap();
        let pts = project(&mesh, &rotation(20.0, 10.0), &framing);
        let vis = visible_vertices(&mesh, &pts);
        let n = vis.iter().filter(|v| **v).count() as f64 / vis.len() as f64;
        assert!((0.35..0.7).contains(&n), "visible fraction {n}");
        for (p, v) in pts.iter().zip(&vis) {
            if p.2 < -0.3 {
                assert!(!v, "a vertex well behind the centre is hidden");
            }
        }
    }
}
