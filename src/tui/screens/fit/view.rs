//! Fit view: the frame with tracked points (dim) and fitted points (`+`, tracked + residual)
//! side by side, the fit's progress, the frame's pose and RMS, the worst residuals, and the
//! head wireframe from the front and the side in the frame's fitted pose.
//!
//! Editing keys work here as in the frames view (mode chain fit → frames → global).

use crate::glossary::names::{REPROJECTION_ERROR, REPROJECTION_RMS};
use crate::landmarks::PointNo;
use crate::math::Matrix3;
use crate::model::Mesh;
use crate::render::HeadViewport;
use crate::tui::app::App;
use crate::tui::screens::frames::view::{draw_image, landmark_markers};
use crate::tui::screens::head::HeadFraming;
use crate::tui::screens::head::view::{Overlay, draw_shaded_mesh, label_triangles, rotation};
use crate::tui::screens::image_and_side;
use crate::tui::widgets::halfblock::Marker;
use crate::tui::widgets::wrap::NBSP;
use ratatui::Frame;
use ratatui::layout::Rect;
use ratatui::style::{Color, Style, Stylize};
use ratatui::text::Line;
use ratatui::widgets::{Block, Borders, Gauge, Paragraph};

/// Rotation of a fitted frame, R = Ry(yaw)·Rx(pitch)·Rz(roll) as `FrameFit` documents.
fn fit_rotation(yaw: f64, pitch: f64, roll: f64) -> Matrix3 {
    let rz =
        nalgebra::Rotation3::from_axis_angle(&crate::math::Vector3::z_axis(), roll.to_radians());
    rotation(yaw, pitch) * rz.into_inner()
}

/// Markers of the fit view: tracked points as grey dots, fitted points (`+`, tracked +
/// residual) over them, the selected point on top.
pub fn fit_markers(app: &App) -> Vec<Marker> {
    let fit = app.fits.by_frame.get(&app.frame());
    let mut markers: Vec<Marker> = landmark_markers(app)
        .into_iter()
        .map(|mut m| {
            if m.symbol != "●" {
                m.symbol = "·";
                m.style = Style::new().fg(Color::Gray);
            }
            m
        })
        .collect();
    if let (Some(fit), Some(points)) = (fit, app.track.frames.get(app.frame_pos)) {
        let fitted = points.points.iter().zip(&fit.residuals).filter_map(|(p, r)| {
            r.map(|r| Marker {
                x: p.x + r[0],
                y: p.y + r[1],
                symbol: "+",
                style: Style::new().fg(Color::LightRed),
            })
        });
        // Fitted under the selected marker, over the tracked ones.
        let sel = markers.pop();
        markers.extend(fitted);
        markers.extend(sel);
    }
    markers
}

pub fn draw(app: &App, frame: &mut Frame, area: Rect) {
    let (image, side) = image_and_side(app, area);
    let f = app.frame();
    let fit = app.fits.by_frame.get(&f);
    draw_image(app, frame, image, &fit_markers(app));
    if side.width == 0 {
        return;
    }
    let inner = Block::new().borders(Borders::LEFT).border_style(Color::DarkGray);
    let content = inner.inner(side);
    frame.render_widget(inner, side);
    let mut y = content.y;
    let bottom = content.y + content.height;
    if app.fit.running || app.fit.progress.1 > 0 && app.fit.progress.0 < app.fit.progress.1 {
        let (d, t) = app.fit.progress;
        let ratio = if t == 0 { 0.0 } else { d as f64 / t as f64 };
        frame.render_widget(
            Gauge::default()
                .ratio(ratio.clamp(0.0, 1.0))
                .label(format!("fit {d}/{t}"))
                .gauge_style(Color::LightCyan),
            Rect::new(content.x, y, content.width, 1),
        );
        y += 1;
    }
    let mut lines: Vec<Line> = Vec::new();
    match fit {
        Some(fit) => {
            lines.push(Line::from(format!("frame {f}")).bold());
            lines.push(Line::from(format!("{REPROJECTION_RMS} {:.2}{NBSP}px", fit.reproj_rms_px)));
            if let Some(why) = &fit.failed {
                lines.push(Line::from(format!("failed: {why}")).fg(Color::LightRed));
            }
            lines.push(Line::from(format!(
                "yaw{NBSP}{:.0}° pitch{NBSP}{:.0}° roll{NBSP}{:.0}°",
                fit.yaw, fit.pitch, fit.roll
            )));
            let mut worst: Vec<(usize, f64)> = fit
                .residuals
                .iter()
                .enumerate()
                .filter_map(|(i, r)| r.map(|r| (i, r[0].hypot(r[1]))))
                .collect();
            worst.sort_by(|a, b| b.1.total_cmp(&a.1));
            lines.push(Line::from(format!("worst points, {REPROJECTION_ERROR}")).fg(Color::Gray));
            for (i, r) in worst.iter().take(6) {
                let mark = if *i == app.frames.selected { "▸" } else { " " };
                lines.push(Line::from(format!("{mark}{:>2} {r:6.2} px", PointNo(*i))));
            }
        }
        None => {
            lines.push(Line::from(format!("frame {f}: not fitted")).fg(Color::Gray));
            if let Some(e) = &app.fit.error {
                lines.push(Line::from(format!("error: {e}")).fg(Color::LightRed));
            }
            lines.push(Line::from("press f to fit the clip").fg(Color::DarkGray));
        }
    }
    if !app.fit.map_problems.is_empty() {
        lines.push(
            Line::from(format!("model map: {} problems", app.fit.map_problems.len()))
                .fg(Color::LightRed)
                .bold(),
        );
        lines
            .extend(app.fit.map_problems.iter().map(|p| Line::from(p.clone()).fg(Color::LightRed)));
        lines.push(Line::from("f again: fit anyway").fg(Color::Yellow));
    }
    if app.fits.stale.contains(&f) {
        lines.push(Line::from("edited since fit").fg(Color::Yellow));
    }
    let lines = crate::tui::widgets::wrap::wrap_lines(lines, usize::from(content.width));
    let text_h = (lines.len() as u16).min(bottom.saturating_sub(y));
    frame.render_widget(Paragraph::new(lines), Rect::new(content.x, y, content.width, text_h));
    y += text_h;
    // Front and side views of the fitted mesh in the fitted pose, shaded, when there is room.
    let room = bottom.saturating_sub(y);
    if let Some(fit) = fit.filter(|f| f.is_usable())
        && room >= 6
        && let Some((shown, framing)) = fitted_mesh(app, fit)
    {
        let half = content.width / 2;
        let r = fit_rotation(fit.yaw, fit.pitch, fit.roll);
        let side_r = rotation(90.0, 0.0) * r;
        let front_area = Rect::new(content.x, y, half, room);
        let side_area = Rect::new(content.x + half, y, content.width - half, room);
        // The skin with the eyes, teeth and tongue, without a figure's see-through shells.
        let drawn = app
            .head
            .occluders
            .as_deref()
            .filter(|e| e.len() == shown.vertices.len())
            .map(Vec::as_slice);
        let triangles = label_triangles(&shown, drawn);
        let vp = |rotation| HeadViewport {
            rotation,
            centre: framing.centre,
            radius: framing.radius,
            half_height: 1.05,
            look_at: (0.0, 0.0),
        };
        let bare = Overlay { vertices: Vec::new(), cursor: None };
        draw_shaded_mesh(frame, front_area, &shown, &triangles, &vp(r), &bare);
        draw_shaded_mesh(frame, side_area, &shown, &triangles, &vp(side_r), &bare);
    }
}

/// The fitted mesh and the sphere framing its face: the model's fitted shape with the head
/// mesh's faces when they share a topology (a figure that is its own model), else with the
/// model's triangles (a model fitted apart from the head). `None` without a model.
fn fitted_mesh(app: &App, fit: &crate::fit::FrameFit) -> Option<(Mesh, HeadFraming)> {
    let model = app.model.as_ref()?;
    let shape = crate::fit::fitted_shape(model, fit);
    let same = app.mesh.as_ref().filter(|m| m.vertices.len() == model.num_vertices());
    // A few hundred thousand multiply-adds for the shape and a face list: well inside a draw.
    Some(match same {
        Some(head) => (Mesh::from_flat(shape.as_slice(), head.faces.clone()), app.head.framing),
        None => {
            let mesh = model.to_mesh(&shape);
            let framing = HeadFraming::of_face(&mesh, Some(model), app.fit_map(), None);
            (mesh, framing)
        }
    })
}
