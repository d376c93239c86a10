//! The analysis view: moving through the tables' rows, sorting, and opening a row's frame.

use super::global::go_to_frame;
use crate::tui::action::Action;
use crate::tui::app::{AnalysisView, App, View};
use crate::tui::views;

/// Applies an action of this file (routed here by `update`).
pub(super) fn update(app: &mut App, action: Action) {
    use Action as A;
    match action {
        A::RowDown | A::RowUp => {
            let n = app.analysis.tables.get(app.analysis_view.table).map_or(0, |t| t.rows.len());
            let r = &mut app.analysis_view.row;
            *r = if action == A::RowDown {
                (*r + 1).min(n.saturating_sub(1))
            } else {
                r.saturating_sub(1)
            };
        }
        A::NextTable => {
            let n = app.analysis.tables.len().max(1);
            app.analysis_view =
                AnalysisView { table: (app.analysis_view.table + 1) % n, ..Default::default() };
        }
        A::SortNextColumn => {
            let ncols = app
                .analysis
                .tables
                .get(app.analysis_view.table)
                .map_or(1, |t| t.columns.len().max(1));
            app.analysis_view.sort_column = (app.analysis_view.sort_column + 1) % ncols;
            app.analysis_view.row = 0;
        }
        A::SortReverse => {
            app.analysis_view.descending = !app.analysis_view.descending;
            app.analysis_view.row = 0;
        }
        A::OpenRow => {
            let frame = app.analysis.tables.get(app.analysis_view.table).and_then(|t| {
                let order = views::analysis::sorted_rows(t, &app.analysis_view);
                order.get(app.analysis_view.row).and_then(|&i| t.rows[i].frame)
            });
            match frame {
                Some(f) => {
                    go_to_frame(app, f);
                    app.view = View::Frames;
                }
                None => app.status = "this row has no frame".into(),
            }
        }
        _ => {}
    }
}
