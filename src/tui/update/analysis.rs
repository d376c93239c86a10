//! The analysis view: moving through the tables' rows, sorting, opening a row's frame, and
//! the charts' speech-driven series (its arrival, or why there is none, and its toggle).

use super::global::go_to_frame;
use crate::tui::action::Action;
use crate::tui::app::{AnalysisView, App, SpeechSeries, View};
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
        A::ToggleSpeech => {
            app.show_speech = !app.show_speech;
            app.status = match (&app.speech, app.show_speech) {
                (_, false) => "speech-driven head hidden".into(),
                (SpeechSeries::Ready(_), true) => "speech-driven head shown".into(),
                (SpeechSeries::Pending, true) => {
                    "speech-driven head: still being driven from the clip's audio".into()
                }
                (SpeechSeries::Absent(why), true) => format!("no speech-driven head: {why}"),
            };
        }
        A::SpeechReady { series } => {
            app.speech = SpeechSeries::Ready(series);
            if app.view == View::Analysis && app.show_speech {
                app.status = "speech-driven head ready".into();
            }
        }
        A::SpeechAbsent { why } => {
            app.speech = SpeechSeries::Absent(why);
            if app.view == View::Analysis {
                app.status = speech_absent(app).unwrap_or_default();
            }
        }
        _ => {}
    }
}

/// The status line's reason for the charts having no speech-driven series, when they have
/// none and it is not hidden on purpose.
pub(super) fn speech_absent(app: &App) -> Option<String> {
    match &app.speech {
        SpeechSeries::Absent(why) if app.show_speech => {
            Some(format!("no speech-driven head: {why}"))
        }
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use crate::tui::action::Action;
    use crate::tui::app::{SpeechSeries, View};
    use crate::tui::fixtures::synthetic_app;
    use crate::tui::update::update;

    #[test]
    fn the_status_line_says_why_there_is_no_speech_series() {
        let mut app = synthetic_app(10, 320, 240, true);
        update(&mut app, Action::SpeechAbsent { why: "the clip has no audio".into() });
        // Not in the analysis view: nothing said yet; on entering it, the reason.
        assert!(app.status.is_empty(), "{}", app.status);
        update(&mut app, Action::ShowAnalysis);
        assert_eq!(app.status, "no speech-driven head: the clip has no audio");
        update(&mut app, Action::ToggleSpeech);
        assert_eq!(app.status, "speech-driven head hidden");
        update(&mut app, Action::ToggleSpeech);
        assert_eq!(app.status, "no speech-driven head: the clip has no audio");
        let series = vec![("W".to_string(), vec![(0.0, 0.5), (1.0, 0.7)])];
        update(&mut app, Action::SpeechReady { series });
        assert_eq!(app.view, View::Analysis);
        assert_eq!(app.status, "speech-driven head ready");
        assert_eq!(app.speech.of("W"), Some(&[(0.0, 0.5), (1.0, 0.7)][..]));
        assert!(app.speech.of("H").is_none());
        assert!(!matches!(app.speech, SpeechSeries::Absent(_)));
    }
}
