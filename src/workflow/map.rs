//! The landmark maps' use cases: which mesh needs labelling ([`label_role`]: the model, or a
//! head that is another mesh with its own map), the mesh a map is labelled on, checking a
//! map against anatomy on its own mesh, and suggesting a whole map from the labels made so
//! far (`lipmap map suggest`, the TUI's `O`).
//!
//! Start with [`label_role`], [`suggest_session_map`] and [`check_session_map`].

use super::error::{Error, Result};
use super::session::{clip_or_first, image_height};
use crate::fit::map_suggest::{MapProposal, suggest_map, suggest_map_on_own_face};
use crate::fit::suggest::{SuggestHead, surface_triangles};
use crate::io::{model_source, obj};
use crate::landmarks::FrameLandmarks;
use crate::math::Point3;
use crate::model::map_check::check_map_on_surface;
use crate::model::{LandmarkMap, MapCheck, check_map};
use crate::session::{MapRole, Session};
use std::path::Path;

/// The head a session's map is labelled on: its vertices, triangles, and which vertices may
/// carry a landmark (`None`: all; a MakeHuman figure's helper and joint geometry may not).
#[derive(Clone, Debug)]
pub struct LabelHead {
    pub vertices: Vec<Point3>,
    pub triangles: Vec<[u32; 3]>,
    pub eligible: Option<Vec<bool>>,
}

impl LabelHead {
    /// As the suggester sees it (`triangles` are already those that hide what is behind).
    pub fn as_suggest_head(&self) -> SuggestHead<'_> {
        SuggestHead {
            vertices: &self.vertices,
            triangles: &self.triangles,
            eligible: self.eligible.as_deref(),
        }
    }
}

/// The mesh that needs labelling first: the model while its map maps nothing (a fit needs
/// it), else a head with its own map (what transfer and indices read), else the model (whose
/// map is then the head's too).
pub fn label_role(session: &Session) -> MapRole {
    let empty =
        |r: &crate::session::MapRef| r.resolve().ok().flatten().is_none_or(|m| m.is_empty());
    if session.model.is_some() && empty(&session.landmark_map) {
        MapRole::Model
    } else if session.head_has_own_map() {
        MapRole::Head
    } else {
        MapRole::Model
    }
}

/// The mesh to label when the user asked for `wanted`: that one when the session has its
/// map (a head's own map needs a head that is another mesh than the model), else
/// [`label_role`]'s choice.
pub fn label_role_or(session: &Session, wanted: Option<MapRole>) -> MapRole {
    match wanted {
        Some(MapRole::Head) if session.head_has_own_map() => MapRole::Head,
        Some(MapRole::Model) if session.model.is_some() => MapRole::Model,
        _ => label_role(session),
    }
}

/// The mesh file the map of `role` names vertices of: the head OBJ for a head with its own
/// map; for the model, its head mesh when that is the model's own mesh, else the model file.
pub fn mesh_file_of(session: &Session, role: MapRole) -> Option<&Path> {
    let model = session.model.as_ref().map(|m| m.path.as_path());
    match role {
        MapRole::Head => session.head_mesh.as_deref().or(model),
        MapRole::Model if session.head_has_own_map() => model,
        MapRole::Model => session.head_mesh.as_deref().or(model),
    }
}

/// The mesh the map of `role` is labelled on ([`mesh_file_of`]): an OBJ as it is, a model
/// as its mean shape.
///
/// # Errors
/// Neither a head nor a model ([`Error::NoModel`]); a file that does not parse.
pub fn label_mesh(session: &Session, role: MapRole) -> Result<LabelHead> {
    let is_obj = |p: &Path| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("obj"));
    let source = mesh_file_of(session, role).ok_or(Error::NoModel)?.to_path_buf();
    let (vertices, triangles) = match (&session.model, is_obj(&source)) {
        (Some(m), _) if m.path == source => {
            let model = model_source::load_model(&m.path, m.blendshapes.as_deref())?;
            (model.mean_mesh().vertices, model.triangles.clone())
        }
        _ => {
            let mesh = obj::read_obj(&source)?;
            let tris = mesh.triangles();
            (mesh.vertices, tris)
        }
    };
    let (eligible, occluding) = if is_obj(&source) {
        (obj::labelable_vertices(&source)?, obj::occluding_vertices(&source)?)
    } else {
        (None, None)
    };
    let triangles = surface_triangles(&triangles, occluding.as_deref());
    Ok(LabelHead { vertices, triangles, eligible })
}

/// The map of `role` checked on its own mesh; `None` when it maps nothing.
///
/// # Errors
/// As [`label_mesh`]; a map file that does not parse.
pub fn check_session_map(session: &Session, role: MapRole) -> Result<Option<MapCheck>> {
    let Some(map) = session.map_of(role).resolve()?.filter(|m| !m.is_empty()) else {
        return Ok(None);
    };
    let head = label_mesh(session, role)?;
    Ok(Some(check_map_on_surface(&map, &head.vertices, &head.triangles)))
}

/// The checks of `lipmap map check` on a map file about to be used (`import --mapping`,
/// `new --mapping`, `transfer --mapping`) on the mesh `mesh` names (its vertices and
/// faces): refused with every problem listed unless `accept`, when they come back as
/// warnings to show.
///
/// # Errors
/// [`Error::MapRefused`] naming the file, the mesh and the problems.
pub fn check_map_to_use(
    map: &LandmarkMap,
    file: &Path,
    mesh: &str,
    vertices: &[Point3],
    triangles: &[[u32; 3]],
    accept: bool,
) -> Result<Vec<super::Warning>> {
    let check = check_map_on_surface(map, vertices, triangles);
    let problems: Vec<String> = check.problems.iter().map(ToString::to_string).collect();
    if problems.is_empty() {
        return Ok(Vec::new());
    }
    if !accept {
        return Err(Error::MapRefused {
            file: file.to_path_buf(),
            mesh: mesh.to_string(),
            problems,
        });
    }
    Ok(problems
        .iter()
        .map(|p| {
            super::Warning(format!(
                "lipmap: warning: {}: going on with a map problem on {mesh}: {p}",
                file.display()
            ))
        })
        .collect())
}

/// What the suggestions were matched to.
#[derive(Clone, Debug, PartialEq)]
pub enum SuggestedFrom {
    /// The head's own face, drawn from the front and read by the shape predictor.
    OwnFace,
    /// A frame of the clip (its number), the speaker's tracked landmarks; with why the
    /// head's own face was not used when it was not asked for.
    Frame(usize, Option<String>),
}

impl std::fmt::Display for SuggestedFrom {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::OwnFace => {
                write!(f, "the head's own face (drawn from the front, shape predictor)")
            }
            Self::Frame(n, None) => write!(f, "frame {n}"),
            Self::Frame(n, Some(why)) => write!(f, "frame {n} ({why})"),
        }
    }
}

/// What [`suggest_session_map`] made.
#[derive(Clone, Debug, PartialEq)]
pub struct SuggestedMap {
    /// What the suggestions were matched to.
    pub from: SuggestedFrom,
    /// The labels they were made from.
    pub labels: LandmarkMap,
    pub proposal: MapProposal,
    /// The labels with the accepted suggestions.
    pub map: LandmarkMap,
    pub check: MapCheck,
}

/// What suggestions are matched to, as a front asks: the head's own face read by dlib's
/// shape predictor, or a frame of the clip (`None`: its first frame with the most visible
/// landmarks) with why the head's own face was not used when it was wanted.
#[derive(Clone, Copy, Debug)]
pub enum MatchTo<'a> {
    OwnFace(&'a crate::track::ShapePredictor),
    Frame(Option<usize>, Option<&'a str>),
}

/// dlib's shape predictor for suggestions on the head's own face: `given` (an error when it
/// cannot be read), else Debian's file; when that cannot be read either, `Ok(Err(why))`,
/// the one line both fronts show when they match to the speaker instead.
///
/// # Errors
/// A `given` predictor that cannot be read.
pub fn read_suggestion_predictor(
    given: Option<&Path>,
) -> Result<std::result::Result<crate::track::ShapePredictor, String>> {
    if let Some(p) = given {
        return Ok(Ok(crate::track::read_shape_predictor(p)?));
    }
    let p = Path::new(crate::track::DEBIAN_PREDICTOR_PATH);
    Ok(crate::track::read_shape_predictor(p).map_err(|_| {
        format!(
            "no shape predictor at {} (Debian `libdlib-data`, or `--predictor`): matched to \
             the speaker instead of the head's own face",
            p.display()
        )
    }))
}

/// Suggests the rest of the map of `role` from its labels: on the head's own face
/// ([`crate::fit::own_face`]) when `frame` is `None` and dlib's shape predictor can be read
/// (`predictor`, else Debian's path), else on `frame` of `clip` (default: the clip's first
/// frame with the most visible landmarks) with the pose estimated from the labels. The
/// speaker in a frame is another face than the head; the head's own face is the head.
///
/// # Errors
/// No map or too few labels for a pose; an unknown clip or a frame without landmarks; a head
/// or model file that does not parse; a `predictor` given that cannot be read.
pub fn suggest_session_map(
    session: &Session,
    role: MapRole,
    clip: Option<&str>,
    frame: Option<usize>,
    predictor: Option<&Path>,
) -> Result<SuggestedMap> {
    let labels = session.map_of(role).resolve()?.unwrap_or_default();
    let read = match frame {
        Some(_) => None,
        None => Some(read_suggestion_predictor(predictor)?),
    };
    let to = match &read {
        None => MatchTo::Frame(frame, None),
        Some(Ok(p)) => MatchTo::OwnFace(p),
        Some(Err(why)) => MatchTo::Frame(None, Some(why)),
    };
    suggest_map_from_labels(session, role, labels, clip, to)
}

/// The use case both fronts call (`lipmap map suggest` through [`suggest_session_map`], the
/// TUI's `o` and `O` with the labels it holds): the rest of the map of `role` suggested from
/// `labels`, matched as `to` says; a head with no faces to draw is matched to the speaker.
///
/// # Errors
/// As [`suggest_session_map`].
pub fn suggest_map_from_labels(
    session: &Session,
    role: MapRole,
    labels: LandmarkMap,
    clip: Option<&str>,
    to: MatchTo<'_>,
) -> Result<SuggestedMap> {
    let head = label_mesh(session, role)?;
    let (frame, why_not_own) = match to {
        MatchTo::OwnFace(_) if head.triangles.is_empty() => {
            (None, Some("the head has no faces to draw: matched to the speaker".to_string()))
        }
        MatchTo::OwnFace(predictor) => return suggest_on_own_face(&head, labels, predictor),
        MatchTo::Frame(frame, why) => (frame, why.map(str::to_string)),
    };
    let c = clip_or_first(session, clip)?;
    let landmarks = match frame {
        Some(n) => session
            .effective_frame(c, n)?
            .ok_or_else(|| Error::Invalid(format!("frame {n} has no landmarks in the clip")))?,
        None => best_frame(session, c)?
            .ok_or_else(|| Error::Invalid("the clip has no frame with landmarks".into()))?,
    };
    let h = image_height(session, c)?;
    let proposal = suggest_map(&head.as_suggest_head(), &labels, &landmarks, h, None)
        .map_err(|e| suggest_error(&format!("frame {}", landmarks.frame), &e))?;
    let map = proposal.applied_to(&labels);
    let check = check_map(&map, &head.vertices);
    let from = SuggestedFrom::Frame(landmarks.frame, why_not_own);
    Ok(SuggestedMap { from, labels, proposal, map, check })
}

/// The suggestions on the head's own face.
fn suggest_on_own_face(
    head: &LabelHead,
    labels: LandmarkMap,
    predictor: &crate::track::ShapePredictor,
) -> Result<SuggestedMap> {
    let proposal = suggest_map_on_own_face(&head.as_suggest_head(), &labels, predictor)
        .map_err(|e| suggest_error("the head's own face", &e))?;
    let map = proposal.applied_to(&labels);
    let check = check_map(&map, &head.vertices);
    Ok(SuggestedMap { from: SuggestedFrom::OwnFace, labels, proposal, map, check })
}

/// A suggestion's failure, naming what it was matched to; where labels are made is the
/// front's to say (the TUI is where they are made, the command line has no way to).
fn suggest_error(on: &str, e: &crate::fit::suggest::SuggestError) -> Error {
    Error::Suggest { on: on.to_string(), error: e.clone() }
}

/// The first frame with the most visible landmarks.
///
/// # Errors
/// The clip's track cannot be read.
fn best_frame(session: &Session, clip: usize) -> Result<Option<FrameLandmarks>> {
    let visible = |f: &FrameLandmarks| f.points.iter().filter(|p| p.visible).count();
    let track = session.effective_track(clip)?;
    Ok(track
        .frames
        .into_iter()
        .reduce(|best, f| if visible(&f) > visible(&best) { f } else { best }))
}
