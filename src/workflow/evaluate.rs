//! Evaluating a session: each clip's fits (cached) turned into an utterance (the video's and
//! the fitted head's W/H/P with the phone alignment), then the RMSE tables and worst frames.

use super::error::{Result, Warning, error_chain};
use super::fit::fit_clip_cached;
use super::measure_fits::head_trajectory;
use super::resources::Resources;
use super::side_view::{HeadP, head_p_of_clip_by_render, head_p_options, side_view_protrusion};
use super::{Progress, ProgressFn};
use crate::eval::report::{group_table, sentence_table, worst_error_table, worst_fit_table};
use crate::eval::{Table, Utterance, phoneme_rmse, viseme_rmse};
use crate::eval::{worst_frames_by_error, worst_frames_by_residual};
use crate::fit::{FitSettings, FrameFit};
use crate::landmarks::closure::{ClosureError, seal_inner_lips};
use crate::measure::mouth::trajectory_from_track;
use crate::measure::{Measure, MeshMeasureOptions, Trajectory};
use crate::model::{LandmarkMap, MorphableModel};
use crate::session::Session;

/// The evaluation input of one clip's parts: the video's W/H from `track` and the fitted
/// head's W/H/P from its fits (measured through `map` with its mouth corners completed,
/// frame by frame without keeping meshes), both `n` frames long. Side-view P is the caller's
/// to add.
#[allow(clippy::too_many_arguments)]
pub fn utterance_from_parts(
    name: &str,
    alignment: &crate::alignment::Alignment,
    fps: f64,
    track: &crate::landmarks::Track,
    model: &MorphableModel,
    map: &LandmarkMap,
    fits: &[FrameFit],
    options: &MeshMeasureOptions,
) -> Utterance {
    let n = track.frames.last().map_or(0, |f| f.frame + 1);
    let video = trajectory_from_track(track, Some(n));
    let map = map.with_commissures_completed();
    let head = head_trajectory(model, &map, fits, n, options);
    Utterance {
        name: name.to_string(),
        speaker: None,
        alignment: alignment.clone(),
        fps,
        video: pad(video, n),
        head: pad(head, n),
    }
}

/// The evaluation input of one clip of a session: [`utterance_from_parts`] on its effective
/// landmarks, plus the side view's protrusion when the clip has one; and what was worked
/// around (a side view whose P cannot be measured, a model without a lip band).
///
/// Sealed lips are closed in the video's landmarks as the session's fit settings say
/// (`landmarks::closure`), as they were for the fits.
///
/// A side view sees the whole upper lip, so for a clip with one the head's P is measured the
/// same way ([`head_p_options`]). Other upper-lip choices in `options` are kept as given.
///
/// # Errors
/// Unknown clip.
pub fn utterance_of_clip(
    session: &Session,
    res: &Resources,
    clip: usize,
    fits: &[FrameFit],
    options: &MeshMeasureOptions,
) -> Result<(Utterance, Vec<Warning>)> {
    let c = session.clip(clip)?;
    let mut track = session.effective_track(clip)?;
    let (options, warning) = head_p_options(&res.model, &res.map, c.side.is_some(), options);
    let mut warnings: Vec<Warning> = warning.into_iter().collect();
    // The video is measured on the landmarks the fits were made from. A clip too short to
    // have a sealed mode (a photo, a few frames) is not speech, and one without a separate
    // cluster of low gaps needs no correction; only a speech-length clip whose gap never
    // varies is worth a warning.
    match seal_inner_lips(&mut track, session.fit_settings.closure) {
        Ok(_) | Err(ClosureError::TooFewFrames(_) | ClosureError::NoSealedMode(_)) => {}
        Err(e) => {
            warnings.push(Warning(format!("lipmap: clip `{}`: inner lips as tracked: {e}", c.name)))
        }
    }
    let mut u = utterance_from_parts(
        &c.name,
        &c.alignment.clone().unwrap_or_default(),
        c.front.fps,
        &track,
        &res.model,
        &res.map,
        fits,
        &options,
    );
    match side_view_protrusion(session, clip, u.video.len()) {
        Ok(Some(p)) => u.video.p = p,
        Ok(None) => {}
        // The front-view tables are still worth having; say why P is missing.
        Err(e) => warnings.push(Warning(format!(
            "lipmap: clip `{}`: no side-view protrusion: {}",
            c.name,
            error_chain(&e)
        ))),
    }
    Ok((u, warnings))
}

fn pad(mut t: Trajectory, n: usize) -> Trajectory {
    for m in Measure::ALL {
        t.series_mut(m).resize(n, None);
    }
    t
}

/// Each clip's name and fits, in clip order.
pub type NamedFits = Vec<(String, Vec<FrameFit>)>;

/// The selected clips of a session, fitted and measured.
#[derive(Clone, Debug, Default)]
pub struct ClipsEvaluated {
    pub utterances: Vec<Utterance>,
    pub fits: NamedFits,
    pub warnings: Vec<Warning>,
}

impl ClipsEvaluated {
    /// The fits as the evaluation takes them.
    pub fn fit_refs(&self) -> Vec<(&str, &[FrameFit])> {
        self.fits.iter().map(|(n, f)| (n.as_str(), f.as_slice())).collect()
    }
}

/// Fits (from cache where valid) and measures the clips `clips` of a session with
/// `settings`, clip by clip; the head's P as `head_p` says. Progress: one stage per clip.
///
/// # Errors
/// As [`fit_clip_cached`] and [`utterance_of_clip`]; a render failure with `HeadP::Render`.
pub fn utterances_with(
    session: &mut Session,
    res: &Resources,
    clips: &[usize],
    settings: &FitSettings,
    head_p: HeadP,
    progress: ProgressFn<'_>,
) -> Result<ClipsEvaluated> {
    let mut out = ClipsEvaluated::default();
    for &c in clips {
        let name = session.clip(c)?.name.clone();
        progress(Progress::Stage { what: format!("fitting {name} ({})", settings.set), total: 0 });
        let steps = |done: usize, total: usize| progress(Progress::Steps { done, total });
        let clip_fits = fit_clip_cached(session, res, c, settings, Some(&steps))?;
        let (mut u, warnings) =
            utterance_of_clip(session, res, c, &clip_fits.fits, &MeshMeasureOptions::default())?;
        out.warnings.extend(warnings);
        if let HeadP::Render { pitch_deg } = head_p {
            progress(Progress::Stage { what: format!("rendering {name} from the side"), total: 0 });
            let n = u.head.p.len();
            u.head.p = head_p_of_clip_by_render(session, res, c, &clip_fits.fits, n, pitch_deg)?.p;
        }
        out.utterances.push(u);
        out.fits.push((name, clip_fits.fits));
    }
    progress(Progress::Finished);
    Ok(out)
}

/// How video and head trajectories are compared.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize)]
pub enum Normalisation {
    /// Min–max per sequence, video and head separately (the published method: shapes of
    /// trajectories, so a head of other proportions can still be judged).
    #[default]
    MinMax,
    /// The reference-length ratios as they are (same-person heads, known truth).
    None,
}

impl Normalisation {
    /// `utterances` on the scale they are compared on.
    pub fn apply(self, utterances: &[Utterance]) -> Vec<Utterance> {
        match self {
            Normalisation::MinMax => utterances.iter().map(Utterance::min_max_normalised).collect(),
            Normalisation::None => utterances.to_vec(),
        }
    }
}

/// The tables of an evaluation.
#[derive(Clone, Debug)]
pub struct EvalReport {
    pub sentences: Table,
    pub phonemes: Table,
    pub visemes: Table,
    pub worst_frames: Table,
    pub worst_fits: Table,
}

impl EvalReport {
    pub fn tables(&self) -> [&Table; 5] {
        [&self.sentences, &self.phonemes, &self.visemes, &self.worst_frames, &self.worst_fits]
    }
}

/// Per-sentence, per-phoneme and per-viseme RMSE tables, and the worst frames by measure
/// error (W, H, P pooled) and by fit residual.
pub fn evaluate(
    utterances: &[Utterance],
    fits: &[(&str, &[FrameFit])],
    normalisation: Normalisation,
    n_worst: usize,
) -> EvalReport {
    let compared = normalisation.apply(utterances);
    let visemes = &crate::reference::current().visemes;
    let mut worst: Vec<_> =
        Measure::ALL.iter().flat_map(|&m| worst_frames_by_error(&compared, m, n_worst)).collect();
    worst.sort_by(|a, b| b.error.abs().total_cmp(&a.error.abs()));
    worst.truncate(n_worst);
    EvalReport {
        sentences: sentence_table(&compared).keyed("sentences"),
        phonemes: group_table("RMSE per phoneme", &phoneme_rmse(&compared), None).keyed("phonemes"),
        visemes: group_table(
            "RMSE per viseme class",
            &viseme_rmse(&compared, visemes),
            Some(visemes),
        )
        .keyed("visemes"),
        worst_frames: worst_error_table(&worst).keyed("worst_frames"),
        worst_fits: worst_fit_table(&worst_frames_by_residual(fits, n_worst)).keyed("worst_fits"),
    }
}
