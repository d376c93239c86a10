//! The session-level pipeline shared by the command line, the TUI and the demo: load what a
//! session refers to, fit its clips (reusing still-valid cached fits), measure and evaluate.
//!
//! Everything here is plain calls over the core; no printing, no terminal. Start with
//! [`Resources::load`], then [`fit_clip_cached`] and [`utterance_of_clip`], then [`evaluate`].

use crate::eval::report::{group_table, sentence_table, worst_error_table, worst_fit_table};
use crate::eval::{Table, Utterance, VisemeTable, phoneme_rmse, viseme_rmse};
use crate::eval::{worst_frames_by_error, worst_frames_by_residual};
use crate::fit::{FitSettings, FrameFit, fit_clip, fitted_shape};
use crate::io::{model_source, obj};
use crate::landmarks::FrameLandmarks;
use crate::math::DVector;
use crate::measure::mesh::trajectory_from_shapes;
use crate::measure::mouth::trajectory_from_track;
use crate::measure::profile::{Facing, ProfileSetup, extract_protrusion_with, propose_setup};
use crate::measure::{Measure, MeshMeasureOptions, Trajectory};
use crate::model::{LandmarkMap, Mesh, MorphableModel};
use crate::session::Session;
use anyhow::{Context, Result, anyhow, bail};

/// What a session's fits need, loaded once: the model, the landmark map and the head mesh.
#[derive(Clone, Debug)]
pub struct Resources {
    pub model: MorphableModel,
    pub map: LandmarkMap,
    pub head: Option<Mesh>,
}

impl Resources {
    /// Loads the session's model (with blendshapes), landmark map and head mesh.
    ///
    /// # Errors
    /// No model or map in the session; any file's `FormatError` (file and line).
    pub fn load(session: &Session) -> Result<Self> {
        let mref = session.model.as_ref().ok_or_else(|| {
            anyhow!("the session has no model: give one with `lipmap new --model`")
        })?;
        let model = model_source::load_model(&mref.path, mref.blendshapes.as_deref())?;
        let map = session.landmark_map.resolve()?.ok_or_else(|| {
            anyhow!("the session has no landmark map: give one with `lipmap new --mapping`")
        })?;
        if let Some((&lm, &v)) = map.to_vertex.iter().find(|(_, v)| **v >= model.num_vertices()) {
            bail!(
                "landmark map: point {lm} maps to vertex {v} but the model has {} vertices",
                model.num_vertices()
            );
        }
        let head = session.head_mesh.as_deref().map(obj::read_obj).transpose()?;
        Ok(Self { model, map, head })
    }
}

/// Image height (pixels) of a clip's front view: the session's record, else the first frame.
///
/// # Errors
/// Neither the session nor the frames tell the size.
pub fn image_height(session: &Session, clip: usize) -> Result<f64> {
    let c = session.clip(clip)?;
    if let Some([_, h]) = c.front.size {
        return Ok(f64::from(h));
    }
    let frames = session.open_frames(clip, 64).with_context(|| format!("clip `{}`", c.name))?;
    Ok(f64::from(frames.size()[1]))
}

/// What fitting one clip did.
#[derive(Clone, Debug)]
pub struct ClipFits {
    /// One fit per frame with landmarks, ascending by frame.
    pub fits: Vec<FrameFit>,
    /// How many frames were fitted now (the rest came from the cache).
    pub refitted: usize,
}

impl ClipFits {
    pub fn failed(&self) -> usize {
        self.fits.iter().filter(|f| f.failed.is_some()).count()
    }
}

/// Fits clip `clip` with `settings`, refitting only what the cache cannot give: the stale
/// frames in per-frame mode, the whole clip in clip mode (its identity is shared, so one
/// changed frame changes them all). The new fits are stored in the session's cache.
/// `progress` receives (frames done, frames to do).
///
/// # Errors
/// Unknown clip; landmarks missing for a frame the cache names.
pub fn fit_clip_cached(
    session: &mut Session,
    res: &Resources,
    clip: usize,
    settings: &FitSettings,
    progress: Option<&(dyn Fn(usize, usize) + Sync)>,
) -> Result<ClipFits> {
    let stale = session.stale_frames_with(clip, settings);
    let height = image_height(session, clip)?;
    let track = session.effective_track(clip)?;
    let to_fit: Vec<FrameLandmarks> = if stale.is_empty() {
        Vec::new()
    } else if settings.clip {
        track.frames.clone()
    } else {
        let stale: std::collections::BTreeSet<usize> = stale.into_iter().collect();
        track.frames.iter().filter(|f| stale.contains(&f.frame)).cloned().collect()
    };
    let refitted = to_fit.len();
    if refitted > 0 {
        let total = refitted;
        let report = |done: usize| {
            if let Some(p) = progress {
                p(done, total);
            }
        };
        let fits = fit_clip(&res.model, &res.map, &to_fit, height, settings, Some(&report));
        session.store_fits(clip, settings, fits)?;
    }
    let fits: Vec<FrameFit> = session.cached_fits(clip, settings).into_iter().cloned().collect();
    Ok(ClipFits { fits, refitted })
}

/// Fitted model-space shapes indexed by frame number (`None` for failed or missing fits),
/// `n_frames` long.
pub fn shapes_by_frame(
    model: &MorphableModel,
    fits: &[FrameFit],
    n_frames: usize,
) -> Vec<Option<DVector>> {
    let mut shapes = vec![None; n_frames];
    for f in fits.iter().filter(|f| f.failed.is_none()) {
        if f.frame < n_frames {
            shapes[f.frame] = Some(fitted_shape(model, f));
        }
    }
    shapes
}

/// Number of frames a clip spans: the last frame with landmarks + 1.
pub fn clip_length(session: &Session, clip: usize) -> Result<usize> {
    let c = session.clip(clip)?;
    Ok(c.tracked.frames.last().map_or(0, |f| f.frame + 1))
}

/// The evaluation input of one clip's parts: the video's W/H from `track` and the fitted
/// head's W/H/P from its model-space shapes (measured through `map` with its mouth corners
/// completed), both `n` frames long. Side-view P is the caller's to add.
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
    let shapes = shapes_by_frame(model, fits, n);
    let map = map.with_commissures_completed();
    let head = trajectory_from_shapes(shapes.iter().map(|s| s.as_ref()), &map, options);
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
/// landmarks, plus the side view's protrusion when the clip has one.
///
/// # Errors
/// Unknown clip.
pub fn utterance_of_clip(
    session: &Session,
    res: &Resources,
    clip: usize,
    fits: &[FrameFit],
    options: &MeshMeasureOptions,
) -> Result<Utterance> {
    let c = session.clip(clip)?;
    let track = session.effective_track(clip)?;
    let mut u = utterance_from_parts(
        &c.name,
        &c.alignment.clone().unwrap_or_default(),
        c.front.fps,
        &track,
        &res.model,
        &res.map,
        fits,
        options,
    );
    match side_view_protrusion(session, clip, u.video.len()) {
        Ok(Some(p)) => u.video.p = p,
        Ok(None) => {}
        // The front-view tables are still worth having; say why P is missing.
        Err(e) => eprintln!("lipmap: clip `{}`: no side-view protrusion: {e:#}", c.name),
    }
    Ok(u)
}

fn pad(mut t: Trajectory, n: usize) -> Trajectory {
    for m in Measure::ALL {
        t.series_mut(m).resize(n, None);
    }
    t
}

/// How video and head trajectories are compared.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, clap::ValueEnum, serde::Serialize)]
pub enum Normalisation {
    /// Min–max per sequence, video and head separately (the published method: shapes of
    /// trajectories, so a head of other proportions can still be judged).
    #[default]
    MinMax,
    /// The reference-length ratios as they are (same-person heads, known truth).
    None,
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
    let compared: Vec<Utterance> = match normalisation {
        Normalisation::MinMax => utterances.iter().map(Utterance::min_max_normalised).collect(),
        Normalisation::None => utterances.to_vec(),
    };
    let visemes = VisemeTable::default();
    let mut worst: Vec<_> =
        Measure::ALL.iter().flat_map(|&m| worst_frames_by_error(&compared, m, n_worst)).collect();
    worst.sort_by(|a, b| b.error.abs().total_cmp(&a.error.abs()));
    worst.truncate(n_worst);
    EvalReport {
        sentences: sentence_table(&compared),
        phonemes: group_table("RMSE per phoneme", &phoneme_rmse(&compared), None),
        visemes: group_table(
            "RMSE per viseme class",
            &viseme_rmse(&compared, &visemes),
            Some(&visemes),
        ),
        worst_frames: worst_error_table(&worst),
        worst_fits: worst_fit_table(&worst_frames_by_residual(fits, n_worst)),
    }
}

/// Key in a clip's `extensions` holding its side-view `ProfileSetup` (crop, reference line,
/// facing, threshold, nose length), set by the user or proposed once and kept.
pub const PROFILE_SETUP_KEY: &str = "profile_setup";

/// The side-view protrusion setup of a clip: the stored one, else one proposed from the
/// first side frame (the face assumed to look right unless a stored setup says otherwise).
///
/// # Errors
/// No side view; an unreadable frame; a first frame whose profile cannot be found.
pub fn profile_setup(session: &Session, clip: usize) -> Result<ProfileSetup> {
    let c = session.clip(clip)?;
    if let Some(v) = c.extensions.get(PROFILE_SETUP_KEY) {
        return serde_json::from_value(v.clone())
            .with_context(|| format!("clip `{}`: stored `{PROFILE_SETUP_KEY}`", c.name));
    }
    let frames = session
        .open_side_frames(clip, 64)?
        .ok_or_else(|| anyhow!("clip `{}` has no side view", c.name))?;
    let first = frames.get(0)?;
    let gray = image::DynamicImage::ImageRgb8((*first).clone()).to_luma8();
    propose_setup(&gray, Facing::Right)
        .map_err(|e| anyhow!("clip `{}`: side view frame 0: {e}", c.name))
}

/// Upper-lip protrusion measured on the side view, resampled onto the front view's frames
/// (side frame nearest to each front frame's time, after the view's offset): `None` for a
/// clip without a side view, `None` entries where extraction failed.
///
/// # Errors
/// As [`profile_setup`]; frames that cannot be opened.
pub fn side_view_protrusion(
    session: &Session,
    clip: usize,
    n_front: usize,
) -> Result<Option<Vec<Option<f64>>>> {
    let c = session.clip(clip)?;
    let Some(side) = c.side.as_ref() else { return Ok(None) };
    let setup = profile_setup(session, clip)?;
    let frames = session.open_side_frames(clip, 64)?.context("side view vanished")?;
    let points = extract_protrusion_with(
        frames.len(),
        |i| {
            frames
                .get(i)
                .map(|img| image::DynamicImage::ImageRgb8((*img).clone()).to_luma8())
                .map_err(|e| e.to_string())
        },
        &setup,
    );
    let value = |i: usize| points.get(i).and_then(|p| p.p_norm.or(p.p_px));
    let series = (0..n_front)
        .map(|f| {
            let t = f as f64 / c.front.fps - side.offset_s;
            let k = (t * side.fps).round();
            if k < 0.0 { None } else { value(k as usize) }
        })
        .collect();
    Ok(Some(series))
}
