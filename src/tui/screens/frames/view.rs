//! Frames view: the frame as half-block pixels with the 68 landmarks over it (style by source
//! and visibility, the selected one highlighted) and a side panel describing frame and point.
//!
//! `landmark_markers` is shared with the fit view; `draw_graphics` puts a terminal graphics
//! protocol image over the half-blocks of either view when one is in use.

use crate::glossary::names::{REPROJECTION_ERROR, REPROJECTION_RMS};
use crate::landmarks::{LandmarkPoint, PointSource};
use crate::tui::app::App;
use crate::tui::overlays::Overlay;
use crate::tui::screens::View;
use crate::tui::screens::image_and_side;
use crate::tui::widgets::graphics::GraphicsState;
use crate::tui::widgets::halfblock::{HalfBlockImage, Mapping, Marker};
use crate::tui::widgets::wrap::NBSP;
use ratatui::Frame;
use ratatui::layout::Rect;
use ratatui::style::{Color, Modifier, Style, Stylize};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Borders, Paragraph, Wrap};

/// Colour of a point's source: tracked green, corrected yellow, interpolated cyan.
pub fn source_colour(s: PointSource) -> Color {
    match s {
        PointSource::Tracked => Color::LightGreen,
        PointSource::Corrected => Color::Yellow,
        PointSource::Interpolated => Color::LightCyan,
    }
}

/// Symbol of a point: shape by source, `×` when occluded.
pub fn point_symbol(p: &LandmarkPoint) -> &'static str {
    match (p.visible, p.source) {
        (false, _) => "×",
        (true, PointSource::Tracked) => "•",
        (true, PointSource::Corrected) => "◆",
        (true, PointSource::Interpolated) => "◇",
    }
}

/// Markers for the current frame's points, the selected one last (drawn on top).
pub fn landmark_markers(app: &App) -> Vec<Marker> {
    let Some(f) = app.track.frames.get(app.frame_pos) else { return Vec::new() };
    let scope = app.scope_indices();
    let mut out: Vec<Marker> = f
        .points
        .iter()
        .enumerate()
        .filter(|(i, _)| *i != app.frames.selected)
        .map(|(i, p)| {
            let mut style = Style::new().fg(source_colour(p.source));
            if !p.visible {
                style = style.add_modifier(Modifier::DIM);
            }
            if scope.len() > 1 && scope.contains(&i) {
                style = style.add_modifier(Modifier::BOLD);
            }
            Marker { x: p.x, y: p.y, symbol: point_symbol(p), style }
        })
        .collect();
    if let Some(p) = f.points.get(app.frames.selected) {
        out.push(Marker {
            x: p.x,
            y: p.y,
            symbol: if p.visible { "●" } else { "×" },
            style: Style::new()
                .fg(Color::LightMagenta)
                .bg(Color::White)
                .add_modifier(Modifier::BOLD),
        });
    }
    out
}

/// The outline of the face box being drawn (when one is), as markers one cell apart at
/// `scale` display pixels per image pixel (a cell is one display pixel wide, two high).
pub fn face_box_markers(app: &App, scale: f64) -> Vec<Marker> {
    let Some(Overlay::FaceBox(b)) = app.top_overlay() else { return Vec::new() };
    let [left, top, side] = b.rect();
    let (right, bottom) = (left + side, top + side);
    let style = Style::new().fg(Color::LightYellow).add_modifier(Modifier::BOLD);
    let mark = |x: f64, y: f64, symbol: &'static str| Marker { x, y, symbol, style };
    // At most a few hundred cells a side, whatever the zoom.
    let (sx, sy) = ((1.0 / scale).max(side / 400.0), (2.0 / scale).max(side / 400.0));
    let mut out = Vec::new();
    let (nx, ny) = ((side / sx).floor() as usize, (side / sy).floor() as usize);
    for i in 1..nx {
        let x = left + i as f64 * sx;
        out.extend([mark(x, top, "─"), mark(x, bottom, "─")]);
    }
    for i in 1..ny {
        let y = top + i as f64 * sy;
        out.extend([mark(left, y, "│"), mark(right, y, "│")]);
    }
    out.extend([
        mark(left, top, "┌"),
        mark(right, top, "┐"),
        mark(left, bottom, "└"),
        mark(right, bottom, "┘"),
    ]);
    out
}

/// Draws the frame image with markers into `area`, with a loading/error note when needed.
pub fn draw_image(app: &App, frame: &mut Frame, area: Rect, markers: &[Marker]) {
    let (w, h) = app.frame_dims();
    let Some(mapping) = Mapping::new(area, w, h, &app.frames.image_view) else { return };
    let image = app.current_image().map(|i| i.as_ref());
    frame.render_widget(HalfBlockImage { image, mapping, markers }, area);
    if image.is_none() {
        let note = match app.frames.cache.errors.get(&app.frame()) {
            Some(e) => format!(" no image: {e} "),
            None => " decoding frame… ".to_string(),
        };
        let r = Rect::new(
            area.x,
            area.y,
            area.width.min(note.chars().count() as u16),
            1.min(area.height),
        );
        frame.render_widget(Paragraph::new(note).style(Style::new().fg(Color::Gray)), r);
    }
}

/// Draws the current frame through the terminal graphics protocol of `gfx` over the
/// half-block image `draw` left in the frames and fit views (same area, same `Mapping`,
/// markers rasterised into the pixels). Call after `draw::draw`, inside the same
/// `Terminal::draw`. Nothing happens without a protocol, without a decoded image (the
/// loading note stays visible), or while the help overlay covers the screen: a protocol
/// image would paint over it, and drawing half-blocks meanwhile makes every cell differ
/// when the overlay closes, so the image is re-sent whole. Returns whether it drew.
pub fn draw_graphics(app: &App, gfx: &mut GraphicsState, frame: &mut Frame) -> bool {
    if gfx.protocol().is_none() || app.overlays.iter().any(|o| matches!(o, Overlay::Help { .. })) {
        return false;
    }
    let size = frame.area();
    let Some(mapping) = crate::tui::screens::image_mapping(app, (size.width, size.height)) else {
        return false;
    };
    let markers = match app.view {
        View::Frames => {
            let mut m = landmark_markers(app);
            m.extend(face_box_markers(app, mapping.scale));
            m
        }
        View::Fit => crate::tui::screens::fit::view::fit_markers(app),
        View::Head | View::Analysis | View::Side => return false,
    };
    let Some(image) = app.current_image() else { return false };
    gfx.render(image, app.frame(), mapping, &markers, frame.buffer_mut())
}

pub fn draw(app: &App, frame: &mut Frame, area: Rect) {
    let (image, side) = image_and_side(app, area);
    let mut markers = landmark_markers(app);
    let (w, h) = app.frame_dims();
    if let Some(m) = Mapping::new(image, w, h, &app.frames.image_view) {
        markers.extend(face_box_markers(app, m.scale));
    }
    draw_image(app, frame, image, &markers);
    if side.width > 0 {
        frame.render_widget(
            Paragraph::new(side_lines(app)).wrap(Wrap { trim: true }).block(
                Block::new().borders(Borders::LEFT).border_style(Style::new().fg(Color::DarkGray)),
            ),
            side,
        );
    }
}

fn side_lines(app: &App) -> Vec<Line<'static>> {
    let mut lines = Vec::new();
    let n = app.n_frames();
    let f = app.frame();
    lines.push(Line::from(vec![
        Span::from(format!("frame {f}")).bold(),
        Span::from(format!("  {}/{}", app.frame_pos + 1, n)),
    ]));
    if let Some(phone) = app.phone_label() {
        lines.push(Line::from(format!("phone {phone}")));
    }
    lines.push(if app.reviewed.contains(&f) {
        Line::from("✓ reviewed").fg(Color::LightGreen)
    } else {
        Line::from("not reviewed").fg(Color::DarkGray)
    });
    lines.push(Line::from(""));
    let sel = app.frames.selected;
    lines.push(
        Line::from(crate::reference::current().names.label(sel)).bold().fg(Color::LightMagenta),
    );
    if let Some(p) = app.track.frames.get(app.frame_pos).and_then(|fr| fr.points.get(sel)) {
        lines.push(Line::from(vec![
            Span::from(p.source.as_str()).fg(source_colour(p.source)),
            Span::from(if p.visible { " · visible" } else { " · occluded" }),
        ]));
        lines.push(Line::from(format!("x {:.2}  y {:.2}", p.x, p.y)));
        if let Some(t) = app.tracked.get(f).and_then(|fr| fr.points.get(sel))
            && t != p
        {
            lines.push(Line::from(format!("tracker {:.1} {:.1}", t.x, t.y)).fg(Color::DarkGray));
        }
        if let Some(c) = p.confidence {
            lines.push(Line::from(format!("confidence {c:.2}")));
        }
    }
    // The point's own error and the frame's RMS, named as the fit view and `eval` name them.
    if let Some(fit) = app.fits.by_frame.get(&f).filter(|fit| fit.is_usable()) {
        if let Some(r) = fit.residuals.get(sel).copied().flatten() {
            lines.push(Line::from(format!("{REPROJECTION_ERROR} {:.2}{NBSP}px", r[0].hypot(r[1]))));
        }
        lines
            .push(Line::from(format!("frame {REPROJECTION_RMS} {:.2}{NBSP}px", fit.reproj_rms_px)));
    }
    lines.push(Line::from(format!(
        "moves: {}   zoom {}×",
        app.frames.scope.label(),
        app.frames.image_view.zoom
    )));
    lines.push(Line::from(""));
    match app.flags_of(f) {
        Some(fl) => {
            lines.push(Line::from("flags").bold().fg(Color::LightRed));
            for r in &fl.reasons {
                lines.push(Line::from(format!("! {r}")).fg(Color::LightRed));
            }
        }
        None => lines.push(Line::from("no flags").fg(Color::DarkGray)),
    }
    lines.push(Line::from(format!("{} flagged frames", app.flags.len())).fg(Color::DarkGray));
    lines
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tui::fixtures::synthetic_app;
    use crate::tui::keymap::Keymap;
    use ratatui::Terminal;
    use ratatui::backend::TestBackend;
    use ratatui_image::picker::ProtocolType;

    /// Draws like the run loop and returns whether the protocol drew, and the symbol of the
    /// image area's first cell.
    fn draw_like_run_loop(app: &App, gfx: &mut GraphicsState) -> (bool, String) {
        let mut term = Terminal::new(TestBackend::new(100, 30)).unwrap();
        let mut drew = false;
        term.draw(|f| {
            crate::tui::draw::draw(app, &Keymap::default(), f);
            drew = draw_graphics(app, gfx, f);
        })
        .unwrap();
        let area = crate::tui::screens::image_mapping(app, (100, 30)).map(|m| m.area);
        let first = area.map(|a| term.backend().buffer()[(a.x, a.y)].symbol().to_string());
        (drew, first.unwrap_or_default())
    }

    #[test]
    fn protocol_image_covers_the_image_area_in_frames_and_fit_views_only() {
        let mut app = synthetic_app(3, 120, 80, true);
        app.term_size = (100, 30);
        let mut gfx = GraphicsState::with_protocol(ProtocolType::Kitty, (8, 16), false);
        let (drew, first) = draw_like_run_loop(&app, &mut gfx);
        assert!(drew && first.starts_with("\x1b_G"), "frames view transmits the image");
        app.view = View::Fit;
        assert!(draw_like_run_loop(&app, &mut gfx).0);
        assert_eq!(gfx.encodes(), 2, "fit markers differ from the frames view's");
        app.overlays.push(Overlay::Help { scroll: 0 });
        assert!(!draw_like_run_loop(&app, &mut gfx).0, "help overlay: half-blocks");
        app.overlays.clear();
        app.view = View::Head;
        assert!(!draw_like_run_loop(&app, &mut gfx).0);
        // Half-blocks: the run loop's extra call draws nothing.
        app.view = View::Frames;
        let (drew, first) = draw_like_run_loop(&app, &mut GraphicsState::halfblocks());
        assert!(!drew && first == "▀");
    }
}
