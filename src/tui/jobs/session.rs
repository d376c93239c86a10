//! Jobs over the whole session (a copy of it, on a thread of their own): the speech-driven
//! head of a clip and the quality cross-validation over every sentence.

use super::analysis::{frame_points, table_for_tui};
use crate::tui::action::Action;

/// Drives clip `clip`'s head from its audio with the session's speech model (the one call
/// into `workflow::speech_session`) and replies with its series, min–max normalised as the
/// analysis' trajectories are, or with why there are none. `session` is the job's copy:
/// fits its cache lacks are made in it.
pub fn speech_for_tui(session: &mut crate::session::Session, clip: usize) -> Action {
    use crate::measure::Measure;
    match crate::workflow::speech_session::drive_clip_with_session_model(session, clip) {
        Ok(u) => {
            let normalised = u.min_max_normalised();
            let series = Measure::ALL
                .into_iter()
                .map(|m| (m.as_str().to_string(), frame_points(normalised.head.series(m))))
                .filter(|(_, pts)| !pts.is_empty())
                .collect();
            Action::SpeechReady { series }
        }
        Err(e) => Action::SpeechAbsent { why: crate::workflow::error_chain(&e) },
    }
}

/// Cross-validates quality prediction (SAQP) over the sentences of `session` (the job's
/// copy, at `path`; fits its cache lacks are made in it) with the default settings, as
/// `lipmap saqp cv` does, and replies with the held-out sentences (each opening its clip)
/// and the per-synthesizer table, or with why there are none.
pub fn quality_for_tui(session: &mut crate::session::Session, path: &std::path::Path) -> Action {
    use crate::workflow::saqp::{
        SaqpSettings, cross_validate_corpus, held_out_table, open_session_corpus, synths_table,
    };
    let settings = SaqpSettings::default();
    let result = open_session_corpus(session, path, &settings.corpus, &|_| {}).and_then(|sc| {
        let clips: Vec<(String, usize)> = sc
            .corpus
            .sentences
            .iter()
            .zip(&sc.origins)
            .map(|(s, o)| (s.name.clone(), o.clip))
            .collect();
        let (frames, bridged) = (sc.frames, sc.bridged);
        cross_validate_corpus(sc, &settings).map(|cv| (cv, clips, frames, bridged))
    });
    let (cv, clips, frames, bridged) = match result {
        Ok(r) => r,
        Err(e) => return Action::QualityFailed { error: crate::workflow::error_chain(&e) },
    };
    let no_frame = |_: &str| None;
    let mut held = table_for_tui(&held_out_table(&cv.report), &no_frame, false);
    for row in &mut held.rows {
        let name = row.cells.first().map(String::as_str).unwrap_or_default();
        row.clip = clips.iter().find(|(n, _)| n == name).map(|(_, c)| *c);
    }
    let synths = table_for_tui(&synths_table(&cv.report), &no_frame, false);
    let best = cv.report.synths.iter().max_by(|a, b| a.pearson_r.total_cmp(&b.pearson_r));
    let summary = format!(
        "quality over {} sentences ({frames} frames, {bridged} bridged){}; Enter opens a sentence",
        cv.sentences,
        best.map_or(String::new(), |s| format!(
            ": best {} r {:.2}, RMSE {:.2} × a constant's ({})",
            s.synth.name(),
            s.pearson_r,
            s.rmse / s.rmse_constant,
            s.kept_skill().verdict().as_str()
        ))
    );
    Action::QualityReady { tables: vec![held, synths], summary }
}
