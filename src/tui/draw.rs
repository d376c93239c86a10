//! Drawing the whole screen: `draw(&App, &Keymap, &mut Frame)` lays out the title bar (clip
//! and screen tabs), the shown screen (its `view`), the per-frame flag strip and the status
//! line (message, hints from the keymap, save state), then the overlays on top. Drawing
//! only reads the `App`.
//!
//! The layout is shared with `update` so mouse hit-testing matches what is drawn; hints are
//! looked up in the keymap so they always name the keys actually bound. A long status
//! message wraps onto up to [`MAX_STATUS_ROWS`] rows, taken from the view, so it is read
//! whole at any width.

use super::action::Action;
use super::input::mode_chain;
use super::keymap::Keymap;
use super::overlays::{self, Overlay};
use super::screens::{self, View};
use super::widgets::wrap::wrap_words;
use crate::tui::app::App;
use ratatui::Frame;
use ratatui::layout::Rect;
use ratatui::style::{Color, Modifier, Style, Stylize};
use ratatui::text::{Line, Span};
use ratatui::widgets::Paragraph;

/// The most rows a status message takes (the rest of a longer one is cut, its last row
/// ending in `…`). Four rows at 80 columns hold the longest warnings lipmap gives.
pub const MAX_STATUS_ROWS: u16 = 4;

/// The fixed parts of the screen.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct ScreenLayout {
    pub title: Rect,
    pub body: Rect,
    pub strip: Rect,
    pub status: Rect,
}

/// Title on top, flag strip and status line at the bottom (as many rows as the app's status
/// message needs, [`status_rows`]), the view in between.
pub fn screen_layout(app: &App, area: Rect) -> ScreenLayout {
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
    // The view keeps at least half the screen.
    let s = status_rows(app, area.width).min((h / 2).saturating_sub(2)).max(1);
    ScreenLayout {
        title: row(0, 1),
        body: row(1, h - 2 - s),
        strip: row(h - 1 - s, 1),
        status: row(h - s, s),
    }
}

/// The status line's right end: the fit's progress and the save state.
fn status_right(app: &App) -> Vec<Span<'static>> {
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
    vec![fit, save]
}

/// Columns of the status message: the width less the right end.
fn message_width(app: &App, width: u16) -> u16 {
    let right: usize = status_right(app).iter().map(Span::width).sum();
    width.saturating_sub(right as u16)
}

/// Rows the status message takes at `width` columns (1 to [`MAX_STATUS_ROWS`]).
pub fn status_rows(app: &App, width: u16) -> u16 {
    let rows = wrap_words(&app.status, usize::from(message_width(app, width))).len();
    (rows as u16).clamp(1, MAX_STATUS_ROWS)
}

/// Draws the whole screen.
pub fn draw(app: &App, keymap: &Keymap, frame: &mut Frame) {
    let area = frame.area();
    let layout = screen_layout(app, area);
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
            Overlay::FaceBox(_) => {
                overlays::view::draw_face_box_hint(app, keymap, frame, layout.status)
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
    let left = Rect::new(area.x, area.y, message_width(app, area.width), area.height);
    let right = Rect::new(area.x + left.width, area.y, area.width - left.width, 1);
    let mut rows = wrap_words(&msg, usize::from(left.width));
    if rows.len() > usize::from(area.height) {
        // The message goes on past the rows there are: say so on the last one.
        rows.truncate(usize::from(area.height));
        if let Some(last) = rows.last_mut() {
            let keep = usize::from(left.width).saturating_sub(1);
            *last = last.chars().take(keep).collect::<String>() + "…";
        }
    }
    let rows: Vec<Line> = rows.into_iter().map(Line::from).collect();
    frame.render_widget(Paragraph::new(rows), left);
    frame.render_widget(Paragraph::new(Line::from(status_right(app))), right);
}
