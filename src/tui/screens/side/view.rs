//! Side view: the side camera's frame framed on the lip crop, with the reference line, the
//! upper lip's foremost point (automatic or corrected) and P, so each frame's P can be checked
//! and the point moved by hand.

use crate::measure::profile::ProfilePoint;
use crate::tui::app::App;
use crate::tui::draw::screen_layout;
use crate::tui::screens::View;
use crate::tui::screens::frames::ImageView;
use crate::tui::screens::frames::view::source_colour;
use crate::tui::screens::image_and_side;
use crate::tui::screens::side::{SideState, SideView};
use crate::tui::widgets::halfblock::{HalfBlockImage, Mapping, Marker};
use ratatui::Frame;
use ratatui::layout::Rect;
use ratatui::style::{Color, Modifier, Style, Stylize};
use ratatui::text::Line;
use ratatui::widgets::{Block, Borders, Paragraph, Wrap};

/// Margin around the crop, as a fraction of its size, so the profile's context shows.
const CROP_MARGIN: f64 = 0.3;

/// The side image's size: a decoded frame's, else the crop's far corner.
fn side_dims(side: &SideView) -> (u32, u32) {
    side.images.values().next().map_or_else(
        || {
            let c = side.setup.crop;
            (c.x + c.width, c.y + c.height)
        },
        |i| (i.width, i.height),
    )
}

/// The mapping of the side frame in the side view for a terminal of `size`: the crop (with a
/// margin) fills the image area. `None` in other views or before the side view is measured.
pub fn side_mapping(app: &App, size: (u16, u16)) -> Option<Mapping> {
    if app.view != View::Side {
        return None;
    }
    let side = app.side.view()?;
    let layout = screen_layout(app, Rect::new(0, 0, size.0, size.1));
    let (area, _) = image_and_side(app, layout.body);
    let (w, h) = side_dims(side);
    let c = side.setup.crop;
    let (aw, ah) = (f64::from(area.width), 2.0 * f64::from(area.height));
    let fit = (aw / f64::from(w)).min(ah / f64::from(h));
    let (cw, ch) = (
        f64::from(c.width.max(1)) * (1.0 + CROP_MARGIN),
        f64::from(c.height.max(1)) * (1.0 + CROP_MARGIN),
    );
    let zoom = ((aw / cw).min(ah / ch) / fit).max(1.0);
    let centre = (
        f64::from(c.x) + f64::from(c.width) / 2.0 - 0.5,
        f64::from(c.y) + f64::from(c.height) / 2.0 - 0.5,
    );
    Mapping::new(area, w, h, &ImageView { zoom, center: Some(centre) })
}

/// The reference line as dots every few pixels down the crop, the crop's corners, and the
/// upper-lip point on top.
fn side_markers(side: &SideView, point: Option<&ProfilePoint>, step_px: f64) -> Vec<Marker> {
    let c = side.setup.crop;
    let line = side.setup.reference_line;
    let dim = Style::new().fg(Color::LightBlue);
    let mut out = Vec::new();
    let (y0, y1) = (f64::from(c.y), f64::from(c.y + c.height));
    let mut y = y0;
    // The line is set in the anchor frame; this frame's head motion maps it back here.
    let back = point.and_then(|p| p.motion).map(|m| m.inverse());
    let (a, b) = match back {
        Some(m) => (m * line.a, m * line.b),
        None => (line.a, line.b),
    };
    let (p, d) = (a, b - a);
    while y <= y1 && d.y.abs() > 1e-9 {
        let t = (y - p.y) / d.y;
        out.push(Marker { x: p.x + t * d.x, y, symbol: "┊", style: dim });
        y += (2.0 * step_px).max(1.0);
    }
    let corner = Style::new().fg(Color::DarkGray);
    for (x, y) in
        [(c.x, c.y), (c.x + c.width, c.y), (c.x, c.y + c.height), (c.x + c.width, c.y + c.height)]
    {
        out.push(Marker { x: f64::from(x), y: f64::from(y), symbol: "+", style: corner });
    }
    if let Some(q) = point.and_then(|p| p.upper_lip_px) {
        let source = point.map_or(crate::landmarks::PointSource::Tracked, |p| p.source);
        out.push(Marker {
            x: q.x,
            y: q.y,
            symbol: "●",
            style: Style::new().fg(source_colour(source)).add_modifier(Modifier::BOLD),
        });
    }
    out
}

pub fn draw(app: &App, frame: &mut Frame, area: Rect) {
    let (image_area, panel) = image_and_side(app, area);
    let side = match &app.side {
        SideState::Ready(s) => s,
        other => {
            let note = match other {
                SideState::Measuring => "measuring the side view's lip profile…".to_string(),
                SideState::Failed(e) => format!("side view: {e}"),
                _ => "this clip has no side view".to_string(),
            };
            frame.render_widget(Paragraph::new(note).fg(Color::Gray), area);
            return;
        }
    };
    let k = side.frame_for(app.frame(), app.fps);
    let point = k.and_then(|k| side.track.effective(k, &side.setup));
    let size = frame.area();
    if let Some(mapping) = side_mapping(app, (size.width, size.height)) {
        let image = k.and_then(|k| side.images.get(&k)).map(|i| i.as_ref());
        let markers = side_markers(side, point.as_ref(), mapping.step_px());
        frame.render_widget(HalfBlockImage { image, mapping, markers: &markers }, image_area);
    }
    if panel.width == 0 {
        return;
    }
    let mut lines = vec![Line::from("side view (P)").bold()];
    match k {
        Some(k) => lines.push(Line::from(format!("side frame {k}/{}", side.n_frames))),
        None => lines.push(Line::from("no side frame at this time").fg(Color::Gray)),
    }
    if let Some(p) = &point {
        match (p.p_px, p.p_norm) {
            (Some(px), Some(n)) => lines.push(Line::from(format!("P {n:.3} ({px:.1} px)"))),
            (Some(px), None) => lines.push(Line::from(format!("P {px:.1} px"))),
            _ => {}
        }
        let source = match p.source {
            crate::landmarks::PointSource::Tracked => "automatic",
            other => other.as_str(),
        };
        lines.push(Line::from(source).fg(source_colour(p.source)));
        if let Some(f) = &p.failed {
            lines.push(Line::from(format!("failed: {f}")).fg(Color::LightRed));
        }
    }
    if let Some(e) = k.and_then(|k| side.image_errors.get(&k)) {
        lines.push(Line::from(format!("no image: {e}")).fg(Color::LightRed));
    }
    let corrected = side.track.corrected.len();
    let failed = side.track.automatic.iter().filter(|p| p.failed.is_some()).count();
    lines.push(Line::from(""));
    lines.push(Line::from(format!("{corrected} corrected, {failed} failed")).fg(Color::Gray));
    lines.push(Line::from("arrows move the point, x reverts").fg(Color::DarkGray));
    frame.render_widget(
        Paragraph::new(lines)
            .wrap(Wrap { trim: true })
            .block(Block::new().borders(Borders::LEFT).border_style(Color::DarkGray)),
        panel,
    );
}
