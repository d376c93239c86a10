//! What a session's fits need, loaded once (model, landmark map, head mesh), and the checks
//! a landmark map must pass before anything is fitted.

use super::error::{Error, Result, Warning};
use crate::fit::FitSettings;
use crate::fit::shape::is_usable_landmark;
use crate::io::{model_source, obj};
use crate::model::{LandmarkMap, Mesh, MorphableModel};
use crate::session::Session;
use std::path::{Path, PathBuf};

/// What a session's fits need, loaded once: the model, the model's landmark map and the
/// head mesh (with its own map when it is another mesh than the model).
#[derive(Clone, Debug)]
pub struct Resources {
    pub model: MorphableModel,
    pub map: LandmarkMap,
    pub head: Option<Mesh>,
    /// The head's own map, when the head is another mesh than the model (`None`: `map`
    /// serves both, or the head has no map yet).
    pub head_map: Option<LandmarkMap>,
    /// Fit even when the model map fails the anatomy check ([`check_before_fit`]).
    pub accept_map_warnings: bool,
}

impl Resources {
    /// Loads the session's model (with blendshapes), landmark map and head mesh.
    ///
    /// # Errors
    /// [`Error::NoModel`], [`Error::NoMap`]; any file's `FormatError` (file and line); a map
    /// naming vertices the model lacks ([`check_map_vertices`]).
    pub fn load(session: &Session) -> Result<Self> {
        let mref = session.model.as_ref().ok_or(Error::NoModel)?;
        let model = model_source::load_model(&mref.path, mref.blendshapes.as_deref())?;
        let map = session
            .landmark_map
            .resolve()?
            .filter(|m| !m.is_empty())
            .ok_or(Error::NoMap { session: None })?;
        // An inline map (labelled in the TUI) has no file to name.
        let map_file = match &session.landmark_map.inline {
            Some(_) => None,
            None => session.landmark_map.file.as_deref(),
        };
        check_map_vertices(&map, model.num_vertices(), map_file)?;
        let head = session.head_mesh.as_deref().map(obj::read_obj).transpose()?;
        let head_map = match &session.head_map {
            Some(r) => r.resolve()?.filter(|m| !m.is_empty()),
            None => None,
        };
        Ok(Self { model, map, head, head_map, accept_map_warnings: false })
    }
}

/// The session's fit resources for a front that names the session by `path` (`fit`, `eval`,
/// `export`): [`Resources::load`] with the no-map hint naming the session, and a warning when
/// a map labelled in the TUI shadows a map file that now differs ([`shadowed_map_file`]).
///
/// # Errors
/// As [`Resources::load`].
pub fn load_resources(session: &Session, path: &Path) -> Result<(Resources, Vec<Warning>)> {
    let warnings = shadowed_map_file(session)
        .map(|file| {
            Warning(format!(
                "lipmap: warning: the map labelled in the TUI is used, not {} (which differs); \
                 to use the file instead: lipmap import {} --mapping {}",
                file.display(),
                path.display(),
                file.display()
            ))
        })
        .into_iter()
        .collect();
    let res = Resources::load(session).map_err(|e| e.in_session(path))?;
    Ok((res, warnings))
}

/// A landmark map naming a vertex the model lacks. Landmarks are reported as the eos map
/// file writes them (1-based iBUG ids), vertices 0-based as in the file.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error(
    "{}: landmark {} maps to vertex {vertex} but the model has {n_vertices} vertices",
    map.as_ref().map_or_else(|| "landmark map".to_string(), |p| p.display().to_string()),
    crate::landmarks::PointNo(*.landmark)
)]
pub struct MapRangeError {
    /// The map file, when the map came from one.
    pub map: Option<PathBuf>,
    /// 0-based iBUG id (shown 1-based).
    pub landmark: usize,
    pub vertex: usize,
    pub n_vertices: usize,
}

/// Checks that every vertex `map` names exists on a model of `n_vertices` vertices; the one
/// range check for `new`, `import`, head folders, files-mode fits and [`Resources::load`].
/// `file` is the map's file, named in the error.
///
/// # Errors
/// The first (lowest landmark) pair out of range.
pub fn check_map_vertices(
    map: &LandmarkMap,
    n_vertices: usize,
    file: Option<&Path>,
) -> Result<(), MapRangeError> {
    match map.pairs().find(|&(_, v)| v >= n_vertices) {
        Some((landmark, vertex)) => {
            Err(MapRangeError { map: file.map(Path::to_path_buf), landmark, vertex, n_vertices })
        }
        None => Ok(()),
    }
}

/// Fewest mapped landmarks a fit can work with: the affine camera needs 4 point pairs
/// (`fit::camera`), and `fit::clip` fails every frame with fewer usable points.
pub const MIN_FIT_LANDMARKS: usize = 4;

/// Why a landmark map cannot drive a fit, found before any frame is fitted.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum MapCheckError {
    /// The map maps nothing.
    #[error("{}", super::error::no_map_message(None))]
    Empty,
    /// Fewer than [`MIN_FIT_LANDMARKS`] of the fit's landmark set are mapped.
    #[error(
        "the landmark map has {usable} landmark{} of set {set}; a fit needs at least {MIN_FIT_LANDMARKS}",
        if *usable == 1 { "" } else { "s" }
    )]
    TooFew { usable: usize, set: crate::landmarks::LandmarkSet },
}

/// Checks `map` against the landmarks a fit with `settings` uses on a model of `n_vertices`
/// vertices (the fit's own rule, `fit::shape::is_usable_landmark`) and returns how many it
/// can use. One check per clip instead of one identical failure per frame; the TUI calls it
/// before starting a fit.
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
        .filter(|&(l, v)| {
            is_usable_landmark(l, v, n_vertices, settings.set, &settings.landmark_weights)
        })
        .count();
    if usable < MIN_FIT_LANDMARKS {
        return Err(MapCheckError::TooFew { usable, set: settings.set });
    }
    Ok(usable)
}

/// Why a fit must not start: a map it cannot use ([`check_map_for_fit`]) or one that fails
/// the anatomy check on the model's mean (`lipmap map check`) and was not accepted.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum FitRefusal {
    #[error(transparent)]
    Unusable(#[from] MapCheckError),
    /// The map's problems, one line each, as `lipmap map check` lists them.
    #[error(
        "the model map fails the anatomy check: {}; fix it (TUI view 2, `lipmap map suggest`) or fit anyway with --accept-map-warnings",
        problems_summary(problems)
    )]
    Implausible { problems: Vec<String> },
}

/// "N problems: the first; the second; and N-2 more", for a one-line message.
pub fn problems_summary(problems: &[String]) -> String {
    match problems {
        [] => "no problem".into(),
        [p] => format!("1 problem: {p}"),
        [p, q] => format!("2 problems: {p}; {q}"),
        [p, q, rest @ ..] => {
            format!("{} problems: {p}; {q}; and {} more", problems.len(), rest.len())
        }
    }
}

/// The one rule for "can this be fitted", for both fronts: the map must be usable by a fit
/// with `settings` ([`check_map_for_fit`]) and plausible on the model's mean shape
/// ([`crate::model::check_map`]: no shared vertices, no left/right crossings, human
/// proportions) unless `accept_map_warnings`. Returns the problems accepted (empty when the
/// map is plausible).
///
/// # Errors
/// [`FitRefusal`].
pub fn check_before_fit(
    model: &MorphableModel,
    map: &LandmarkMap,
    settings: &FitSettings,
    accept_map_warnings: bool,
) -> Result<Vec<String>, FitRefusal> {
    check_map_for_fit(map, model.num_vertices(), settings)?;
    let problems: Vec<String> = crate::model::check_map(map, &model.mean_mesh().vertices)
        .problems
        .iter()
        .map(ToString::to_string)
        .collect();
    if !problems.is_empty() && !accept_map_warnings {
        return Err(FitRefusal::Implausible { problems });
    }
    Ok(problems)
}

/// The session's map file when an inline map (labelled in the TUI) shadows it and the file
/// now says something else: fits use the inline map, and the user should know the file is
/// ignored. `None` when there is no inline map, no file, they agree, or the file maps
/// nothing (a blank template the labelling started from); an unreadable file is reported.
pub fn shadowed_map_file(session: &Session) -> Option<PathBuf> {
    let r = &session.landmark_map;
    let (inline, file) = (r.inline_map()?, r.file.as_ref()?);
    match crate::io::landmark_map_toml::read_landmark_map(file) {
        Ok(m) if m.is_empty() || m.to_vertex == inline.to_vertex => None,
        _ => Some(file.clone()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn out_of_range_vertices_are_named_with_one_based_ids() {
        let mut map = LandmarkMap::default();
        map.to_vertex.insert(47, 10);
        map.to_vertex.insert(48, 3);
        assert_eq!(check_map_vertices(&map, 11, None), Ok(()));
        let e = check_map_vertices(&map, 10, Some(Path::new("m.toml"))).unwrap_err();
        assert_eq!((e.landmark, e.vertex), (47, 10));
        assert_eq!(
            e.to_string(),
            "m.toml: landmark 48 maps to vertex 10 but the model has 10 vertices"
        );
        let e = check_map_vertices(&map, 2, None).unwrap_err();
        assert!(e.to_string().starts_with("landmark map: landmark 48 maps to vertex 10"), "{e}");
    }
}
