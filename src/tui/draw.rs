//! Drawing the whole screen: `draw(&App, &Keymap, &mut Frame)` lays out the title bar (clip
//! and screen tabs), the shown screen (its `view`), the per-frame flag strip and the status
//! line (message, hints from the keymap, save state), then the overlays on top. Drawing
//! only reads the `App`.
//!
//! The layout is shared with `update` so mouse hit-testing matches what is drawn; hints are
//! looked up in the keymap so they always name the keys actually bound.

use super::action::Action;
use super::input::mode_chain;
use super::keymap::Keymap;
use super::overlays::{self, Overlay};
use super::screens::{self, View};
use crate::tui::app::App;
use ratatui::Frame;
use ratatui::layout::Rect;
use ratatui::style::{Color, Modifier, Style, Stylize};
use ratatui::text::{Line, Span};
use ratatui::widgets::Paragraph;

/// The fixed parts of the screen.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ScreenLayout {
    pub title: Rect,
    pub body: Rect,
    pub strip: Rect,
    pub status: Rect,
}

/// Title on top, flag strip and status line at the bottom, the view in between.
pub fn screen_layout(area: Rect) -> ScreenLayout {
    let h = area.height;
    let row = |y: u16, height: u16| Rect::new(area.x, area.y + y, area.width, height);
    if h < 4 {
        return ScreenLayout {
            title: row(0, 0),
            body: row(0, h),
            strip: row(h, 0),
            status: row(h, 0),
        };
    }
    ScreenLayout {
        title: row(0, 1),
        body: row(1, h - 3),
        strip: row(h - 2, 1),
        status: row(h - 1, 1),
    }
}

/// Draws the whole screen.
pub fn draw(app: &App, keymap: &Keymap, frame: &mut Frame) {
    let area = frame.area();
    let layout = screen_layout(area);
    draw_title(app, frame, layout.title);
    screens::draw_shown(app, frame, layout.body);
    draw_strip(app, frame, layout.strip);
    draw_status(app, keymap, frame, layout.status);
    for overlay in &app.overlays {
        match overlay {
            Overlay::Help { scroll } => {
                overlays::view::draw_help(app, keymap, *scroll, frame, area)
            }
            Overlay::Prompt { kind, input } => {
                overlays::view::draw_prompt(*kind, input, frame, layout.status)
            }
        }
    }
}

pub fn draw_title(app: &App, frame: &mut Frame, area: Rect) {
    if area.height == 0 {
        return;
    }
    let tab = |n: &str, name: &str, v: View| {
        let s = Span::from(format!(" {n} {name} "));
        if app.view == v { s.reversed().bold() } else { s.fg(Color::Gray) }
    };
    let mut tabs = vec![
        tab("1", "frames", View::Frames),
        tab("2", "head", View::Head),
        tab("3", "fit", View::Fit),
        tab("4", "analysis", View::Analysis),
    ];
    if app.side != screens::side::SideState::None {
        tabs.push(tab("5", "side", View::Side));
    }
    // The tabs always show; a long session · clip title gives way.
    let tabs_width: usize = tabs.iter().map(|s| s.content.chars().count()).sum();
    let room = usize::from(area.width).saturating_sub(tabs_width + "lipmap ".len() + 1);
    let title: String = if app.title.chars().count() <= room {
        app.title.clone()
    } else {
        let keep: String = app.title.chars().take(room.saturating_sub(1)).collect();
        format!("{keep}…")
    };
    let mut spans = vec![Span::from("lipmap ").bold().fg(Color::LightMagenta)];
    spans.push(Span::from(format!("{title} ")));
    spans.extend(tabs);
    frame.render_widget(Paragraph::new(Line::from(spans)), area);
}

/// One cell per frame (or per bucket of frames when there are more frames than columns):
/// `!` flagged (red), `✓` reviewed, `·` plain; the current frame's cell reversed.
pub fn draw_strip(app: &App, frame: &mut Frame, area: Rect) {
    if area.height == 0 || area.width == 0 {
        return;
    }
    let n = app.n_frames();
    if n == 0 {
        return;
    }
    let cols = (area.width as usize).min(n);
    let mut spans = Vec::with_capacity(cols);
    let flagged: std::collections::BTreeSet<usize> = app.flags.iter().map(|f| f.frame).collect();
    for c in 0..cols {
        let (a, b) = (c * n / cols, ((c + 1) * n / cols).max(c * n / cols + 1));
        let frames = &app.track.frames[a..b.min(n)];
        let any_flag = frames.iter().any(|f| flagged.contains(&f.frame));
        let all_reviewed = frames.iter().all(|f| app.reviewed.contains(&f.frame));
        let (sym, colour) = if any_flag && !all_reviewed {
            ("!", Color::LightRed)
        } else if all_reviewed {
            ("✓", Color::LightGreen)
        } else if any_flag {
            ("!", Color::Green)
        } else {
            ("·", Color::DarkGray)
        };
        let mut style = Style::new().fg(colour);
        if (a..b).contains(&app.frame_pos) {
            style = style.add_modifier(Modifier::REVERSED);
        }
        spans.push(Span::styled(sym, style));
    }
    frame.render_widget(Paragraph::new(Line::from(spans)), area);
}

pub fn draw_status(app: &App, keymap: &Keymap, frame: &mut Frame, area: Rect) {
    if area.height == 0 {
        return;
    }
    let chain = mode_chain(app);
    let key = |a: Action| keymap.key_for(&chain, &a).map_or(String::new(), |k| k.to_string());
    let save = if !app.save.is_clean() {
        Span::from(" ● unsaved ").fg(Color::Yellow)
    } else {
        Span::from(" saved ").fg(Color::DarkGray)
    };
    let fit = if app.fit.running {
        let (d, t) = app.fit.progress;
        Span::from(format!(" fitting {d}/{t} ")).fg(Color::LightCyan)
    } else {
        Span::from("")
    };
    let msg = if app.status.is_empty() {
        let mut hints = format!(
            "{} help  {} quit  {} undo",
            key(Action::ToggleHelp),
            key(Action::Quit),
            key(Action::Undo)
        );
        // Two maps to label: the key that switches between them.
        if app.view == View::Head && app.head.head_has_own_map && app.head.heads.shown.is_none() {
            let other = match app.head.label_role {
                crate::session::MapRole::Model => "head",
                crate::session::MapRole::Head => "model",
            };
            hints.push_str(&format!("  {} label the {other} map", key(Action::SwitchLabelledMesh)));
        }
        hints
    } else {
        app.status.clone()
    };
    let right_len = (save.width() + fit.width()) as u16;
    let left = Rect::new(area.x, area.y, area.width.saturating_sub(right_len), 1);
    let right = Rect::new(area.x + left.width, area.y, area.width - left.width, 1);
    frame.render_widget(Paragraph::new(msg), left);
    frame.render_widget(Paragraph::new(Line::from(vec![fit, save])), right);
}
