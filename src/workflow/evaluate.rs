//! Evaluating a session: each clip's fits (cached) turned into an utterance (the video's and
//! the fitted head's W/H/P with the phone alignment), then the RMSE tables and worst frames.
//!
//! Start with [`evaluate_session`] (`lipmap eval`, the demo) or [`evaluate_clip`] (the clip
//! open in the TUI); both measure through [`utterance_of`] and tabulate through
//! [`evaluate`]. [`compare_sets`] is `eval --compare`.

use super::error::{Error, Result, Warning, error_chain};
use super::fit::fit_clip_cached;
use super::flags::clip_flag_lines;
use super::measure_fits::head_trajectory;
use super::resources::{Resources, load_resources};
use super::session::{ReadSession, select_clips};
use super::side_view::{HeadP, head_p_of_clip_by_render, head_p_options, side_view_protrusion};
use super::{Progress, ProgressFn};
use crate::eval::report::{group_table, sentence_table_of, worst_error_table, worst_fit_table};
use crate::eval::seal::{LipSeal, lip_seal, seal_table};
use crate::eval::{Comparison, Configuration, RowKey, compare_configurations};
use crate::eval::{Table, Tally, Utterance};
use crate::fit::{FitSettings, FrameFit};
use crate::landmarks::closure::{ClosureError, seal_inner_lips};
use crate::measure::mouth::trajectory_from_track;
use crate::measure::{Measure, MeshMeasureOptions, PoseComparison, Trajectory};
use crate::model::{LandmarkMap, MorphableModel};
use crate::session::Session;

/// The evaluation input of one clip's parts: the video's W/H from `track` and the fitted
/// head's W/H/P from its fits (measured through `map` with its mouth corners completed,
/// frame by frame without keeping meshes), both `n` frames long, W and H compared as `pose`
/// says; and how many measured frames a frontal comparison left out because the head turned
/// past its limit. Side-view P is the caller's to add.
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
    pose: PoseComparison,
) -> (Utterance, usize) {
    let n = track.frames.last().map_or(0, |f| f.frame + 1);
    let mut video = pad(trajectory_from_track(track, Some(n)), n);
    let map = map.with_commissures_completed();
    let mut head = pad(head_trajectory(model, &map, fits, n, options, pose), n);
    let mut turned = 0;
    for f in fits.iter().filter(|f| f.is_usable_within(n) && !pose.admits(f.yaw, f.pitch)) {
        let measured = head.w[f.frame].is_some() || head.h[f.frame].is_some();
        turned += usize::from(measured);
        for t in [&mut video, &mut head] {
            t.w[f.frame] = None;
            t.h[f.frame] = None;
        }
    }
    let u = Utterance {
        name: name.to_string(),
        speaker: None,
        alignment: alignment.clone(),
        fps,
        video,
        head,
    };
    (u, turned)
}

/// One clip as an evaluation takes it, however the front holds it: the session's clip
/// (`eval`, `export`, the demo) or the clip open in the TUI with its unsaved edits.
#[derive(Clone, Copy, Debug)]
pub struct ClipInput<'a> {
    pub name: &'a str,
    pub alignment: &'a crate::alignment::Alignment,
    pub fps: f64,
    /// The landmarks the fits were made from (effective, inner lips sealed as the fit
    /// settings say).
    pub track: &'a crate::landmarks::Track,
    pub fits: &'a [FrameFit],
    /// Whether the clip has a side view: the head's P is then measured the way a profile
    /// shows it ([`head_p_options`]).
    pub side_view: bool,
    /// The side view's P per front frame, when measured.
    pub side_p: Option<&'a [Option<f64>]>,
    /// How W and H are compared under head pose.
    pub pose: PoseComparison,
    /// The landmark set the fits used, named in the tables (when the caller knows it).
    pub set: Option<crate::landmarks::LandmarkSet>,
}

/// The utterance of one clip: the video's and the fitted head's W/H/P
/// ([`utterance_from_parts`], the head's P as [`head_p_options`] says for a clip with a side
/// view), the side view's P as the video's; and what was worked around.
pub fn utterance_of(
    model: &MorphableModel,
    map: &LandmarkMap,
    input: &ClipInput<'_>,
    options: &MeshMeasureOptions,
) -> (Utterance, Vec<Warning>) {
    let (options, warning) = head_p_options(model, map, input.side_view, options);
    let mut warnings: Vec<Warning> = warning.into_iter().collect();
    let (mut u, turned) = utterance_from_parts(
        input.name,
        input.alignment,
        input.fps,
        input.track,
        model,
        map,
        input.fits,
        &options,
        input.pose,
    );
    if turned > 0 {
        warnings.push(Warning(format!(
            "lipmap: clip `{}`: {turned} of {} fitted frames turned past the pose limit (|yaw| or \
             |pitch| above {}°) and are left out of the frontal W/H comparison; \
             `lipmap eval --pose image-plane` compares every frame in the image plane",
            input.name,
            input.fits.iter().filter(|f| f.is_usable()).count(),
            match input.pose {
                PoseComparison::Frontal { limit_deg } => limit_deg,
                PoseComparison::ImagePlane => 0.0,
            }
        )));
    }
    warnings.extend(head_opening_limit(model, input.name, &u));
    warnings.extend(lip_seal_limit(model, map, input, &u));
    if let Some(p) = input.side_p {
        u.video.p = p.to_vec();
        u.video.p.resize(u.head.p.len(), None);
    }
    (u, warnings)
}

/// When the head does not open (its widest H below
/// [`crate::eval::seal::LEAST_OPENING_RATIO`] of the video's), a warning saying so and why
/// when the model says it (no expression blendshapes): its sealed-lips share is then a ratio
/// of two gaps it keeps closed, not a measure of sealing.
fn head_opening_limit(model: &MorphableModel, clip: &str, u: &Utterance) -> Option<Warning> {
    let seal = lip_seal(u).filter(|s| !s.head_opens())?;
    let why = if model.expressions.as_ref().is_none_or(|e| e.names.is_empty()) {
        "the model has no expression blendshapes and its identity components hardly part the \
         lips (give it expressions: `--blendshapes`)"
    } else {
        "the model's components hardly part its lips"
    };
    Some(Warning(format!(
        "lipmap: clip `{clip}`: the head does not open: its widest H is {:.3} against the \
         video's {:.3} ({:.0} %): {why}; its sealed-lips share ({:.0} % of its own widest \
         opening) measures no sealing",
        seal.head_widest,
        seal.video_widest,
        100.0 * seal.opening_ratio(),
        100.0 * seal.share(),
    )))
}

/// Share of the clip's widest fitted opening above which a head that cannot close further
/// is said to be held open by its model: the sealed-lips target (`docs/closure.md`).
const SEAL_SHARE: f64 = 0.1;

/// When the video's lips meet but the model cannot bring its inner lips within
/// [`SEAL_SHARE`] of the clip's widest fitted opening, a warning naming that limit: the
/// head's H error on those frames is the model's, not the fit's. The smallest frontal gap is
/// taken with the clip's fitted identity and β ≥ 0 when its fits share one identity (clip
/// mode); when each frame chose its own, with any plausible identity (within 99 % of the
/// model's prior, `measure::lip_reach`), since nothing else holds a frame's identity.
fn lip_seal_limit(
    model: &MorphableModel,
    map: &LandmarkMap,
    input: &ClipInput<'_>,
    u: &Utterance,
) -> Option<Warning> {
    let gap = crate::measure::lip_reach::InnerLipGap::of(model, map)?;
    let usable: Vec<&FrameFit> =
        input.fits.iter().filter(|f| f.is_usable_within(u.video.h.len())).collect();
    let identity = &usable.first()?.identity;
    let widest = usable.iter().map(|f| gap.length(&f.identity, &f.expression)).fold(0.0, f64::max);
    let meet = crate::landmarks::closure::meeting(&u.video.h);
    let sealed: Vec<&&FrameFit> = usable.iter().filter(|f| meet[f.frame]).collect();
    if sealed.is_empty() || widest <= 0.0 {
        return None;
    }
    let (reach, with) = if usable.iter().all(|f| &f.identity == identity) {
        (gap.smallest(identity)?.0, "the fitted identity")
    } else {
        (gap.smallest_plausible()?, "any identity within 99 % of the model's prior")
    };
    if reach <= SEAL_SHARE * widest {
        return None;
    }
    let mut kept: Vec<f64> =
        sealed.iter().map(|f| gap.length(&f.identity, &f.expression)).collect();
    kept.sort_by(f64::total_cmp);
    Some(Warning(format!(
        "lipmap: clip `{}`: the model cannot seal its lips: its smallest reachable inner-lip \
         gap with {with} is {reach:.3} ({:.0} % of the clip's widest fitted opening \
         {widest:.3}, model units, frontal); on the {} frames where the video's lips meet the \
         head keeps a median {:.3}, of which {reach:.3} is the model's limit, not fitting \
         error",
        input.name,
        100.0 * reach / widest,
        sealed.len(),
        kept[kept.len() / 2],
    )))
}

/// The evaluation input of one clip of a session: [`utterance_of`] its effective landmarks,
/// plus the side view's protrusion when the clip has one; and what was worked around (a side
/// view whose P cannot be measured, a model without a lip band).
///
/// Sealed lips are closed in the video's landmarks as the session's fit settings say
/// (`landmarks::closure`), as they were for the fits.
///
/// # Errors
/// Unknown clip.
pub fn utterance_of_clip(
    session: &Session,
    res: &Resources,
    clip: usize,
    fits: &[FrameFit],
    options: &MeshMeasureOptions,
    pose: PoseComparison,
) -> Result<(Utterance, Vec<Warning>)> {
    let c = session.clip(clip)?;
    let mut track = session.effective_track(clip)?;
    let mut warnings = Vec::new();
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
    let n = track.frames.last().map_or(0, |f| f.frame + 1);
    let side_p = match side_view_protrusion(session, clip, n) {
        Ok(p) => p,
        // The front-view tables are still worth having; say why P is missing.
        Err(e) => {
            warnings.push(Warning(format!(
                "lipmap: clip `{}`: no side-view protrusion: {}",
                c.name,
                error_chain(&e)
            )));
            None
        }
    };
    let alignment = c.alignment.clone().unwrap_or_default();
    let input = ClipInput {
        name: &c.name,
        alignment: &alignment,
        fps: c.front.fps,
        track: &track,
        fits,
        side_view: c.side.is_some(),
        side_p: side_p.as_deref(),
        pose,
        set: None,
    };
    let (u, more) = utterance_of(&res.model, &res.map, &input, options);
    warnings.splice(0..0, more);
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
    /// Frames fitted now (the rest came from the cache).
    pub refitted: usize,
}

impl ClipsEvaluated {
    /// The fits as the evaluation takes them.
    pub fn fit_refs(&self) -> Vec<(&str, &[FrameFit])> {
        self.fits.iter().map(|(n, f)| (n.as_str(), f.as_slice())).collect()
    }
}

/// Which clips of a session [`utterances_with`] fits and measures, and how: W and H compared
/// as `pose` says, the head's P as `head_p` says.
#[derive(Clone, Copy, Debug)]
pub struct ClipsToMeasure<'a> {
    /// Clip indices, in the order the results keep.
    pub clips: &'a [usize],
    pub head_p: HeadP,
    pub pose: PoseComparison,
}

/// Fits (from cache where valid) and measures the clips `which` names with `settings`, clip
/// by clip. Progress: one stage per clip.
///
/// # Errors
/// As [`fit_clip_cached`] and [`utterance_of_clip`]; a render failure with `HeadP::Render`.
pub fn utterances_with(
    session: &mut Session,
    res: &Resources,
    which: ClipsToMeasure<'_>,
    settings: &FitSettings,
    progress: ProgressFn<'_>,
) -> Result<ClipsEvaluated> {
    let ClipsToMeasure { clips, head_p, pose } = which;
    let mut out = ClipsEvaluated::default();
    let (warnings, refitted) = for_each_clip_evaluated(
        session,
        res,
        clips,
        &ClipRequest { settings, head_p, pose },
        progress,
        &mut |_, clip| {
            out.utterances.push(clip.utterance);
            out.fits.push((clip.name, clip.fits));
            Ok(())
        },
    )?;
    out.warnings = warnings;
    out.refitted = refitted;
    Ok(out)
}

/// How the clips of [`for_each_clip_evaluated`] are fitted and measured.
#[derive(Clone, Copy, Debug)]
pub struct ClipRequest<'a> {
    pub settings: &'a FitSettings,
    pub head_p: HeadP,
    pub pose: PoseComparison,
}

/// One clip fitted and measured.
#[derive(Clone, Debug)]
pub struct ClipEvaluated {
    /// Its index in the session.
    pub index: usize,
    pub name: String,
    pub utterance: Utterance,
    /// One fit per frame with landmarks, ascending.
    pub fits: Vec<FrameFit>,
}

/// Fits (from cache where valid) and measures the clips `clips` of a session one at a time,
/// handing each to `each` before the next is read: what a whole-corpus use case needs in
/// memory is one clip and what `each` keeps of it. Returns the warnings and how many frames
/// were fitted now. Progress: one stage per clip.
///
/// # Errors
/// As [`fit_clip_cached`] and [`utterance_of_clip`]; a render failure with `HeadP::Render`;
/// `each`'s error.
pub fn for_each_clip_evaluated(
    session: &mut Session,
    res: &Resources,
    clips: &[usize],
    req: &ClipRequest<'_>,
    progress: ProgressFn<'_>,
    each: &mut dyn FnMut(&Session, ClipEvaluated) -> Result<()>,
) -> Result<(Vec<Warning>, usize)> {
    let (mut warnings, mut refitted) = (Vec::new(), 0);
    let settings = req.settings;
    for &c in clips {
        let name = session.clip(c)?.name.clone();
        progress(Progress::Stage { what: format!("fitting {name} ({})", settings.set), total: 0 });
        let steps = |done: usize, total: usize| progress(Progress::Steps { done, total });
        let clip_fits = fit_clip_cached(session, res, c, settings, Some(&steps))?;
        warnings.extend(clip_fits.map_warning.clone());
        let options = MeshMeasureOptions::default();
        let (mut u, more) =
            utterance_of_clip(session, res, c, &clip_fits.fits, &options, req.pose)?;
        warnings.extend(more);
        if let HeadP::Render { pitch_deg } = req.head_p {
            progress(Progress::Stage { what: format!("rendering {name} from the side"), total: 0 });
            let n = u.head.p.len();
            u.head.p = head_p_of_clip_by_render(session, res, c, &clip_fits.fits, n, pitch_deg)?.p;
        }
        refitted += clip_fits.refitted;
        each(session, ClipEvaluated { index: c, name, utterance: u, fits: clip_fits.fits })?;
    }
    progress(Progress::Finished);
    Ok((warnings, refitted))
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
    /// How tables name the scale: `min–max scaled per sentence` or `ratios unscaled`.
    pub fn label(self) -> String {
        match self {
            Normalisation::MinMax => format!("{} per sentence", crate::glossary::names::MIN_MAX),
            Normalisation::None => "ratios unscaled".to_string(),
        }
    }

    /// `utterances` on the scale they are compared on.
    pub fn apply(self, utterances: &[Utterance]) -> Vec<Utterance> {
        utterances.iter().map(|u| self.apply_one(u)).collect()
    }

    /// One utterance on the scale it is compared on.
    pub fn apply_one(self, u: &Utterance) -> Utterance {
        match self {
            Normalisation::MinMax => u.min_max_normalised(),
            Normalisation::None => u.clone(),
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
    /// Where the video's lips meet, the head's inner-lip gap ([`crate::eval::seal`]).
    pub seals: Table,
}

impl EvalReport {
    pub fn tables(&self) -> [&Table; 6] {
        [
            &self.sentences,
            &self.phonemes,
            &self.visemes,
            &self.worst_frames,
            &self.worst_fits,
            &self.seals,
        ]
    }

    /// Names what was compared in every table's title: the W/H/P tables get the whole of
    /// `conditions` (and the pose comparison in their W and H columns), the sealed-lips table
    /// the same but its scale as it is computed (the ratios before any normalisation: its
    /// figure is a share of the head's own widest opening), the reprojection table the
    /// landmark set alone.
    pub fn name_conditions(&mut self, conditions: &EvalConditions) {
        let label = conditions.label();
        for t in
            [&mut self.sentences, &mut self.phonemes, &mut self.visemes, &mut self.worst_frames]
        {
            t.name_conditions(&label, Some(conditions.pose));
        }
        let unscaled = EvalConditions { normalisation: Normalisation::None, ..*conditions };
        self.seals.name_conditions(&unscaled.label(), Some(conditions.pose));
        let set = conditions.set.map_or(String::new(), set_label);
        self.worst_fits.name_conditions(&set, None);
    }

    /// The tables of the sentences and fits added to `tally`, and the sealed-lips table of
    /// `seals` (sentence, its seal).
    pub fn of(tally: &Tally, seals: &[(String, Option<LipSeal>)]) -> Self {
        let visemes = &crate::reference::current().visemes;
        EvalReport {
            sentences: sentence_table_of(tally.sentences()).keyed("sentences"),
            phonemes: group_table("RMSE per phoneme", &tally.phonemes(), None).keyed("phonemes"),
            visemes: group_table("RMSE per viseme class", &tally.visemes(), Some(visemes))
                .keyed("visemes"),
            worst_frames: worst_error_table(&tally.worst_frames()).keyed("worst_frames"),
            worst_fits: worst_fit_table(tally.worst_fits()).keyed("worst_fits"),
            seals: seal_table(seals).keyed("seals"),
        }
    }
}

/// A [`Tally`] of utterances compared as `normalisation` says, phones by the reference
/// tables: one sentence added at a time ([`EvalTally::add`]), the report at the end.
#[derive(Clone, Debug)]
pub struct EvalTally {
    tally: Tally,
    normalisation: Normalisation,
    /// Each sentence's sealed lips, measured before normalisation (a share of the head's own
    /// widest opening, `eval::seal`).
    seals: Vec<(String, Option<LipSeal>)>,
}

impl EvalTally {
    pub fn new(normalisation: Normalisation, n_worst: usize) -> Self {
        Self { tally: Tally::new(n_worst), normalisation, seals: Vec::new() }
    }

    /// Adds one clip: its utterance (as measured) and its fits.
    pub fn add(&mut self, utterance: &Utterance, clip: &str, fits: &[FrameFit]) {
        self.add_utterance(utterance);
        self.add_fits(clip, fits);
    }

    /// Adds one sentence as measured.
    pub fn add_utterance(&mut self, utterance: &Utterance) {
        let tables = crate::reference::current();
        let compared = self.normalisation.apply_one(utterance);
        self.tally.add_utterance(&compared, &tables.phones, &tables.visemes);
        self.seals.push((utterance.name.clone(), lip_seal(utterance)));
    }

    /// Adds a clip's fits to the worst fits.
    pub fn add_fits(&mut self, clip: &str, fits: &[FrameFit]) {
        self.tally.add_fits(clip, fits);
    }

    /// The tables of everything added.
    pub fn report(&self) -> EvalReport {
        EvalReport::of(&self.tally, &self.seals)
    }
}

/// What an evaluation compared, as every table's header says it: the landmark set the fits
/// used (when known), how trajectories were scaled, and how W and H met head pose.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EvalConditions {
    pub set: Option<crate::landmarks::LandmarkSet>,
    pub normalisation: Normalisation,
    pub pose: PoseComparison,
}

impl EvalConditions {
    /// `fit on F4 (51 points) · min–max scaled per sentence · W/H frontal ≤15°`.
    pub fn label(&self) -> String {
        let mut parts: Vec<String> = self.set.map(set_label).into_iter().collect();
        parts.push(self.normalisation.label());
        parts.push(format!("W/H {}", self.pose.short_label()));
        parts.join(" · ")
    }
}

/// `fit on F4 (51 points)`: a landmark set as table headers name it.
fn set_label(set: crate::landmarks::LandmarkSet) -> String {
    format!("fit on {set} ({} points)", set.indices().len())
}

/// Per-sentence, per-phoneme and per-viseme RMSE tables, the worst frames by measure error
/// (W, H, P pooled) and by fit residual, and the head's gap where the video's lips meet (on
/// the measures as they are: a share of the head's own widest opening).
pub fn evaluate(
    utterances: &[Utterance],
    fits: &[(&str, &[FrameFit])],
    normalisation: Normalisation,
    n_worst: usize,
) -> EvalReport {
    let mut tally = EvalTally::new(normalisation, n_worst);
    for u in utterances {
        tally.add_utterance(u);
    }
    for (clip, f) in fits {
        tally.add_fits(clip, f);
    }
    tally.report()
}

/// Rows of the worst-frame tables unless the user asks for another number: `eval`,
/// `export`, the demo and the TUI's analysis list as many.
pub const DEFAULT_WORST_ROWS: usize = 10;

/// One clip evaluated on its own (the TUI's analysis of the clip it has open).
#[derive(Clone, Debug)]
pub struct ClipEvaluation {
    pub utterance: Utterance,
    pub report: EvalReport,
    pub warnings: Vec<Warning>,
}

/// Measures one clip as [`utterance_of`] does (mesh measures by default) and evaluates it
/// alone.
pub fn evaluate_clip(
    model: &MorphableModel,
    map: &LandmarkMap,
    input: &ClipInput<'_>,
    normalisation: Normalisation,
    n_worst: usize,
) -> ClipEvaluation {
    let (utterance, warnings) = utterance_of(model, map, input, &MeshMeasureOptions::default());
    let mut report = evaluate(
        std::slice::from_ref(&utterance),
        &[(input.name, input.fits)],
        normalisation,
        n_worst,
    );
    report.name_conditions(&EvalConditions { set: input.set, normalisation, pose: input.pose });
    ClipEvaluation { utterance, report, warnings }
}

/// What to evaluate in a session, and how.
#[derive(Clone, Debug)]
pub struct EvalRequest {
    /// Only this clip (by name); all when `None`.
    pub clip: Option<String>,
    /// Sealed lips, when it is to replace the session's setting (saved with the fits).
    pub closure: Option<crate::landmarks::closure::Closure>,
    pub head_p: HeadP,
    /// How W and H are compared under head pose.
    pub pose: PoseComparison,
    pub normalisation: Normalisation,
    /// Rows of the worst-frame tables.
    pub worst: usize,
}

impl EvalRequest {
    /// The clips `clips` measured as this request asks.
    pub fn measuring<'a>(&self, clips: &'a [usize]) -> ClipsToMeasure<'a> {
        ClipsToMeasure { clips, head_p: self.head_p, pose: self.pose }
    }
}

impl Default for EvalRequest {
    fn default() -> Self {
        Self {
            clip: None,
            closure: None,
            head_p: HeadP::Mesh,
            pose: PoseComparison::default(),
            normalisation: Normalisation::default(),
            worst: DEFAULT_WORST_ROWS,
        }
    }
}

/// A session evaluated.
#[derive(Clone, Debug)]
pub struct SessionEvaluation {
    pub report: EvalReport,
    /// The same tables on each head the motion was transferred onto (`lipmap transfer`).
    pub transferred: Vec<Table>,
    /// What fitting the clips found: frames, failures, frames fitted now.
    pub fits: FitTally,
    /// What was worked around, one line each.
    pub warnings: Vec<Warning>,
}

impl SessionEvaluation {
    /// Every table: the model's, then the transferred heads'.
    pub fn tables(&self) -> Vec<&Table> {
        self.report.tables().into_iter().chain(&self.transferred).collect()
    }

    /// Whether any frame of any clip failed to fit.
    pub fn any_failed(&self) -> bool {
        self.fits.failed > 0
    }
}

/// What the fits of the clips evaluated came to, counted clip by clip.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct FitTally {
    pub clips: usize,
    /// Frames fitted (from the cache or now).
    pub frames: usize,
    /// Frames whose fit failed.
    pub failed: usize,
    /// Frames fitted now.
    pub refitted: usize,
    /// The first failure: the clip and the reason.
    pub first_failure: Option<(String, String)>,
}

impl FitTally {
    /// Counts one clip's fits.
    pub fn add(&mut self, clip: &str, fits: &[FrameFit]) {
        self.clips += 1;
        self.frames += fits.len();
        for f in fits.iter().filter(|f| !f.is_usable()) {
            self.failed += 1;
            if self.first_failure.is_none() {
                let why = f.failed.clone().unwrap_or_default();
                self.first_failure = Some((clip.to_string(), why));
            }
        }
    }

    /// Fails when no frame of any clip was fitted: the error is one line with the count and
    /// the first clip's first reason.
    ///
    /// # Errors
    /// [`Error::Invalid`] when every fit failed or there was no frame to fit.
    pub fn require_some_fit(&self) -> Result<()> {
        if self.frames > self.failed {
            return Ok(());
        }
        Err(Error::Invalid(match &self.first_failure {
            Some((clip, why)) => format!(
                "every fit failed ({} of {}), nothing to evaluate; first: {clip}: {why}",
                plural(self.frames, "frame"),
                plural(self.clips, "clip")
            ),
            None => "no frame has landmarks to fit".into(),
        }))
    }
}

/// Evaluates a session opened for reading: loads its resources, fits what the cache lacks
/// (kept when the session is locked by this process), measures every selected clip and
/// tabulates them, with the tables of the heads the motion was transferred onto. Each
/// clip's flags go to `flags` as soon as the clip is measured (a count, then one line per
/// flagged frame), not kept. Progress: one stage per clip.
///
/// # Errors
/// As [`load_resources`], [`select_clips`] and [`utterances_with`]; the save's error;
/// [`Error::Invalid`] when every fit failed (the tables would hold nothing but failures).
pub fn evaluate_session(
    opened: &mut ReadSession,
    req: &EvalRequest,
    progress: ProgressFn<'_>,
    flags: &mut dyn FnMut(&[String]),
) -> Result<SessionEvaluation> {
    let (res, mut warnings) = load_resources(&opened.session, &opened.path)?;
    let clips = select_clips(&opened.session, req.clip.as_deref())?;
    if clips.iter().all(|&c| opened.session.clips[c].alignment.is_none()) {
        warnings.push(Warning(
            "lipmap: warning: no clip has a phone alignment; per-phoneme tables will be empty"
                .into(),
        ));
    }
    if let Some(c) = req.closure {
        opened.session.fit_settings.closure = c;
    }
    let settings = opened.session.fit_settings.clone();
    // Each clip is fitted, measured, flagged and added to the tallies (the model's and each
    // transferred head's) before the next is read: nothing per frame is kept across clips.
    let (mut heads, more) = TransferredTallies::prepare(&opened.session, &res, req);
    warnings.extend(more);
    let mut tally = EvalTally::new(req.normalisation, req.worst);
    let mut fits = FitTally::default();
    let clip_req = ClipRequest { settings: &settings, head_p: req.head_p, pose: req.pose };
    let (more, refitted) = for_each_clip_evaluated(
        &mut opened.session,
        &res,
        &clips,
        &clip_req,
        progress,
        &mut |session, clip| {
            flags(&clip_flag_lines(session, clip.index, &clip.fits)?);
            tally.add(&clip.utterance, &clip.name, &clip.fits);
            fits.add(&clip.name, &clip.fits);
            heads.add(&res, &clip);
            Ok(())
        },
    )?;
    warnings.extend(more);
    fits.refitted = refitted;
    opened.save_if_locked()?;
    fits.require_some_fit()?;
    let mut report = tally.report();
    let conditions = EvalConditions {
        set: Some(settings.set),
        normalisation: req.normalisation,
        pose: req.pose,
    };
    report.name_conditions(&conditions);
    let (transferred, more) = heads.tables(&conditions);
    warnings.extend(more);
    Ok(SessionEvaluation { report, transferred, fits, warnings })
}

/// The tallies of the heads the motion was transferred onto, one per head that could be set
/// up, each clip's head side measured on the transferred head as it comes.
struct TransferredTallies {
    heads: Vec<TransferredTally>,
    /// How W and H are compared, as for the fitted model.
    pose: PoseComparison,
    warnings: Vec<Warning>,
}

struct TransferredTally {
    entry: crate::session::TransferredHead,
    head: super::transfer::PreparedHead,
    tally: EvalTally,
}

impl TransferredTallies {
    /// Sets up every transferred head of the session; a head that cannot be (a moved file)
    /// is a warning, not a failure.
    fn prepare(session: &Session, res: &Resources, req: &EvalRequest) -> (Self, Vec<Warning>) {
        let mut heads = Vec::new();
        let mut warnings = Vec::new();
        for entry in &session.transferred_heads {
            match super::transfer::prepare_head(res, entry) {
                Ok(head) => heads.push(TransferredTally {
                    entry: entry.clone(),
                    head,
                    tally: EvalTally::new(req.normalisation, req.worst),
                }),
                Err(e) => warnings.push(skipped_head(entry, &e)),
            }
        }
        (Self { heads, pose: req.pose, warnings: Vec::new() }, warnings)
    }

    /// Adds one clip to every head's tally; a head whose transfer fails is dropped with a
    /// warning.
    fn add(&mut self, res: &Resources, clip: &ClipEvaluated) {
        let mut failed = Vec::new();
        for (k, h) in self.heads.iter_mut().enumerate() {
            match super::transfer::transferred_utterance(
                res,
                &h.head.transfer,
                &h.head.map,
                &clip.utterance,
                &clip.fits,
                self.pose,
            ) {
                Ok(u) => h.tally.add(&u, &clip.name, &clip.fits),
                Err(e) => {
                    self.warnings.push(skipped_head(&h.entry, &e));
                    failed.push(k);
                }
            }
        }
        for k in failed.into_iter().rev() {
            self.heads.remove(k);
        }
    }

    /// The per-sentence, per-phoneme and per-viseme tables of each head, titles naming it
    /// and what was compared.
    fn tables(self, conditions: &EvalConditions) -> (Vec<Table>, Vec<Warning>) {
        let mut tables = Vec::new();
        for h in &self.heads {
            let mut r = h.tally.report();
            for t in [&mut r.sentences, &mut r.phonemes, &mut r.visemes] {
                t.title =
                    format!("{}, transferred head `{}` ({})", t.title, h.entry.name, h.entry.mode);
            }
            r.name_conditions(conditions);
            for mut t in [r.sentences, r.phonemes, r.visemes] {
                t.key = format!("transferred_{}", t.key);
                tables.push(t.for_item(&h.entry.name));
            }
        }
        (tables, self.warnings)
    }
}

fn skipped_head(entry: &crate::session::TransferredHead, e: &Error) -> Warning {
    Warning(format!(
        "lipmap: warning: transferred head `{}` skipped: {}",
        entry.name,
        error_chain(e)
    ))
}

fn plural(n: usize, noun: &str) -> String {
    if n == 1 { format!("{n} {noun}") } else { format!("{n} {noun}s") }
}

/// Fits the selected clips of a session with each landmark set of `sets` (the session's
/// other settings kept) and compares them sentence by sentence, the first set being the
/// t-tests' baseline (`eval --compare`). New fits are kept when the session is locked by
/// this process.
///
/// # Errors
/// As [`evaluate_session`]; configurations that cannot be compared.
pub fn compare_sets(
    opened: &mut ReadSession,
    req: &EvalRequest,
    sets: &[crate::landmarks::LandmarkSet],
    progress: ProgressFn<'_>,
) -> Result<(Comparison, Vec<Warning>)> {
    let (res, mut warnings) = load_resources(&opened.session, &opened.path)?;
    let clips = select_clips(&opened.session, req.clip.as_deref())?;
    if let Some(c) = req.closure {
        opened.session.fit_settings.closure = c;
    }
    let base = opened.session.fit_settings.clone();
    let mut configs = Vec::new();
    for &set in sets {
        let settings = FitSettings { set, ..base.clone() };
        let which = req.measuring(&clips);
        let done = utterances_with(&mut opened.session, &res, which, &settings, progress)?;
        warnings.extend(done.warnings);
        let utterances = req.normalisation.apply(&done.utterances);
        configs.push(Configuration { name: set.to_string(), utterances });
    }
    opened.save_if_locked()?;
    Ok((compare_configurations(&configs, 0, RowKey::Sentence)?, warnings))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn fit(frame: usize, failed: Option<&str>) -> FrameFit {
        FrameFit { failed: failed.map(String::from), ..FrameFit::unposed(frame) }
    }

    #[test]
    fn every_fit_failed_is_an_error() {
        let why = "too few usable landmarks (2 of 2)";
        let tally = |fits: &[FrameFit]| {
            let mut t = FitTally::default();
            t.add("c", fits);
            t
        };
        let e = tally(&[fit(0, Some(why)), fit(1, Some(why))]).require_some_fit();
        assert_eq!(
            e.unwrap_err().to_string(),
            format!("every fit failed (2 frames of 1 clip), nothing to evaluate; first: c: {why}")
        );
        assert!(tally(&[fit(0, Some(why)), fit(1, None)]).require_some_fit().is_ok());
        assert_eq!(
            FitTally::default().require_some_fit().unwrap_err().to_string(),
            "no frame has landmarks to fit"
        );
    }

    /// Two vertices, the upper (62) and lower (66) stomion 10 apart, and one identity mode
    /// of standard deviation `sd` moving the upper one: the gap is 10 + sd·α.
    fn stomion_model(sd: f64) -> (MorphableModel, LandmarkMap) {
        use crate::landmarks::ibug::point::{STOMION_LOWER, STOMION_UPPER};
        use crate::math::{DMatrix, DVector};
        let model = MorphableModel {
            shape: crate::model::PcaModel {
                mean: DVector::from_vec(vec![0.0, 10.0, 0.0, 0.0, 0.0, 0.0]),
                basis: DMatrix::from_column_slice(6, 1, &[0.0, 1.0, 0.0, 0.0, 0.0, 0.0]),
                eigenvalues: DVector::from_element(1, sd * sd),
            },
            expressions: None,
            triangles: Vec::new(),
        };
        (model, LandmarkMap { to_vertex: [(STOMION_UPPER, 0), (STOMION_LOWER, 1)].into() })
    }

    #[test]
    fn frames_fitted_alone_name_the_limit_of_every_plausible_identity() {
        let (track, alignment) = (crate::landmarks::Track::default(), Default::default());
        // Each frame its own identity; the video's lips meet on the first three frames.
        let alphas = [0.2, 0.0, -0.3, 1.5, 3.0];
        let fits: Vec<FrameFit> = alphas
            .iter()
            .enumerate()
            .map(|(f, &a)| FrameFit { identity: vec![a], ..FrameFit::unposed(f) })
            .collect();
        let mut u = Utterance { name: "c".into(), fps: 25.0, ..Default::default() };
        u.video.h = [0.0, 0.0, 0.0, 1.0, 2.0].iter().map(|h| Some(*h)).collect();
        let input = ClipInput {
            name: "c",
            alignment: &alignment,
            fps: 25.0,
            track: &track,
            fits: &fits,
            side_view: false,
            side_p: None,
            pose: PoseComparison::ImagePlane,
            set: None,
        };
        // sd 2: the widest fitted gap is 16, and no identity within the prior's 99 % radius
        // (2.57) brings it below 10 − 2·2.57 ≈ 4.87, 30 % of it.
        let (model, map) = stomion_model(2.0);
        let w = lip_seal_limit(&model, &map, &input, &u).expect("a limit");
        let reach = 10.0 - 2.0 * crate::measure::lip_reach::plausible_radius(1);
        let named = format!("any identity within 99 % of the model's prior is {reach:.3} (30 %");
        assert!(w.0.contains(&named), "{}", w.0);
        // sd 10: an identity 1 sd out closes the lips: no limit, whatever the fits kept.
        let (model, map) = stomion_model(10.0);
        assert!(lip_seal_limit(&model, &map, &input, &u).is_none());
        // One identity for the clip (clip mode): the limit is that identity's own.
        let (model, map) = stomion_model(2.0);
        let shared: Vec<FrameFit> =
            fits.iter().map(|f| FrameFit { identity: vec![0.2], ..f.clone() }).collect();
        let input = ClipInput { fits: &shared, ..input };
        u.video.h = [0.0, 0.0, 0.0, 1.0, 2.0].iter().map(|h| Some(*h)).collect();
        let w = lip_seal_limit(&model, &map, &input, &u).expect("a limit");
        assert!(w.0.contains("the fitted identity is 10.400"), "{}", w.0);
    }

    #[test]
    fn the_sealed_lips_title_names_the_scale_it_is_computed_on() {
        let mut report = evaluate(&[], &[], Normalisation::MinMax, 1);
        report.name_conditions(&EvalConditions {
            set: None,
            normalisation: Normalisation::MinMax,
            pose: PoseComparison::ImagePlane,
        });
        assert!(
            report.sentences.title.contains("min–max scaled per sentence"),
            "{}",
            report.sentences.title
        );
        let seals = &report.seals.title;
        assert!(seals.contains("ratios unscaled · W/H image plane"), "{seals}");
        assert!(!seals.contains("min–max"), "{seals}");
    }

    #[test]
    fn a_frontal_comparison_leaves_out_and_counts_the_turned_frames_of_video_and_head() {
        use crate::landmarks::{FrameLandmarks, LandmarkPoint, Track};
        let head = crate::demo::head::build_head();
        let n3 = 3 * head.mesh.num_vertices();
        let model = MorphableModel {
            shape: crate::model::PcaModel {
                mean: head.mesh.to_flat(),
                basis: crate::math::DMatrix::zeros(n3, 0),
                eigenvalues: crate::math::DVector::zeros(0),
            },
            expressions: None,
            triangles: Vec::new(),
        };
        let yaws = [0.0, 30.0, 10.0, -40.0, 0.0];
        let fits: Vec<FrameFit> = yaws
            .iter()
            .enumerate()
            .map(|(f, &yaw)| FrameFit { yaw, scale: 2.0, ..FrameFit::unposed(f) })
            .collect();
        let map = head.landmarks.with_commissures_completed();
        let frames = fits
            .iter()
            .map(|fit| {
                let shape = crate::fit::fitted_shape(&model, fit);
                let points = crate::measure::mesh::landmark_points_3d(&shape, &map)
                    .into_iter()
                    .map(|p| {
                        p.map_or_else(LandmarkPoint::missing, |p| {
                            let q = crate::fit::project(fit, p, 480.0);
                            LandmarkPoint::tracked(q.x, q.y)
                        })
                    })
                    .collect();
                FrameLandmarks::new(fit.frame, points)
            })
            .collect();
        let track = Track::new(frames);
        let alignment = crate::alignment::Alignment::default();
        let opts = MeshMeasureOptions::default();
        let parts = |pose| {
            utterance_from_parts("c", &alignment, 25.0, &track, &model, &map, &fits, &opts, pose)
        };
        let (u, turned) = parts(PoseComparison::frontal());
        assert_eq!(turned, 2);
        for (f, &yaw) in yaws.iter().enumerate() {
            let kept = f64::abs(yaw) <= 15.0;
            assert_eq!(u.video.w[f].is_some(), kept, "frame {f}");
            assert_eq!(u.head.h[f].is_some(), kept, "frame {f}");
        }
        // In the image plane every frame is compared, and the head measured through the
        // camera that made the video's points reads the video's W on the turned frames too.
        let (u, turned) = parts(PoseComparison::ImagePlane);
        assert_eq!(turned, 0);
        for f in 0..yaws.len() {
            let (v, h) = (u.video.w[f].unwrap(), u.head.w[f].unwrap());
            assert!((v - h).abs() < 1e-9, "frame {f}: video {v} head {h}");
        }
    }
}
