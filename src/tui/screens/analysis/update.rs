//! The analysis view: moving through the tables' rows, sorting, opening a row's frame, and
//! the tables' arrival from the analysis job, the quality cross-validation, and the charts'
//! speech-driven series (its arrival, or why there is none, and its toggle).

use crate::tui::action::Action;
use crate::tui::app::{App, Effect};
use crate::tui::screens::View;
use crate::tui::screens::analysis::{AnalysisData, AnalysisTable, AnalysisView, SpeechSeries};

/// Queues a fresh analysis of the clip (when there are fits to analyse, with a model and a
/// map); replies to older requests are dropped.
pub fn request_analysis(app: &mut App) {
    if !app.fits.by_frame.is_empty() && app.model.is_some() && app.fit_map().is_some() {
        app.analysis.generation += 1;
        app.effects.push(Effect::Analyse { generation: app.analysis.generation });
    }
}

pub fn row_down(app: &mut App) {
    let n = app.analysis.data.tables.get(app.analysis.cursor.table).map_or(0, |t| t.rows.len());
    let r = &mut app.analysis.cursor.row;
    *r = (*r + 1).min(n.saturating_sub(1));
}

pub fn row_up(app: &mut App) {
    app.analysis.cursor.row = app.analysis.cursor.row.saturating_sub(1);
}

pub fn next_table(app: &mut App) {
    let n = app.analysis.data.tables.len().max(1);
    app.analysis.cursor =
        AnalysisView { table: (app.analysis.cursor.table + 1) % n, ..Default::default() };
}

pub fn sort_next_column(app: &mut App) {
    let ncols = app
        .analysis
        .data
        .tables
        .get(app.analysis.cursor.table)
        .map_or(1, |t| t.columns.len().max(1));
    app.analysis.cursor.sort_column = (app.analysis.cursor.sort_column + 1) % ncols;
    app.analysis.cursor.row = 0;
}

pub fn sort_reverse(app: &mut App) {
    app.analysis.cursor.descending = !app.analysis.cursor.descending;
    app.analysis.cursor.row = 0;
}

/// Opens the selected row (in the order shown): its frame in the frames view, or its
/// sentence's clip (saving first, as the next-clip key does).
pub fn open_row(app: &mut App) -> Option<Action> {
    let row = app.analysis.data.tables.get(app.analysis.cursor.table).and_then(|t| {
        let order = super::view::sorted_rows(t, &app.analysis.cursor);
        order.get(app.analysis.cursor.row).map(|&i| &t.rows[i])
    });
    match row.map(|r| (r.frame, r.clip)) {
        Some((_, Some(clip))) if clip != app.clip => return Some(Action::SwitchClip { clip }),
        Some((_, Some(_))) => app.status = "that sentence is the open clip".into(),
        Some((Some(frame), None)) => {
            app.view = View::Frames;
            return Some(Action::GoToFrame { frame });
        }
        _ => app.status = "this row has no frame".into(),
    }
    None
}

/// Starts the quality cross-validation on a job, unless one is running.
pub fn assess_quality(app: &mut App) {
    if app.analysis.quality_running {
        app.status = "the quality cross-validation is already running".into();
        return;
    }
    app.analysis.quality_running = true;
    app.status = "cross-validating quality prediction over the session's sentences…".into();
    app.effects.push(Effect::AssessQuality);
}

/// The quality tables replace the previous ones after the clip's own, and are shown.
pub fn quality_ready(app: &mut App, tables: Vec<AnalysisTable>, summary: String) {
    app.analysis.quality_running = false;
    let own = app.analysis.data.tables.len()
        - app.analysis.quality.len().min(app.analysis.data.tables.len());
    app.analysis.data.tables.truncate(own);
    app.analysis.data.tables.extend(tables.iter().cloned());
    app.analysis.quality = tables;
    // Show the held-out sentences.
    app.analysis.cursor = AnalysisView { table: own, ..Default::default() };
    app.view = View::Analysis;
    app.status = summary;
}

pub fn quality_failed(app: &mut App, error: String) {
    app.analysis.quality_running = false;
    app.status = format!("no quality cross-validation: {error}");
}

pub fn toggle_speech(app: &mut App) {
    app.analysis.show_speech = !app.analysis.show_speech;
    app.status = match (&app.analysis.speech, app.analysis.show_speech) {
        (_, false) => "speech-driven head hidden".into(),
        (SpeechSeries::Ready(_), true) => "speech-driven head shown".into(),
        (SpeechSeries::Pending, true) => {
            "speech-driven head: still being driven from the clip's audio".into()
        }
        (SpeechSeries::Absent(why), true) => format!("no speech-driven head: {why}"),
    };
}

pub fn speech_ready(app: &mut App, series: Vec<(String, Vec<(f64, f64)>)>) {
    app.analysis.speech = SpeechSeries::Ready(series);
    if app.view == View::Analysis && app.analysis.show_speech {
        app.status = "speech-driven head ready".into();
    }
}

pub fn speech_absent(app: &mut App, why: String) {
    app.analysis.speech = SpeechSeries::Absent(why);
    if app.view == View::Analysis {
        app.status = speech_absent_reason(app).unwrap_or_default();
    }
}

/// The newest analysis' tables, with the quality tables kept after them; older replies are
/// dropped.
pub fn analysis_ready(app: &mut App, generation: u64, data: AnalysisData) {
    if generation != app.analysis.generation {
        return;
    }
    if let Some(w) = data.warnings.first() {
        app.status.clone_from(w);
    }
    let (own_before, own) = (
        app.analysis.data.tables.len().saturating_sub(app.analysis.quality.len()),
        data.tables.len(),
    );
    app.analysis.data = data;
    app.analysis.data.tables.extend(app.analysis.quality.iter().cloned());
    // Still where the previous clip left it (the user has not moved): keep the cursor on the
    // same quality table behind the new own tables.
    if let Some(v) = app.analysis.quality_cursor.take()
        && app.analysis.cursor.table == own_before + v.table
    {
        app.analysis.cursor.table = own + v.table;
    }
    let n = app.analysis.data.tables.len().max(1);
    app.analysis.cursor.table = app.analysis.cursor.table.min(n - 1);
}

/// The status line's reason for the charts having no speech-driven series, when they have
/// none and it is not hidden on purpose.
pub(crate) fn speech_absent_reason(app: &App) -> Option<String> {
    match &app.analysis.speech {
        SpeechSeries::Absent(why) if app.analysis.show_speech => {
            Some(format!("no speech-driven head: {why}"))
        }
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use crate::tui::action::Action;
    use crate::tui::app::Effect;
    use crate::tui::fixtures::{synthetic_analysis, synthetic_app};
    use crate::tui::screens::View;
    use crate::tui::screens::analysis::{AnalysisData, AnalysisRow, AnalysisTable, SpeechSeries};
    use crate::tui::update::apply;

    fn table(title: &str, rows: &[(&str, Option<usize>)]) -> AnalysisTable {
        AnalysisTable {
            title: title.into(),
            columns: vec!["sentence".into(), "error".into()],
            rows: rows
                .iter()
                .enumerate()
                .map(|(i, (name, clip))| AnalysisRow {
                    clip: *clip,
                    ..AnalysisRow::numbers(name, &[i as f64], None)
                })
                .collect(),
        }
    }

    #[test]
    fn quality_tables_follow_the_clips_own_and_enter_opens_the_sentence() {
        let mut app = synthetic_app(10, 320, 240, true);
        app.clip_names = vec!["s1".into(), "s2".into(), "s3".into()];
        apply(&mut app, Action::AssessQuality);
        assert_eq!(app.effects, vec![Effect::AssessQuality]);
        apply(&mut app, Action::AssessQuality);
        assert_eq!(app.effects.len(), 1, "a second run while one runs");
        let own = AnalysisData { tables: vec![table("phonemes", &[])], ..Default::default() };
        app.analysis.data = own.clone();
        let held = table("held out", &[("s1", Some(0)), ("s3", Some(2))]);
        let synths = table("synthesizers", &[("trajectory", None)]);
        apply(
            &mut app,
            Action::QualityReady {
                tables: vec![held.clone(), synths.clone()],
                summary: "q".into(),
            },
        );
        assert_eq!(app.view, View::Analysis);
        assert_eq!(
            app.analysis.data.tables,
            vec![own.tables[0].clone(), held.clone(), synths.clone()]
        );
        assert_eq!(app.analysis.cursor.table, 1, "the held-out sentences are shown");
        // The clip's own tables are recomputed; the quality tables stay after them.
        let generation = app.analysis.generation;
        apply(&mut app, Action::AnalysisReady { generation, data: own.clone() });
        assert_eq!(app.analysis.data.tables.len(), 3);
        assert_eq!(app.analysis.data.tables[1], held);
        // A second result replaces the first rather than adding to it.
        apply(&mut app, Action::QualityReady { tables: vec![held], summary: "q".into() });
        assert_eq!(app.analysis.data.tables.len(), 2);
        // Enter on the open clip's sentence says so; on another, that clip is opened.
        apply(&mut app, Action::OpenRow);
        assert_eq!(app.status, "that sentence is the open clip");
        assert_eq!(app.switch_clip, None);
        apply(&mut app, Action::RowDown);
        apply(&mut app, Action::OpenRow);
        assert_eq!(app.switch_clip, Some(2));
        // The next clip opens with the quality tables and the cursor where it was, once its
        // own tables arrive in front of them too.
        let mut next = synthetic_app(10, 320, 240, true);
        next.clip = 2;
        let own_at_start = next.analysis.data.tables.len();
        let from = Box::new(crate::tui::global::Carried::of(&app, "s3"));
        apply(&mut next, Action::Carry { from });
        assert_eq!(next.analysis.data.tables.len(), own_at_start + 1);
        assert_eq!(next.analysis.cursor.table, own_at_start);
        let generation = next.analysis.generation;
        let two = AnalysisData {
            tables: vec![table("phonemes", &[]), table("visemes", &[])],
            ..Default::default()
        };
        apply(&mut next, Action::AnalysisReady { generation, data: two });
        assert_eq!(next.analysis.data.tables.len(), 3);
        assert_eq!((next.analysis.cursor.table, next.analysis.cursor.row), (2, 1));
        apply(&mut app, Action::QualityFailed { error: "no clip has an alignment".into() });
        assert!(app.status.contains("no clip has an alignment"), "{}", app.status);
        assert!(!app.analysis.quality_running);
    }

    #[test]
    fn the_status_line_says_why_there_is_no_speech_series() {
        let mut app = synthetic_app(10, 320, 240, true);
        apply(&mut app, Action::SpeechAbsent { why: "the clip has no audio".into() });
        // Not in the analysis view: nothing said yet; on entering it, the reason.
        assert!(app.status.is_empty(), "{}", app.status);
        apply(&mut app, Action::ShowAnalysis);
        assert_eq!(app.status, "no speech-driven head: the clip has no audio");
        apply(&mut app, Action::ToggleSpeech);
        assert_eq!(app.status, "speech-driven head hidden");
        apply(&mut app, Action::ToggleSpeech);
        assert_eq!(app.status, "no speech-driven head: the clip has no audio");
        let series = vec![("W".to_string(), vec![(0.0, 0.5), (1.0, 0.7)])];
        apply(&mut app, Action::SpeechReady { series });
        assert_eq!(app.view, View::Analysis);
        assert_eq!(app.status, "speech-driven head ready");
        assert_eq!(app.analysis.speech.of("W"), Some(&[(0.0, 0.5), (1.0, 0.7)][..]));
        assert!(app.analysis.speech.of("H").is_none());
        assert!(!matches!(app.analysis.speech, SpeechSeries::Absent(_)));
    }

    #[test]
    fn an_analysis_warning_reaches_the_status_line() {
        let mut app = synthetic_app(10, 320, 240, true);
        let mut data = synthetic_analysis(10);
        data.warnings.push("warning: the model's upper-lip region: no lip band".into());
        let generation = app.analysis.generation;
        apply(&mut app, Action::AnalysisReady { generation, data });
        assert_eq!(app.status, "warning: the model's upper-lip region: no lip band");
    }
}
