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
use crate::measure::profile::{
    Facing, ProfilePoint, ProfileSetup, ProfileTrack, extract_protrusion_with, propose_setup,
};
use crate::measure::{Measure, MeshMeasureOptions, Trajectory, UpperLip};
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
        let map = session
            .landmark_map
            .resolve()?
            .filter(|m| !m.is_empty())
            .ok_or_else(|| anyhow!(NO_MAP_MESSAGE))?;
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

/// Why a session cannot be fitted yet: it has no landmark map (or an empty one).
pub const NO_MAP_MESSAGE: &str = "the session has no landmark map: label the head in the TUI \
     (view 2) or `lipmap import SESSION --mapping FILE`";

/// Fewest mapped landmarks a fit can work with: the affine camera needs 4 point pairs
/// (`fit::camera`), and `fit::clip` fails every frame with fewer usable points.
pub const MIN_FIT_LANDMARKS: usize = 4;

/// Why a landmark map cannot drive a fit, found before any frame is fitted.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum MapCheckError {
    /// The map maps nothing.
    #[error("{}", NO_MAP_MESSAGE)]
    Empty,
    /// Fewer than [`MIN_FIT_LANDMARKS`] of the fit's landmark set are mapped.
    #[error(
        "the landmark map has {usable} landmark{} of set {set}; a fit needs at least {MIN_FIT_LANDMARKS}",
        if *usable == 1 { "" } else { "s" }
    )]
    TooFew { usable: usize, set: crate::landmarks::LandmarkSet },
}

/// Checks `map` against the landmarks a fit with `settings` uses on a model of `n_vertices`
/// vertices (the same rule as `fit::shape::LandmarkBasis::new`: in the set, mapped to an
/// existing vertex, weight > 0) and returns how many it can use. One check per clip instead
/// of one identical failure per frame; the TUI calls it before starting a fit.
///
/// # Errors
/// [`MapCheckError::Empty`] for an empty map, [`MapCheckError::TooFew`] below
/// [`MIN_FIT_LANDMARKS`].
pub fn check_map_for_fit(
    map: &LandmarkMap,
    n_vertices: usize,
    settings: &FitSettings,
) -> Result<usize, MapCheckError> {
    if map.is_empty() {
        return Err(MapCheckError::Empty);
    }
    let usable = map
        .pairs()
        .filter(|&(l, _)| l < crate::landmarks::N_LANDMARKS && settings.set.contains(l))
        .filter(|&(_, v)| v < n_vertices)
        .filter(|&(l, _)| {
            let w = settings.landmark_weights.get(l).copied().unwrap_or(1.0);
            w.is_finite() && w > 0.0
        })
        .count();
    if usable < MIN_FIT_LANDMARKS {
        return Err(MapCheckError::TooFew { usable, set: settings.set });
    }
    Ok(usable)
}

/// The session's map file when an inline map (labelled in the TUI) shadows it and the file
/// now says something else: fits use the inline map, and the user should know the file is
/// ignored. `None` when there is no inline map, no file, they agree, or the file maps
/// nothing (a blank template the labelling started from); an unreadable file is reported.
pub fn shadowed_map_file(session: &Session) -> Option<std::path::PathBuf> {
    let r = &session.landmark_map;
    let (inline, file) = (r.inline_map()?, r.file.as_ref()?);
    match crate::io::landmark_map_toml::read_landmark_map(file) {
        Ok(m) if m.is_empty() || m.to_vertex == inline.to_vertex => None,
        _ => Some(file.clone()),
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
/// Unknown clip; landmarks missing for a frame the cache names; a map the fit cannot use
/// ([`check_map_for_fit`]), before anything is fitted.
pub fn fit_clip_cached(
    session: &mut Session,
    res: &Resources,
    clip: usize,
    settings: &FitSettings,
    progress: Option<&(dyn Fn(usize, usize) + Sync)>,
) -> Result<ClipFits> {
    check_map_for_fit(&res.map, res.model.num_vertices(), settings)?;
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
/// A side view sees the whole upper lip, so for a clip with one the head's P is measured the
/// same way: the default `UpperLip::MappedLandmarks` becomes the model's upper-lip region
/// ([`head_p_options`]). Other upper-lip choices in `options` are kept as given.
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
    let options = &head_p_options(session, res, clip, options);
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

/// The mesh-measure options for the head of clip `clip`: `options` as given, except that a
/// clip with a side view measures the head's P on the whole upper lip like the profile does
/// (`UpperLip::MappedLandmarks` → `UpperLip::Region`, resolved once on the model's mean
/// shape). A model whose map outlines no lip band keeps the landmark vertices, with a warning.
pub fn head_p_options(
    session: &Session,
    res: &Resources,
    clip: usize,
    options: &MeshMeasureOptions,
) -> MeshMeasureOptions {
    let side = session.clip(clip).is_ok_and(|c| c.side.is_some());
    let wanted = match &options.upper_lip {
        UpperLip::MappedLandmarks if side => UpperLip::Region,
        other => other.clone(),
    };
    if wanted != UpperLip::Region {
        return options.clone();
    }
    let region = MeshMeasureOptions { upper_lip: UpperLip::Region, ..options.clone() };
    let map = res.map.with_commissures_completed();
    match region.with_region_resolved(&res.model.shape.mean, &map) {
        Ok(o) => o,
        Err(e) => {
            eprintln!("lipmap: the model's upper-lip region: {e}; P uses the landmark vertices");
            MeshMeasureOptions { upper_lip: UpperLip::MappedLandmarks, ..options.clone() }
        }
    }
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

/// The side view's setup and profile points of a clip: the automatic extraction over every
/// side frame with the user's corrections laid over it (`None` for a clip without a side
/// view). The setup comes with the points so it is resolved (maybe proposed) only once.
///
/// # Errors
/// As [`profile_setup`]; frames that cannot be opened.
pub fn side_view_track(
    session: &Session,
    clip: usize,
) -> Result<Option<(ProfileSetup, ProfileTrack)>> {
    if session.clip(clip)?.side.is_none() {
        return Ok(None);
    }
    let setup = profile_setup(session, clip)?;
    let track = side_view_track_with(session, clip, &setup)?;
    Ok(Some((setup, track)))
}

fn side_view_track_with(
    session: &Session,
    clip: usize,
    setup: &ProfileSetup,
) -> Result<ProfileTrack> {
    let c = session.clip(clip)?;
    let frames = session.open_side_frames(clip, 64)?.context("side view vanished")?;
    let points = extract_protrusion_with(
        frames.len(),
        |i| {
            frames
                .get(i)
                .map(|img| image::DynamicImage::ImageRgb8((*img).clone()).to_luma8())
                .map_err(|e| e.to_string())
        },
        setup,
    );
    // The extraction resolved the nose length once; every normalised point carries it.
    let nose = points.iter().find_map(|p| match (p.p_px, p.p_norm) {
        (Some(px), Some(n)) if n != 0.0 => Some(px / n),
        _ => None,
    });
    let mut track = ProfileTrack::new(points, nose);
    track.corrected = c.profile_corrections.clone();
    Ok(track)
}

/// One front frame's side-view measurement: the side frame it was taken from (nearest in
/// time) and that frame's effective point (automatic, corrected, or failed with a reason);
/// `point` is `None` when the front frame falls outside the side view.
#[derive(Clone, Debug, PartialEq)]
pub struct SidePoint {
    pub side_frame: Option<usize>,
    pub point: Option<ProfilePoint>,
}

impl SidePoint {
    /// The P value compared with the head: normalised by the nose length when known, else px.
    pub fn p(&self) -> Option<f64> {
        self.point.as_ref().and_then(|p| p.p_norm.or(p.p_px))
    }
}

/// The side view's effective points of a clip at each of `n_front` front frames, with the
/// setup used (`None` for a clip without a side view).
///
/// # Errors
/// As [`profile_setup`]; frames that cannot be opened.
pub fn side_view_points(
    session: &Session,
    clip: usize,
    n_front: usize,
) -> Result<Option<(ProfileSetup, Vec<SidePoint>)>> {
    let c = session.clip(clip)?;
    let Some(side) = c.side.as_ref() else { return Ok(None) };
    let setup = profile_setup(session, clip)?;
    let track = side_view_track_with(session, clip, &setup)?;
    let n_side = track.automatic.len();
    let frames = resample_to_front(c.front.fps, side.fps, side.offset_s, n_front, |k| {
        (k < n_side || track.corrected.contains_key(&k)).then_some(k)
    });
    let points = frames
        .into_iter()
        .map(|k| SidePoint { side_frame: k, point: k.and_then(|k| track.effective(k, &setup)) })
        .collect();
    Ok(Some((setup, points)))
}

/// Upper-lip protrusion measured on the side view (corrections applied), resampled onto the
/// front view's frames (side frame nearest to each front frame's time, after the view's
/// offset): `None` for a clip without a side view, `None` entries where extraction failed.
///
/// # Errors
/// As [`profile_setup`]; frames that cannot be opened.
pub fn side_view_protrusion(
    session: &Session,
    clip: usize,
    n_front: usize,
) -> Result<Option<Vec<Option<f64>>>> {
    let points = side_view_points(session, clip, n_front)?;
    Ok(points.map(|(_, pts)| pts.iter().map(SidePoint::p).collect()))
}

/// Values of a side-view series at each front frame: the side frame nearest in time, after
/// the side view's offset.
pub fn resample_to_front<T>(
    front_fps: f64,
    side_fps: f64,
    offset_s: f64,
    n_front: usize,
    value: impl Fn(usize) -> Option<T>,
) -> Vec<Option<T>> {
    (0..n_front)
        .map(|f| {
            let t = f as f64 / front_fps - offset_s;
            let k = (t * side_fps).round();
            if k < 0.0 { None } else { value(k as usize) }
        })
        .collect()
}

/// How the fitted head's P is measured.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub enum HeadP {
    /// On the mesh: the foremost upper-lip vertex along the model's forward axis (the whole
    /// upper-lip region for a clip with a side view, see [`head_p_options`]).
    #[default]
    Mesh,
    /// On side renders of the fitted shapes, measured like the side video, the virtual
    /// camera nodded by `pitch_deg` (to match the real side camera's pitch).
    Render { pitch_deg: f64 },
}

/// The fitted head's P measured on side renders, and what it was measured with.
#[derive(Clone, Debug)]
pub struct RenderedHeadP {
    /// The profile setup proposed on the first render (no head-following anchor: the
    /// shapes are in model space, so the head does not move between renders).
    pub setup: ProfileSetup,
    pub renderer: crate::render::SideRenderer,
    /// P per frame (normalised by the render's nose length), `None` for missing shapes and
    /// renders whose profile could not be measured.
    pub p: Vec<Option<f64>>,
}

/// P of model-space `shapes` (one per frame, `None` for failed fits) measured on side
/// renders: a fixed camera fitted to the first shape and nodded by `pitch_deg`, facing
/// `facing`, `size` pixels; a profile setup proposed once on the first render (from the
/// projected nose and subnasale vertices of `map`, see
/// [`crate::render::SideRenderer::profile_setup`]; from the image when the map lacks them);
/// then each frame rendered and measured by [`crate::measure::profile::measure_render`], in
/// parallel.
///
/// # Errors
/// No shape at all; a degenerate first shape; triangles that do not fit the shapes; a first
/// render whose profile has no nose or lip to propose a setup from.
pub fn head_p_by_render(
    shapes: &[Option<DVector>],
    triangles: &[[u32; 3]],
    map: &LandmarkMap,
    facing: Facing,
    pitch_deg: f64,
    size: [u32; 2],
) -> Result<RenderedHeadP> {
    use rayon::prelude::*;
    let to_points = |s: &DVector| Mesh::from_flat(s.as_slice(), Vec::new()).vertices;
    let first = shapes.iter().flatten().next().ok_or_else(|| anyhow!("no fitted shape"))?;
    let first = to_points(first);
    let renderer = crate::render::SideRenderer::new(&first, pitch_deg, facing, size[0], size[1])
        .ok_or_else(|| anyhow!("the first fitted shape cannot be framed for a side render"))?;
    let setup = match renderer.profile_setup(&first, map) {
        Some(setup) => setup,
        None => {
            // No nose or subnasale vertex in the map: find them on the image instead.
            let render0 = renderer.render(&first, triangles)?;
            let mut setup = propose_setup(&image::imageops::grayscale(&render0), facing)
                .map_err(|e| anyhow!("side render of the first fitted shape: {e}"))?;
            setup.anchor = None;
            setup
        }
    };
    let p = shapes
        .par_iter()
        .map(|s| {
            let img = renderer.render(&to_points(s.as_ref()?), triangles).ok()?;
            let m = crate::measure::profile::measure_render(&img, &setup).ok()?;
            m.p_norm.or(m.p_px)
        })
        .collect();
    Ok(RenderedHeadP { setup, renderer, p })
}

/// The fitted head's P of clip `clip` from side renders of its fits ([`head_p_by_render`]),
/// `n` frames long: the model's triangles (or the head mesh's, when the model has none), the
/// facing of the clip's side setup (right without a side view), the side view's image size
/// (720×480 without one).
///
/// # Errors
/// No triangles to render; as [`head_p_by_render`] and [`profile_setup`].
pub fn head_p_of_clip_by_render(
    session: &Session,
    res: &Resources,
    clip: usize,
    fits: &[FrameFit],
    n: usize,
    pitch_deg: f64,
) -> Result<RenderedHeadP> {
    let c = session.clip(clip)?;
    let (facing, size) = match &c.side {
        Some(side) => (profile_setup(session, clip)?.facing, side.size.unwrap_or([720, 480])),
        None => (Facing::Right, [720, 480]),
    };
    let triangles = if !res.model.triangles.is_empty() {
        res.model.triangles.clone()
    } else {
        match &res.head {
            Some(h) if h.vertices.len() == res.model.num_vertices() => h.triangles(),
            _ => bail!("neither the model nor the head mesh has triangles to render"),
        }
    };
    let shapes = shapes_by_frame(&res.model, fits, n);
    let map = res.map.with_commissures_completed();
    head_p_by_render(&shapes, &triangles, &map, facing, pitch_deg, size)
        .with_context(|| format!("clip `{}`: head P from side renders", c.name))
}
