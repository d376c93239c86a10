//! The side view: its profile setup (stored or proposed), the upper-lip points per side
//! frame with the user's corrections, P resampled onto the front frames; and the fitted
//! head's P measured the same way, on the whole upper lip or on side renders.

use super::error::{Context, Error, Result, Warning};
use super::resources::Resources;
use crate::fit::FrameFit;
use crate::math::DVector;
use crate::measure::profile::{
    Facing, ProfilePoint, ProfileSetup, ProfileTrack, extract_protrusion_with, propose_setup,
};
use crate::measure::{MeshMeasureOptions, UpperLip};
use crate::model::{LandmarkMap, Mesh, MorphableModel};
use crate::session::Session;

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
        let setup: ProfileSetup = serde_json::from_value(v.clone()).map_err(|e| {
            Error::Invalid(e.to_string())
                .context(format!("clip `{}`: stored `{PROFILE_SETUP_KEY}`", c.name))
        })?;
        check_setup_in_frame(session, clip, &setup)?;
        return Ok(setup);
    }
    let frames = session
        .open_side_frames(clip, 64)?
        .ok_or_else(|| Error::Invalid(format!("clip `{}` has no side view", c.name)))?;
    let first = frames.get(0)?;
    let gray = image::DynamicImage::ImageRgb8((*first).clone()).to_luma8();
    propose_setup(&gray, Facing::Right)
        .map_err(|e| Error::Invalid(format!("clip `{}`: side view frame 0: {e}", c.name)))
}

/// Checks that a setup's crop (and anchor region) lie inside the clip's side frames: a
/// crop is allocated and scanned width × height, so one from a file or a flag is bounded
/// by the image before it is used.
///
/// # Errors
/// A region outside the side frame (naming the clip and field); no side view.
pub fn check_setup_in_frame(session: &Session, clip: usize, setup: &ProfileSetup) -> Result<()> {
    let c = session.clip(clip)?;
    let [w, h] = match c.side.as_ref().and_then(|s| s.size) {
        Some(size) => size,
        None => session
            .open_side_frames(clip, 1)?
            .ok_or_else(|| Error::Invalid(format!("clip `{}` has no side view", c.name)))?
            .size(),
    };
    let regions = std::iter::once(("crop", &setup.crop))
        .chain(setup.anchor.as_ref().map(|a| ("anchor region", &a.region)));
    for (field, r) in regions {
        let inside = r.width > 0
            && r.height > 0
            && u64::from(r.x) + u64::from(r.width) <= u64::from(w)
            && u64::from(r.y) + u64::from(r.height) <= u64::from(h);
        if !inside {
            return Err(Error::Invalid(format!(
                "clip `{}`: profile {field} {},{},{},{} is not inside the {w}×{h} side frame",
                c.name, r.x, r.y, r.width, r.height
            )));
        }
    }
    Ok(())
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
    let frames = session
        .open_side_frames(clip, 64)?
        .ok_or_else(|| Error::Invalid("side view vanished".into()))?;
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

/// The mesh-measure options for a head compared with a clip: `options` as given, except that
/// with a side view (`side`) the head's P is measured on the whole upper lip like the profile
/// does (`UpperLip::MappedLandmarks` → `UpperLip::Region`, resolved once on the model's mean
/// shape). A model whose map outlines no lip band keeps the landmark vertices, with a
/// warning saying so. The one rule for both fronts' evaluations.
pub fn head_p_options(
    model: &MorphableModel,
    map: &LandmarkMap,
    side: bool,
    options: &MeshMeasureOptions,
) -> (MeshMeasureOptions, Option<Warning>) {
    let wanted = match &options.upper_lip {
        UpperLip::MappedLandmarks if side => UpperLip::Region,
        other => other.clone(),
    };
    if wanted != UpperLip::Region {
        return (options.clone(), None);
    }
    let region = MeshMeasureOptions { upper_lip: UpperLip::Region, ..options.clone() };
    let map = map.with_commissures_completed();
    match region.with_region_resolved(&model.shape.mean, &map) {
        Ok(o) => (o, None),
        Err(e) => (
            MeshMeasureOptions { upper_lip: UpperLip::MappedLandmarks, ..options.clone() },
            Some(Warning(format!(
                "lipmap: the model's upper-lip region: {e}; P uses the landmark vertices"
            ))),
        ),
    }
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
    let first =
        shapes.iter().flatten().next().ok_or_else(|| Error::Invalid("no fitted shape".into()))?;
    let first = to_points(first);
    let renderer = crate::render::SideRenderer::new(&first, pitch_deg, facing, size[0], size[1])
        .ok_or_else(|| {
            Error::Invalid("the first fitted shape cannot be framed for a side render".into())
        })?;
    let setup = match renderer.profile_setup(&first, map) {
        Some(setup) => setup,
        None => {
            // No nose or subnasale vertex in the map: find them on the image instead.
            let render0 = renderer.render(&first, triangles)?;
            let mut setup =
                propose_setup(&image::imageops::grayscale(&render0), facing).map_err(|e| {
                    Error::Invalid(format!("side render of the first fitted shape: {e}"))
                })?;
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
            _ => {
                return Err(Error::Invalid(
                    "neither the model nor the head mesh has triangles to render".into(),
                ));
            }
        }
    };
    let shapes = super::fit::shapes_by_frame(&res.model, fits, n);
    let map = res.map.with_commissures_completed();
    head_p_by_render(&shapes, &triangles, &map, facing, pitch_deg, size)
        .with_context(|| format!("clip `{}`: head P from side renders", c.name))
}
