//! Creating a session and adding to one (`lipmap new`, `lipmap import`): read and check every
//! input first, then write, so a bad file leaves the session as it was.
//!
//! Start with [`create_session`] and [`import_into_session`]; [`read_clip`] reads one clip's
//! files into a [`Clip`].

use super::audio::{AudioInput, read_clip_audio};
use super::error::{Error, Result, Warning};
use super::map::check_map_to_use;
use super::resources::{check_map_for_fit, check_map_vertices};
use super::session::{clip_or_first, open_for_edit_at};
use super::track::{TrackerFiles, load_tracker, track_frames};
use crate::fit::FitSettings;
use crate::io::frames::{DEFAULT_FOLDER_FPS, FrameOptions, FrameSource};
use crate::io::textgrid::TierChoice;
use crate::io::{alignment_format, landmark_format, landmark_map_toml, model_source, obj};
use crate::landmarks::LandmarkSet;
use crate::model::{LandmarkMap, MapCheck, Mesh, check_map};
use crate::session::{
    Clip, FramesRef, MapRef, MapRole, ModelRef, Session, SessionLock, View, absolute,
};
use std::path::{Path, PathBuf};

/// One clip's input files.
#[derive(Clone, Debug, Default)]
pub struct ClipInputs {
    /// Front-view frames: a folder of images or a video file.
    pub frames: PathBuf,
    /// Frames per second (`None`: the video's, or [`DEFAULT_FOLDER_FPS`] for a folder).
    pub fps: Option<f64>,
    /// Where the landmarks come from.
    pub landmarks: LandmarkInput,
    /// A phone alignment and the TextGrid tier to read from it.
    pub alignment: Option<(PathBuf, Option<TierChoice>)>,
    /// Side-view frames, for protrusion.
    pub side: Option<SideInputs>,
    /// The clip's name (`None`: from the frames path, see [`default_clip_name`]).
    pub name: Option<String>,
    /// The clip's audio (for speech-driven animation).
    pub audio: Option<AudioInput>,
}

/// A clip's landmarks: a tracker's file, or tracked by lipmap on the clip's frames.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum LandmarkInput {
    /// Landmarks in any format lipmap reads.
    File(PathBuf),
    /// Tracked with lipmap's own tracker (`workflow::track`) from these files.
    Track(TrackerFiles),
}

impl Default for LandmarkInput {
    fn default() -> Self {
        Self::File(PathBuf::new())
    }
}

impl From<PathBuf> for LandmarkInput {
    fn from(p: PathBuf) -> Self {
        Self::File(p)
    }
}

/// A side view's frames and timing.
#[derive(Clone, Debug, Default)]
pub struct SideInputs {
    pub frames: PathBuf,
    /// Frames per second (`None`: the front view's).
    pub fps: Option<f64>,
    /// Seconds from the front view's frame 0 to the side view's frame 0.
    pub offset_s: f64,
}

/// What a new session is made of.
#[derive(Clone, Debug)]
pub struct NewSession {
    /// Where the session file goes.
    pub path: PathBuf,
    pub clip: ClipInputs,
    /// The head the motion drives: the model's own mesh, or another mesh that gets a map of
    /// its own.
    pub head: Option<PathBuf>,
    pub model: PathBuf,
    pub blendshapes: Option<PathBuf>,
    /// A landmark map file (eos TOML).
    pub mapping: Option<PathBuf>,
    /// The landmark set the fit uses.
    pub set: LandmarkSet,
    /// Replace an existing session file.
    pub force: bool,
    /// Use a map that fails the map checks (`lipmap map check`) anyway.
    pub accept_map_warnings: bool,
}

/// What to add to an existing session.
#[derive(Clone, Debug)]
pub struct Import {
    pub path: PathBuf,
    pub clip: Option<ClipInputs>,
    /// A landmark map file that replaces the session's map.
    pub mapping: Option<PathBuf>,
    /// Audio for an existing clip (named, or the first) when no clip is added.
    pub audio: Option<(AudioInput, Option<String>)>,
    /// A head mesh (OBJ) that becomes the session's head, replacing the one it named.
    pub head: Option<PathBuf>,
    /// A map file for a head that is another mesh than the model (its own map).
    pub head_mapping: Option<PathBuf>,
    /// Use a map that fails the map checks (`lipmap map check`) anyway.
    pub accept_map_warnings: bool,
}

/// Whether a session's map can be fitted with, as far as creating it can tell.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum MapState {
    /// No map was given.
    Missing,
    /// A map the fit can use, with this many landmarks.
    Usable(usize),
    /// A map the fit cannot use yet (the message says why and what to do).
    Problem(String),
}

/// A clip that was added: its name and how many frames of landmarks it has.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct AddedClip {
    pub name: String,
    pub frames: usize,
}

/// A session just created.
#[derive(Clone, Debug)]
pub struct Created {
    pub path: PathBuf,
    pub clip: AddedClip,
    pub map: MapState,
    /// The head, when one was given, and what its map is.
    pub head: Option<HeadMesh>,
    pub warnings: Vec<Warning>,
}

/// A session's head and whether it needs a map of its own.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct HeadMesh {
    pub file: PathBuf,
    pub vertices: usize,
    pub model_vertices: usize,
}

impl HeadMesh {
    /// Another mesh than the model: it needs its own map (the model's names other vertices).
    pub fn needs_own_map(&self) -> bool {
        self.vertices != self.model_vertices
    }
}

/// A map file set on a session, and what it replaced.
#[derive(Clone, Debug)]
pub struct MapSet {
    pub file: PathBuf,
    pub landmarks: usize,
    /// What the new map replaced.
    pub replaced: Vec<ReplacedMap>,
    /// Cached fits made with the previous map were dropped.
    pub fits_dropped: bool,
    /// Why the fit cannot use the new map yet (`None` when it can, or there is no model).
    pub problem: Option<String>,
}

/// A map that a new map file replaced.
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum ReplacedMap {
    /// The map labelled in the TUI, with this many landmarks.
    Labelled(usize),
    /// The map file the session named before.
    File(PathBuf),
}

/// A head mesh set on a session.
#[derive(Clone, Debug)]
pub struct HeadSet {
    pub file: PathBuf,
    pub vertices: usize,
    /// The head file the session named before.
    pub replaced: Option<PathBuf>,
    /// The head's map checked on the new head (`None`: no map yet): its own map when it is
    /// another mesh than the model, else the model's.
    pub map_check: Option<MapCheck>,
    /// The head is another mesh than the model and has (or needs) its own map.
    pub own_map: bool,
}

/// What an import changed.
#[derive(Clone, Debug)]
pub struct Imported {
    pub path: PathBuf,
    pub clip: Option<AddedClip>,
    pub map: Option<MapSet>,
    pub head: Option<HeadSet>,
    /// The head's own map file that was set, and its check on the head.
    pub head_map: Option<(PathBuf, MapCheck)>,
    /// The existing clip given audio, and the audio file.
    pub audio: Option<(String, PathBuf)>,
    pub warnings: Vec<Warning>,
}

/// Creates the session `new` describes, after reading and checking every input.
///
/// # Errors
/// The session exists (and `force` is off), any input that cannot be read (naming the
/// file), a map naming vertices the model lacks, or the session cannot be written.
pub fn create_session(new: &NewSession) -> Result<Created> {
    let path = &new.path;
    if path.exists() && !new.force {
        return Err(Error::Invalid(format!(
            "{}: already exists (use --force to replace it)",
            path.display()
        )));
    }
    let (mut clip, mut warnings) = read_clip(&new.clip)?;
    if let Some(audio) = &new.clip.audio {
        clip.audio = Some(read_clip_audio(&clip, path, audio)?);
    }
    let model = model_source::load_model(&new.model, new.blendshapes.as_deref())?;
    let map = new.mapping.as_deref().map(landmark_map_toml::read_landmark_map).transpose()?;
    if let (Some(map), Some(file)) = (&map, &new.mapping) {
        check_map_vertices(map, model.num_vertices(), Some(file))?;
        let accept = new.accept_map_warnings;
        warnings.extend(check_on_model_mean(map, file, &new.model, &model, accept)?);
    }
    let settings = FitSettings { set: new.set, ..FitSettings::default() };
    let head = match &new.head {
        Some(file) => Some(HeadMesh {
            file: file.clone(),
            vertices: obj::read_obj(file)?.vertices.len(),
            model_vertices: model.num_vertices(),
        }),
        None => None,
    };
    let _lock = SessionLock::acquire(path)?;
    let mut session = Session::new(path);
    session.write_data_early(path);
    session.head_mesh = new.head.as_deref().map(absolute);
    if head.as_ref().is_some_and(HeadMesh::needs_own_map) {
        session.head_map = Some(MapRef::default());
    }
    session.model = Some(ModelRef {
        path: absolute(&new.model),
        blendshapes: new.blendshapes.as_deref().map(absolute),
    });
    session.landmark_map.file = new.mapping.as_deref().map(absolute);
    session.fit_settings = settings.clone();
    let added = AddedClip { name: clip.name.clone(), frames: clip.tracked_summary().frames };
    session.add_clip(clip)?;
    session.save(path)?;
    // A journal of the session this one replaces (`--force`) holds that session's edits:
    // replayed onto this one it would be refused, or replace the edits of a clip that
    // happens to have the same name.
    crate::session::journal::Journal::new(path).clear()?;
    let map = match &map {
        None => MapState::Missing,
        Some(m) => match map_problem(m, model.num_vertices(), &settings, path) {
            None => MapState::Usable(m.len()),
            Some(problem) => MapState::Problem(problem),
        },
    };
    Ok(Created { path: path.clone(), clip: added, map, head, warnings })
}

/// Adds a clip, sets the landmark map and/or the head mesh of an existing session, under its
/// lock.
///
/// # Errors
/// Nothing to import, the session cannot be opened or locked, any input that cannot be read;
/// the session is then unchanged.
pub fn import_into_session(import: &Import) -> Result<Imported> {
    if import.clip.is_none()
        && import.mapping.is_none()
        && import.audio.is_none()
        && import.head.is_none()
        && import.head_mapping.is_none()
    {
        return Err(Error::Invalid(
            "give a clip to add (--frames and --landmarks), a landmark map (--mapping FILE), a head mesh (--head HEAD.obj) or a clip's audio (--audio FILE.wav)"
                .into(),
        ));
    }
    let path = &import.path;
    let mut opened = open_for_edit_at(path)?;
    let session = &mut opened.session;
    // Read everything before changing the session, so a bad input changes nothing.
    let (clip, mut warnings) = match &import.clip {
        Some(inputs) => {
            let (mut clip, warnings) = read_clip(inputs)?;
            if let Some(audio) = &inputs.audio {
                clip.audio = Some(read_clip_audio(&clip, path, audio)?);
            }
            (Some(clip), warnings)
        }
        None => (None, Vec::new()),
    };
    let audio = match (&import.clip, &import.audio) {
        (None, Some((input, name))) => {
            let index = clip_or_first(session, name.as_deref())?;
            let clip = session.clip(index)?;
            Some((index, clip.name.clone(), read_clip_audio(clip, path, input)?))
        }
        _ => None,
    };
    let model_vertices = match &session.model {
        Some(m) if import.head.is_some() || import.head_mapping.is_some() => {
            Some(model_source::load_model(&m.path, m.blendshapes.as_deref())?.num_vertices())
        }
        _ => None,
    };
    let head = match &import.head {
        Some(file) => Some((file, obj::read_obj(file)?)),
        None => None,
    };
    let accept = import.accept_map_warnings;
    let map = match import.mapping.as_deref() {
        Some(file) => {
            let (set, more) = set_map_from_file(session, file, path, accept)?;
            warnings.extend(more);
            Some(set)
        }
        None => None,
    };
    // Checked after a map given in the same import is set, so the check is of the pair the
    // session now holds.
    let head = match head {
        Some((file, mesh)) => Some(set_head(session, file, &mesh, model_vertices)?),
        None => None,
    };
    let head_map = match &import.head_mapping {
        Some(file) => {
            let (set, more) = set_head_map_from_file(session, file, accept)?;
            warnings.extend(more);
            Some(set)
        }
        None => None,
    };
    let clip = match clip {
        Some(clip) => {
            let added =
                AddedClip { name: clip.name.clone(), frames: clip.tracked_summary().frames };
            session.add_clip(clip)?;
            Some(added)
        }
        None => None,
    };
    let audio = audio.map(|(index, name, a)| {
        let file = a.file.clone();
        session.clips[index].audio = Some(a);
        (name, file)
    });
    // The journal's edits were restored on opening and are now in the file.
    warnings.splice(0..0, std::mem::take(&mut opened.notices));
    opened.save()?;
    Ok(Imported { path: path.clone(), clip, map, head, head_map, audio, warnings })
}

/// Makes `file` (already read as `mesh`) the session's head and checks the head's map on
/// it. A head with another vertex count than the model (`model_vertices`) is another mesh:
/// it gets a map of its own (kept when the same head is set again), and the model keeps its
/// map for fitting. Fits are of the model, not the head, so the fit cache stays.
fn set_head(
    session: &mut Session,
    file: &Path,
    mesh: &Mesh,
    model_vertices: Option<usize>,
) -> Result<HeadSet> {
    let file_abs = absolute(file);
    let replaced = session.head_mesh.replace(file_abs).filter(|old| *old != absolute(file));
    let own_map = model_vertices.is_some_and(|n| n != mesh.vertices.len());
    session.head_map = match (own_map, session.head_map.take()) {
        (false, _) => None,
        (true, Some(kept)) if replaced.is_none() => Some(kept),
        (true, _) => Some(MapRef::default()),
    };
    let map = session.map_of(MapRole::Head).resolve()?.filter(|m| !m.is_empty());
    Ok(HeadSet {
        file: file.to_path_buf(),
        vertices: mesh.vertices.len(),
        replaced,
        map_check: map.map(|m| check_map(&m, &mesh.vertices)),
        own_map,
    })
}

/// Sets the map file of a head that is another mesh than the model, after checking its
/// vertices exist on the head.
///
/// # Errors
/// No head, or a head that is the model's own mesh (its map is the model's, `--mapping`);
/// an unreadable map or head; a vertex the head lacks.
fn set_head_map_from_file(
    session: &mut Session,
    file: &Path,
    accept: bool,
) -> Result<((PathBuf, MapCheck), Vec<Warning>)> {
    let Some(head) = session.head_mesh.clone() else {
        return Err(Error::Invalid(
            "the session has no head: give it one with --head HEAD.obj".into(),
        ));
    };
    if !session.head_has_own_map() {
        return Err(Error::Invalid(format!(
            "{} is the model's own mesh: its map is the model's (--mapping FILE)",
            head.display()
        )));
    }
    let map = landmark_map_toml::read_landmark_map(file)?;
    let mesh = obj::read_obj(&head)?;
    check_map_vertices(&map, mesh.vertices.len(), Some(file))?;
    let shown = head.display().to_string();
    let warnings = check_map_to_use(&map, file, &shown, &mesh.vertices, &mesh.triangles(), accept)?;
    session.head_map = Some(MapRef { file: Some(absolute(file)), inline: None });
    Ok(((file.to_path_buf(), check_map(&map, &mesh.vertices)), warnings))
}

/// Reads one clip's files into a [`Clip`], checking them before anything is written; the
/// warnings say what was assumed or looks wrong.
///
/// # Errors
/// Any unreadable input, naming the file.
pub fn read_clip(inputs: &ClipInputs) -> Result<(Clip, Vec<Warning>)> {
    let mut warnings = Vec::new();
    let frames_path = &inputs.frames;
    let frames =
        FrameSource::open(frames_path, &FrameOptions { fps: inputs.fps, ..Default::default() })?;
    if frames_path.is_dir() && inputs.fps.is_none() {
        warnings.push(Warning(assumed_fps_notice(frames_path)));
    }
    let mut front = View::new(frames_ref(frames_path), frames.fps());
    front.size = Some(frames.size());
    let landmarks = match &inputs.landmarks {
        LandmarkInput::File(file) => file,
        LandmarkInput::Track(files) => {
            let tracked = track_frames(&load_tracker(files)?, &frames, &super::no_progress)?;
            if let Some(first) = tracked.lost.first() {
                warnings.push(Warning(format!(
                    "lipmap: warning: no face found on {} of {} (first: frame {first}); they have no landmarks: draw a face box there in `lipmap tui` (key b) to track from",
                    tracked.lost.len(),
                    frames_path.display()
                )));
            }
            let mut clip = Clip::new(
                inputs.name.clone().unwrap_or_else(|| default_clip_name(frames_path)),
                front,
            );
            clip.set_tracked(tracked.track);
            return finish_clip(clip, inputs, &frames, warnings);
        }
    };
    let tracked = landmark_format::read_track(landmarks)?;
    if tracked.is_empty() {
        return Err(Error::Invalid(format!("{}: no frames of landmarks", landmarks.display())));
    }
    // A probed frame count can be off by a frame or two (container estimates); more than
    // that past the end is landmarks for another clip, or a corrupt frame number.
    let slack = (frames.len() / 100).max(2);
    if let Some(last) = tracked.frames.last()
        && last.frame >= frames.len() + slack
    {
        return Err(Error::Invalid(format!(
            "{}: field `frame`: frame {} is past the end of {} ({} frames)",
            landmarks.display(),
            last.frame,
            frames_path.display(),
            frames.len()
        )));
    }
    if let Some(last) = tracked.frames.last()
        && last.frame >= frames.len()
    {
        warnings.push(Warning(format!(
            "lipmap: warning: {} has landmarks up to frame {} but {} has {} frames",
            landmarks.display(),
            last.frame,
            frames_path.display(),
            frames.len()
        )));
    }
    let name = inputs.name.clone().unwrap_or_else(|| default_clip_name(frames_path));
    let mut clip = Clip::new(name, front);
    clip.set_tracked(tracked);
    clip.landmarks_file = Some(absolute(landmarks));
    finish_clip(clip, inputs, &frames, warnings)
}

/// Adds the alignment and the side view to a clip whose landmarks are read.
fn finish_clip(
    mut clip: Clip,
    inputs: &ClipInputs,
    frames: &FrameSource,
    warnings: Vec<Warning>,
) -> Result<(Clip, Vec<Warning>)> {
    if let Some((file, tier)) = &inputs.alignment {
        clip.alignment = Some(alignment_format::read_alignment(file, tier.as_ref())?);
        clip.alignment_file = Some(absolute(file));
    }
    if let Some(side) = &inputs.side {
        let fps = side.fps.unwrap_or(frames.fps());
        let sf = FrameSource::open(
            &side.frames,
            &FrameOptions { fps: Some(fps), ..Default::default() },
        )?;
        let mut view = View::new(frames_ref(&side.frames), sf.fps());
        view.size = Some(sf.size());
        view.offset_s = side.offset_s;
        clip.side = Some(view);
    }
    Ok((clip, warnings))
}

/// How a session refers to frames at `path`: a folder of images or a video file.
fn frames_ref(path: &Path) -> FramesRef {
    if path.is_dir() {
        FramesRef::Images { dir: absolute(path) }
    } else {
        FramesRef::Video { file: absolute(path) }
    }
}

/// The notice given when an image folder's frame rate is assumed.
pub fn assumed_fps_notice(dir: &Path) -> String {
    format!(
        "lipmap: note: {} is a folder of images: assuming {DEFAULT_FOLDER_FPS} fps (set it with --fps)",
        dir.display()
    )
}

/// Folder names that say nothing about the clip; the folder above them names it instead.
const GENERIC_FRAME_DIRS: [&str; 8] =
    ["frames", "images", "imgs", "img", "png", "jpg", "front", "video"];

/// A clip's default name: a video's file stem, an image folder's name (its parent's when the
/// folder has a generic name such as `frames`).
pub fn default_clip_name(frames: &Path) -> String {
    let abs = absolute(frames);
    let name_of = |p: &Path| p.file_name().map(|s| s.to_string_lossy().into_owned());
    let name = if abs.is_dir() {
        match name_of(&abs) {
            Some(n) if GENERIC_FRAME_DIRS.contains(&n.to_ascii_lowercase().as_str()) => {
                abs.parent().and_then(name_of).unwrap_or(n)
            }
            other => other.unwrap_or_default(),
        }
    } else {
        abs.file_stem().map(|s| s.to_string_lossy().into_owned()).unwrap_or_default()
    };
    if name.is_empty() { "clip".into() } else { name }
}

/// How to give a session at `path` a map, for messages.
pub fn map_hint(path: &Path) -> String {
    super::error::NO_MAP_HINT.replace("SESSION", &path.display().to_string())
}

/// Why a fit with `settings` cannot use `map` yet, as a message line (`None` when it can).
fn map_problem(
    map: &LandmarkMap,
    n_vertices: usize,
    settings: &FitSettings,
    path: &Path,
) -> Option<String> {
    match check_map_for_fit(map, n_vertices, settings) {
        Ok(_) => None,
        Err(_) if map.is_empty() => {
            Some(format!("the landmark map maps no landmarks yet: {}", map_hint(path)))
        }
        Err(e) => Some(format!("warning: {e}")),
    }
}

/// Points the session's map at `file` (checked against the model when the session has one),
/// dropping any inline map labelled in the TUI and the cached fits made with another map.
fn set_map_from_file(
    session: &mut Session,
    file: &Path,
    path: &Path,
    accept: bool,
) -> Result<(MapSet, Vec<Warning>)> {
    let map = landmark_map_toml::read_landmark_map(file)?;
    let mut warnings = Vec::new();
    let n_vertices = match &session.model {
        Some(m) => {
            let model = model_source::load_model(&m.path, m.blendshapes.as_deref())?;
            check_map_vertices(&map, model.num_vertices(), Some(file))?;
            warnings = check_on_model_mean(&map, file, &m.path, &model, accept)?;
            Some(model.num_vertices())
        }
        None => None,
    };
    let old = session.landmark_map.clone();
    let previous = old.resolve().ok().flatten();
    let file_abs = absolute(file);
    let mut replaced = Vec::new();
    if let Some(inline) = old.inline_map() {
        replaced.push(ReplacedMap::Labelled(inline.len()));
    }
    if let Some(f) = old.file.as_ref().filter(|f| **f != file_abs) {
        replaced.push(ReplacedMap::File(f.clone()));
    }
    session.landmark_map.file = Some(file_abs);
    session.landmark_map.inline = None;
    // The cache is keyed by the map's file name, not its content: drop fits made with a
    // different map so a map edited in place is not mistaken for the old one.
    let fits_dropped =
        previous.is_some_and(|p| p.to_vertex != map.to_vertex) && session.has_cached_fits();
    if fits_dropped {
        session.clear_fit_cache();
    }
    let problem = n_vertices.and_then(|n| map_problem(&map, n, &session.fit_settings, path));
    let set =
        MapSet { file: file.to_path_buf(), landmarks: map.len(), replaced, fits_dropped, problem };
    Ok((set, warnings))
}

/// The map checks of a model map file on the model's mean shape ([`check_map_to_use`]).
///
/// # Errors
/// As [`check_map_to_use`].
fn check_on_model_mean(
    map: &LandmarkMap,
    file: &Path,
    model_file: &Path,
    model: &crate::model::MorphableModel,
    accept: bool,
) -> Result<Vec<Warning>> {
    let shown = format!("the mean of {}", model_file.display());
    check_map_to_use(map, file, &shown, &model.mean_mesh().vertices, &model.triangles, accept)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn clips_are_named_after_the_video_or_the_frames_folder() {
        let dir = tempfile::tempdir().unwrap();
        let frames = dir.path().join("carphone").join("frames");
        std::fs::create_dir_all(&frames).unwrap();
        let takes = dir.path().join("take_03");
        std::fs::create_dir_all(&takes).unwrap();
        assert_eq!(default_clip_name(&frames), "carphone");
        assert_eq!(default_clip_name(&takes), "take_03");
        assert_eq!(default_clip_name(Path::new("clips/s2_front.mp4")), "s2_front");
    }

    #[test]
    fn an_import_with_nothing_to_import_is_refused_before_the_session_is_touched() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("s.lipmap.json");
        let e = import_into_session(&Import {
            path: path.clone(),
            clip: None,
            mapping: None,
            audio: None,
            head: None,
            head_mapping: None,
            accept_map_warnings: false,
        })
        .unwrap_err();
        assert!(e.to_string().contains("--mapping FILE"), "{e}");
        assert!(e.to_string().contains("--head HEAD.obj"), "{e}");
        assert!(!path.exists() && std::fs::read_dir(dir.path()).unwrap().next().is_none());
    }
}
