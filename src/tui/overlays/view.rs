//! Drawing the overlays. The help is generated from the keymap and the actions' help text (so
//! it cannot drift from the real bindings): one section per keymap table of the shown screen,
//! keys bound to the same action listed together. A prompt takes the status line.

use super::PromptKind;
use crate::tui::action::Action;
use crate::tui::app::App;
use crate::tui::input::mode_chain;
use crate::tui::keymap::{KeyMode, Keymap};
use ratatui::Frame;
use ratatui::layout::Rect;
use ratatui::style::{Color, Stylize};
use ratatui::text::{Line, Span};
use ratatui::widgets::{Block, Clear, Paragraph};

/// Widest key column before key lists move to a line of their own.
const KEY_COLUMN: usize = 16;

/// The help text lines for the current view.
pub fn help_lines(app: &App, keymap: &Keymap) -> Vec<Line<'static>> {
    let mut lines = Vec::new();
    for mode in mode_chain(app).into_iter().filter(|m| *m != KeyMode::Help) {
        // Group by description without its direction arrow, so the four arrows of one
        // action kind share a line: "left h, right l, up k, down j".
        let mut entries: Vec<(String, Vec<String>)> = Vec::new();
        let mut done: Vec<&crate::tui::action::Action> = Vec::new();
        for b in keymap.of_mode(mode) {
            if done.contains(&&b.action) {
                continue;
            }
            done.push(&b.action);
            let keys: Vec<String> = keymap
                .of_mode(mode)
                .filter(|o| o.action == b.action)
                .map(|o| o.key.to_string())
                .collect();
            let desc = b.action.describe();
            let base = desc.trim_end_matches(['←', '→', '↑', '↓']).trim_end().to_string();
            match entries.iter_mut().find(|e| e.0 == base) {
                Some(e) => e.1.push(keys.join(" ")),
                None => entries.push((base, vec![keys.join(" ")])),
            }
        }
        if entries.is_empty() {
            continue;
        }
        lines.push(Line::from(format!("{} keys", mode.name())).bold().fg(Color::LightMagenta));
        let width = entries
            .iter()
            .map(|e| e.1.join(", ").chars().count())
            .filter(|w| *w <= KEY_COLUMN)
            .max()
            .unwrap_or(0);
        for (d, keys) in entries {
            let k = keys.join(", ");
            if k.chars().count() > width {
                // Long key lists get their own line rather than pushing the text off screen.
                lines.push(Line::from(format!("  {k}")).fg(Color::LightCyan));
                lines.push(Line::from(format!("  {:<width$} {d}", "")));
            } else {
                lines.push(Line::from(vec![
                    Span::from(format!("  {k:<width$} ")).fg(Color::LightCyan),
                    Span::from(d),
                ]));
            }
        }
    }
    lines.push(Line::from("mouse: click selects the nearest point, drag moves it").fg(Color::Gray));
    lines
}

/// The help overlay, centred over the screen, scrolled down `scroll` lines.
pub fn draw_help(app: &App, keymap: &Keymap, scroll: u16, frame: &mut Frame, area: Rect) {
    let w = area.width.saturating_sub(4).min(90);
    let h = area.height.saturating_sub(2);
    if w < 10 || h < 3 {
        return;
    }
    let r = Rect::new(area.x + (area.width - w) / 2, area.y + (area.height - h) / 2, w, h);
    // Long key lists wrap rather than run off a narrow screen.
    let lines = crate::tui::widgets::wrap::wrap_lines(help_lines(app, keymap), usize::from(w - 2));
    let max_scroll = (lines.len() as u16).saturating_sub(h.saturating_sub(2));
    let chain = [KeyMode::Help];
    let key = |a: Action| keymap.key_for(&chain, &a).map_or("?".to_string(), |k| k.to_string());
    let title = format!(
        " help · {}/{} scroll · {} close ",
        key(Action::ScrollDown),
        key(Action::ScrollUp),
        key(Action::ToggleHelp)
    );
    frame.render_widget(Clear, r);
    frame.render_widget(
        Paragraph::new(lines)
            .scroll((scroll.min(max_scroll), 0))
            .block(Block::bordered().title(title).border_style(Color::LightMagenta)),
        r,
    );
}

/// The prompt, over the status line.
pub fn draw_prompt(kind: PromptKind, input: &str, frame: &mut Frame, area: Rect) {
    if area.height == 0 {
        return;
    }
    let line = Line::from(vec![
        Span::from(format!("{}: ", kind.question())).fg(Color::LightCyan),
        Span::from(input.to_string()).bold(),
        Span::from("▏"),
        Span::from("  Enter ok · Esc cancel").fg(Color::DarkGray),
    ]);
    frame.render_widget(ratatui::widgets::Clear, area);
    frame.render_widget(Paragraph::new(line), area);
}

/// What drawing a face box takes, over the status line: the keys bound to move, size,
/// confirm and cancel it (from the keymap, so they cannot drift), and the mouse.
pub fn draw_face_box_hint(app: &App, keymap: &Keymap, frame: &mut Frame, area: Rect) {
    if area.height == 0 {
        return;
    }
    let chain = mode_chain(app);
    let keys = |actions: &[Action]| {
        actions
            .iter()
            .filter_map(|a| keymap.key_for(&chain, a).map(|k| k.to_string()))
            .collect::<Vec<_>>()
            .join("/")
    };
    let moves = keys(&[
        Action::MoveFaceBox { dx: -1, dy: 0 },
        Action::MoveFaceBox { dx: 1, dy: 0 },
        Action::MoveFaceBox { dx: 0, dy: -1 },
        Action::MoveFaceBox { dx: 0, dy: 1 },
    ]);
    let sizes =
        keys(&[Action::ResizeFaceBox { percent: 10 }, Action::ResizeFaceBox { percent: -10 }]);
    let line = Line::from(vec![
        Span::from(format!("face box on frame {}: ", app.frame())).fg(Color::LightCyan),
        Span::from(format!(
            "brows to chin, ear to ear · drag with the mouse or {moves} move, {sizes} size · {} track from it · {} cancel",
            keys(&[Action::ConfirmFaceBox]),
            keys(&[Action::Cancel]),
        )),
    ]);
    frame.render_widget(Clear, area);
    frame.render_widget(Paragraph::new(line), area);
}
