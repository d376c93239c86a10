//! Analysis view: the selected error table (sortable by any column; Enter opens a row's frame)
//! over the W/H/P trajectories of video vs 3D (and vs the head driven from the clip's audio,
//! when the session names a speech model), with phoneme boundaries and labels.
//!
//! `sorted_rows` is shared with `update` so Enter opens the row the user sees.

use crate::tui::app::App;

use crate::tui::screens::analysis::{AnalysisTable, AnalysisView};
use ratatui::Frame;
use ratatui::layout::{Constraint, Rect};
use ratatui::style::{Color, Modifier, Style, Stylize};
use ratatui::text::Line;
use ratatui::widgets::canvas::{Canvas, Line as CLine};
use ratatui::widgets::{Block, Cell, Paragraph, Row, Table, TableState};

/// Row indices of `table` in display order for the view's sort column and direction.
pub fn sorted_rows(table: &AnalysisTable, view: &AnalysisView) -> Vec<usize> {
    let mut order: Vec<usize> = (0..table.rows.len()).collect();
    let col = view.sort_column;
    // A summary row (`mean`) stays at the bottom whatever the order.
    let summary = |r: &crate::tui::screens::analysis::AnalysisRow| {
        r.cells.first().is_some_and(|c| c == "mean")
    };
    order.sort_by(|&a, &b| {
        let (ra, rb) = (&table.rows[a], &table.rows[b]);
        if summary(ra) != summary(rb) {
            return summary(ra).cmp(&summary(rb));
        }
        let key =
            |r: &crate::tui::screens::analysis::AnalysisRow| r.keys.get(col).copied().flatten();
        let o = match (key(ra), key(rb)) {
            (Some(x), Some(y)) => x.total_cmp(&y),
            // Blank values sort last either way.
            (Some(_), None) => std::cmp::Ordering::Less,
            (None, Some(_)) => std::cmp::Ordering::Greater,
            (None, None) => ra.cells.get(col).cmp(&rb.cells.get(col)),
        };
        if view.descending { o.reverse() } else { o }
    });
    order
}

pub fn draw(app: &App, frame: &mut Frame, area: Rect) {
    let Some(table) = app.analysis.data.tables.get(app.analysis.cursor.table) else {
        frame.render_widget(
            Paragraph::new(vec![
                Line::from("No analysis yet.").bold(),
                Line::from(
                    "Fit the clip (f) and the per-phoneme and per-sentence tables appear here.",
                ),
            ])
            .fg(Color::Gray),
            area,
        );
        return;
    };
    let chart_h = if app.analysis.data.trajectories.is_empty() { 0 } else { area.height * 2 / 5 };
    let table_area = Rect::new(area.x, area.y, area.width, area.height - chart_h);
    draw_table(app, table, frame, table_area);
    if chart_h >= 4 {
        let n = app.analysis.data.trajectories.len() as u16;
        let w = area.width / n.max(1);
        for (k, t) in app.analysis.data.trajectories.iter().enumerate() {
            let x = area.x + w * k as u16;
            let width = if k as u16 + 1 == n { area.width - w * (n - 1) } else { w };
            draw_trajectory(
                app,
                t,
                frame,
                Rect::new(x, area.y + area.height - chart_h, width, chart_h),
            );
        }
    }
}

fn draw_table(app: &App, table: &AnalysisTable, frame: &mut Frame, area: Rect) {
    let view = &app.analysis.cursor;
    let order = sorted_rows(table, view);
    let arrow = if view.descending { "▼" } else { "▲" };
    let header: Vec<Cell> = table
        .columns
        .iter()
        .enumerate()
        .map(|(i, name)| {
            if i == view.sort_column {
                Cell::from(format!("{name}{arrow}"))
            } else {
                Cell::from(name.clone())
            }
        })
        .collect();
    let rows =
        order.iter().map(|&i| Row::new(table.rows[i].cells.iter().map(|c| Cell::from(c.clone()))));
    // Column widths from the content, the first (label) column taking what is left.
    let widths: Vec<Constraint> = (0..table.columns.len())
        .map(|c| {
            let w = table
                .rows
                .iter()
                .filter_map(|r| r.cells.get(c))
                .chain(std::iter::once(&table.columns[c]))
                .map(|s| s.chars().count() + 1)
                .max()
                .unwrap_or(4)
                // Labels (sentence names, index names) whole; numbers are short anyway.
                .min(if c == 0 { 40 } else { 24 }) as u16;
            // The sort arrow and a gap between columns.
            Constraint::Length(w + u16::from(c == 0) + 1)
        })
        .collect();
    let n_tables = app.analysis.data.tables.len();
    // The table's place first: a long title (it names what was compared) is cut at the end.
    let title = format!(" {}/{n_tables} {} ", view.table + 1, table.title);
    // Columns packed to the left: numbers next to their labels, the spare width at the end.
    let t = Table::new(rows, widths)
        .flex(ratatui::layout::Flex::Start)
        .header(Row::new(header).style(Style::new().bold().fg(Color::LightCyan)))
        .row_highlight_style(Style::new().add_modifier(Modifier::REVERSED))
        .block(Block::bordered().title(title).border_style(Color::DarkGray));
    let mut state =
        TableState::default().with_selected(Some(view.row.min(order.len().saturating_sub(1))));
    frame.render_stateful_widget(t, area, &mut state);
    if table.rows.is_empty() && area.height > 4 && area.width > 4 {
        let note = if table.title.contains("phoneme") || table.title.contains("viseme") {
            "no rows: the clip has no phone alignment (lipmap import --alignment)"
        } else {
            "no rows"
        };
        let r = Rect::new(area.x + 2, area.y + 3, area.width - 4, 1);
        frame.render_widget(Paragraph::new(note).fg(Color::Gray), r);
    }
}

/// The speech-driven head's colour in the charts and their legend.
const SPEECH: Color = Color::LightGreen;

fn draw_trajectory(
    app: &App,
    t: &crate::tui::screens::analysis::Trajectory,
    frame: &mut Frame,
    area: Rect,
) {
    let speech: &[(f64, f64)] = if app.analysis.show_speech {
        app.analysis.speech.of(&t.name).unwrap_or_default()
    } else {
        &[]
    };
    let all = t.video.iter().chain(&t.model).chain(speech);
    let (mut x0, mut x1, mut y0, mut y1) =
        (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for &(x, y) in all.filter(|p| p.0.is_finite() && p.1.is_finite()) {
        (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
    }
    if !x0.is_finite() {
        return;
    }
    let pad = ((y1 - y0) * 0.1).max(1e-6);
    let (y0, y1) = (y0 - pad, y1 + pad);
    let x1 = x1.max(x0 + 1.0);
    let phones: Vec<(f64, f64, String)> = app
        .alignment
        .as_ref()
        .map(|a| {
            a.phones.iter().map(|p| (p.start * app.fps, p.end * app.fps, p.label.clone())).collect()
        })
        .unwrap_or_default();
    let cur = app.frame() as f64;
    let labels = fitting_phone_labels(&phones, (x0, x1), area.width.saturating_sub(2));
    let mut legend = vec![
        format!(" {} ", t.name).bold(),
        "video".fg(Color::LightCyan),
        " vs ".into(),
        "3D ".fg(Color::LightMagenta),
    ];
    if !speech.is_empty() {
        legend.extend(["vs ".into(), "speech ".fg(SPEECH)]);
    }
    let title = Line::from(legend);
    let canvas = Canvas::default()
        .block(Block::bordered().title(title).border_style(Color::DarkGray))
        .marker(ratatui::symbols::Marker::Braille)
        .x_bounds([x0, x1])
        .y_bounds([y0, y1])
        .paint(|ctx| {
            for (s, _, _) in &phones {
                if *s >= x0 && *s <= x1 {
                    ctx.draw(&CLine { x1: *s, y1: y0, x2: *s, y2: y1, color: Color::DarkGray });
                }
            }
            for (s, label) in &labels {
                ctx.print(*s, y1, Line::from(label.clone()).fg(Color::Gray));
            }
            for w in t.video.windows(2) {
                ctx.draw(&CLine {
                    x1: w[0].0,
                    y1: w[0].1,
                    x2: w[1].0,
                    y2: w[1].1,
                    color: Color::LightCyan,
                });
            }
            for (series, color) in [(t.model.as_slice(), Color::LightMagenta), (speech, SPEECH)] {
                for w in series.windows(2) {
                    ctx.draw(&CLine { x1: w[0].0, y1: w[0].1, x2: w[1].0, y2: w[1].1, color });
                }
            }
            ctx.draw(&CLine { x1: cur, y1: y0, x2: cur, y2: y1, color: Color::Yellow });
        });
    frame.render_widget(canvas, area);
}

/// The phone labels a chart `cols` columns wide over frames `x0..x1` can show without one
/// running into the next: each at its phone's start, whole if it fits before the next
/// phone's start (with a column between), else without its stress digit, else left out
/// (the boundary line still marks the phone).
fn fitting_phone_labels(
    phones: &[(f64, f64, String)],
    (x0, x1): (f64, f64),
    cols: u16,
) -> Vec<(f64, String)> {
    let span = (x1 - x0).max(f64::EPSILON);
    let col = |x: f64| ((x - x0) / span * f64::from(cols.saturating_sub(1))).round() as i64;
    let shown: Vec<&(f64, f64, String)> =
        phones.iter().filter(|(s, _, _)| *s >= x0 && *s <= x1).collect();
    let mut out = Vec::new();
    for (k, (s, _, label)) in shown.iter().enumerate() {
        let next = shown.get(k + 1).map_or(i64::from(cols) + 1, |n| col(n.0));
        let room = usize::try_from(next - col(*s) - 1).unwrap_or(0);
        let bare = label.trim_end_matches(|c: char| c.is_ascii_digit());
        let fits = [label.as_str(), bare]
            .into_iter()
            .find(|l| !l.is_empty() && ratatui::text::Span::raw(*l).width() <= room);
        if let Some(l) = fits {
            out.push((*s, l.to_string()));
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    fn phones(labels: &[&str], each: f64) -> Vec<(f64, f64, String)> {
        labels
            .iter()
            .enumerate()
            .map(|(k, l)| (k as f64 * each, (k + 1) as f64 * each, l.to_string()))
            .collect()
    }

    #[test]
    fn phone_labels_never_run_together() {
        let p = phones(&["sil", "P", "L", "EY1", "S", "R", "EH1", "D", "AE1", "T", "sil"], 6.0);
        for cols in [10u16, 24, 38, 78, 158] {
            let shown = fitting_phone_labels(&p, (0.0, 66.0), cols);
            let col = |x: f64| (x / 66.0 * f64::from(cols - 1)).round() as usize;
            for w in shown.windows(2) {
                let end = col(w[0].0) + w[0].1.chars().count();
                assert!(end < col(w[1].0), "{cols}: {shown:?}");
            }
            assert!(shown.iter().all(|(_, l)| p.iter().any(|q| q.2.starts_with(l.as_str()))));
        }
        let wide = fitting_phone_labels(&p, (0.0, 66.0), 158);
        assert_eq!(wide.len(), p.len(), "every label whole at 160 columns");
        assert!(wide.iter().any(|(_, l)| l == "EY1"));
        let narrow = fitting_phone_labels(&p, (0.0, 66.0), 24);
        assert!(narrow.iter().any(|(_, l)| l == "P") && narrow.len() < p.len());
    }
}
