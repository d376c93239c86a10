//! The speech model a session names (`Session::speech_model`): recorded by `speech train` in
//! the sessions it trained on and by `speech eval` in the session it scored; the TUI drives a
//! clip's head from its audio with it for the analysis charts.
//!
//! Start at [`record_speech_model`] and [`drive_clip_with_session_model`].

use super::error::{Error, Result, Warning, error_chain, no_progress};
use super::resources::Resources;
use super::session::open_for_edit;
use super::speech::{drive_clip, load_speech_model};
use crate::eval::Utterance;
use crate::session::Session;
use std::path::Path;

/// Records `model` as the speech model of every session in `sessions` and saves each. A
/// session that cannot take it (open in another editor, unwritable) keeps what it named and
/// is reported in a warning: training has succeeded by then and must not fail for it.
pub fn record_speech_model(sessions: &[String], model: &Path) -> Vec<Warning> {
    let model = crate::session::absolute(model);
    sessions
        .iter()
        .filter_map(|s| {
            let recorded = open_for_edit(s).and_then(|mut e| {
                e.session.speech_model = Some(model.clone());
                e.save()
            });
            recorded.err().map(|e| {
                Warning(format!(
                    "lipmap: warning: {s}: the speech model was not recorded in the session: {}",
                    error_chain(&e)
                ))
            })
        })
        .collect()
}

/// Drives clip `clip`'s head from its audio with the session's speech model and returns the
/// utterance whose head is the AV-HMM-driven one (the video side as measured), for the TUI's
/// charts. Fits missing from the cache are made in `session` (the caller's copy).
///
/// # Errors
/// One line saying why there is no speech-driven head: the clip has no audio; the session
/// names no speech model; the model file cannot be read, or was trained on other features
/// or another morphable model; the clip has no good fit; the fit's or the inversion's error.
pub fn drive_clip_with_session_model(session: &mut Session, clip: usize) -> Result<Utterance> {
    if session.clip(clip)?.audio.is_none() {
        return Err(Error::Invalid("the clip has no audio".into()));
    }
    let path = session.speech_model.clone().ok_or_else(|| {
        Error::Invalid(
            "the session names no speech model (`lipmap speech train SESSION --out MODEL` \
             records one)"
                .into(),
        )
    })?;
    let model = load_speech_model(&path)?;
    let res = Resources::load(session)?;
    let mut warnings = Vec::new();
    match drive_clip(&model, session, &res, clip, &no_progress, &mut warnings)? {
        Some(driven) => Ok(driven.utterance_hmm),
        None => Err(Error::Invalid(warnings.first().map_or_else(
            || "the clip gives no speech-driven head".into(),
            |w| w.0.strip_prefix("lipmap: warning: ").unwrap_or(&w.0).to_string(),
        ))),
    }
}
