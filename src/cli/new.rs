//! `lipmap new` and `lipmap import`: create a session from frames, tracked landmarks, a phone
//! alignment, a head mesh, a model and (optionally) a landmark map; add clips or set the map
//! later.

use crate::cli::output::plural;
use crate::cli::phones::tier_choice;
use crate::fit::FitSettings;
use crate::io::frames::{DEFAULT_FOLDER_FPS, FrameOptions, FrameSource};
use crate::io::{alignment_format, landmark_format, landmark_map_toml, model_source, obj};
use crate::landmarks::LandmarkSet;
use crate::model::LandmarkMap;
use crate::session::{Clip, FramesRef, ModelRef, Session, SessionLock, View};
use crate::workflow::{check_map_for_fit, check_map_vertices, load_session, session_path};
use anyhow::{Result, bail};
use std::path::{Path, PathBuf};

/// One clip's inputs. `--frames` and `--landmarks` are optional here only so that
/// `lipmap import SESSION --mapping FILE` can leave the clip out (clap still requires fields
/// of an optional flattened struct); `lipmap new` makes them required (see `cli::Command`),
/// and any other clip option needs them.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct ClipArgs {
    /// Front-view frames: a folder of images (PNG/JPEG/PPM) or a video file (needs ffmpeg).
    #[arg(long, requires = "landmarks")]
    pub frames: Option<PathBuf>,
    /// Frames per second (default: the video's, or 25 for an image folder, with a notice).
    #[arg(long, requires = "frames")]
    pub fps: Option<f64>,
    /// Tracked landmarks: .pts file or folder, OpenFace CSV, dlib XML, lipmap CSV.
    #[arg(long, requires = "frames")]
    pub landmarks: Option<PathBuf>,
    /// Phone alignment: TextGrid, HTK/Festival .lab, or start,end,phone CSV.
    #[arg(long, requires = "frames")]
    pub alignment: Option<PathBuf>,
    /// TextGrid tier (name or 1-based number).
    #[arg(long, requires = "alignment")]
    pub tier: Option<String>,
    /// Side-view frames (folder or video), for protrusion.
    #[arg(long, requires = "frames")]
    pub side_frames: Option<PathBuf>,
    /// Side-view frames per second (default: the front view's).
    #[arg(long, requires = "side_frames")]
    pub side_fps: Option<f64>,
    /// Seconds from the front view's frame 0 to the side view's frame 0 (default 0).
    #[arg(long, allow_hyphen_values = true, requires = "side_frames")]
    pub side_offset: Option<f64>,
    /// Clip name (default: the video's file name, or the frames folder's name; the folder
    /// above it when the folder is called e.g. `frames` or `images`).
    #[arg(long, requires = "frames")]
    pub clip: Option<String>,
}

impl ClipArgs {
    /// Whether a clip was given at all.
    pub fn is_given(&self) -> bool {
        self.frames.is_some() || self.landmarks.is_some()
    }

    /// The front frames and landmarks paths, which every clip needs.
    ///
    /// # Errors
    /// Either is missing.
    pub fn inputs(&self) -> Result<(&Path, &Path)> {
        match (&self.frames, &self.landmarks) {
            (Some(f), Some(l)) => Ok((f, l)),
            _ => bail!("a clip needs --frames and --landmarks"),
        }
    }
}

/// Create a session.
#[derive(clap::Args, Debug)]
pub struct NewArgs {
    /// Session file, or a bare name for sessions/NAME.lipmap.json.
    pub session: String,
    #[command(flatten)]
    pub clip: ClipArgs,
    /// Head mesh (OBJ) whose vertices the landmark map names.
    #[arg(long)]
    pub head: Option<PathBuf>,
    /// Morphable model: eos .bin, .npz, folder of .npy parts, lipmap model, folder of pose OBJs.
    #[arg(long)]
    pub model: PathBuf,
    /// Expression blendshapes (eos .bin, folder of .target or OBJ).
    #[arg(long)]
    pub blendshapes: Option<PathBuf>,
    /// Landmark map in eos TOML format (iBUG ids 1-based). Optional: the head can be labelled
    /// in the TUI (view 2), or a map set later with `lipmap import SESSION --mapping FILE`.
    #[arg(long)]
    pub mapping: Option<PathBuf>,
    /// Landmark set for fitting.
    #[arg(long, default_value = "F4")]
    pub set: LandmarkSet,
    /// Overwrite an existing session file.
    #[arg(long)]
    pub force: bool,
}

/// Add a clip to an existing session, and/or set or replace its landmark map.
#[derive(clap::Args, Debug)]
pub struct ImportArgs {
    /// Session file or name.
    pub session: String,
    /// The clip to add (--frames and --landmarks; leave out to only set the map).
    #[command(flatten)]
    pub clip: ClipArgs,
    /// Set the session's landmark map to this eos TOML file, replacing the map file it named
    /// and any map labelled in the TUI.
    #[arg(long)]
    pub mapping: Option<PathBuf>,
}

/// Reads one clip's files into a `Clip`, checking them before anything is written.
///
/// # Errors
/// Any unreadable input, naming the file.
pub fn read_clip(a: &ClipArgs) -> Result<Clip> {
    let (frames_path, landmarks) = a.inputs()?;
    let opts = FrameOptions { fps: a.fps, ..FrameOptions::default() };
    let frames = FrameSource::open(frames_path, &opts)?;
    if frames_path.is_dir() && a.fps.is_none() {
        eprintln!("{}", assumed_fps_notice(frames_path));
    }
    let source = if frames_path.is_dir() {
        FramesRef::Images { dir: crate::session::absolute(frames_path) }
    } else {
        FramesRef::Video { file: crate::session::absolute(frames_path) }
    };
    let mut front = View::new(source, frames.fps());
    front.size = Some(frames.size());
    let tracked = landmark_format::read_track(landmarks)?;
    if tracked.is_empty() {
        bail!("{}: no frames of landmarks", landmarks.display());
    }
    if let Some(last) = tracked.frames.last()
        && last.frame >= frames.len()
    {
        eprintln!(
            "lipmap: warning: {} has landmarks up to frame {} but {} has {} frames",
            landmarks.display(),
            last.frame,
            frames_path.display(),
            frames.len()
        );
    }
    let name = a.clip.clone().unwrap_or_else(|| default_clip_name(frames_path));
    let mut clip = Clip::new(name, front);
    clip.tracked = tracked;
    clip.landmarks_file = Some(crate::session::absolute(landmarks));
    if let Some(al) = &a.alignment {
        let tier = a.tier.as_deref().map(tier_choice);
        clip.alignment = Some(alignment_format::read_alignment(al, tier.as_ref())?);
        clip.alignment_file = Some(crate::session::absolute(al));
    }
    if let Some(side) = &a.side_frames {
        let fps = a.side_fps.unwrap_or(frames.fps());
        let sopts = FrameOptions { fps: Some(fps), ..FrameOptions::default() };
        let sf = FrameSource::open(side, &sopts)?;
        let source = if side.is_dir() {
            FramesRef::Images { dir: crate::session::absolute(side) }
        } else {
            FramesRef::Video { file: crate::session::absolute(side) }
        };
        let mut view = View::new(source, sf.fps());
        view.size = Some(sf.size());
        view.offset_s = a.side_offset.unwrap_or(0.0);
        clip.side = Some(view);
    }
    Ok(clip)
}

/// The notice printed when an image folder's frame rate is assumed.
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
    let abs = crate::session::absolute(frames);
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

pub fn run_new(a: &NewArgs) -> Result<String> {
    let path = session_path(&a.session);
    if path.exists() && !a.force {
        bail!("{}: already exists (use --force to replace it)", path.display());
    }
    // Read and check every input before writing anything.
    let clip = read_clip(&a.clip)?;
    let model = model_source::load_model(&a.model, a.blendshapes.as_deref())?;
    let map = a.mapping.as_deref().map(landmark_map_toml::read_landmark_map).transpose()?;
    if let (Some(map), Some(file)) = (&map, &a.mapping) {
        check_map_vertices(map, model.num_vertices(), Some(file))?;
    }
    let settings = FitSettings { set: a.set, ..FitSettings::default() };
    if let Some(head) = &a.head {
        let mesh = obj::read_obj(head)?;
        if mesh.vertices.len() != model.num_vertices() {
            eprintln!(
                "lipmap: warning: {} has {} vertices but the model has {}",
                head.display(),
                mesh.vertices.len(),
                model.num_vertices()
            );
        }
    }
    let _lock = SessionLock::acquire(&path)?;
    let mut session = Session::new(&path);
    session.head_mesh = a.head.as_deref().map(crate::session::absolute);
    session.model = Some(ModelRef {
        path: crate::session::absolute(&a.model),
        blendshapes: a.blendshapes.as_deref().map(crate::session::absolute),
    });
    session.landmark_map.file = a.mapping.as_deref().map(crate::session::absolute);
    session.fit_settings = settings.clone();
    let frames = clip.tracked.len();
    let name = clip.name.clone();
    session.add_clip(clip)?;
    session.save(&path)?;
    let mut msg = format!(
        "{}: new session, clip `{name}` with {} of landmarks",
        path.display(),
        plural(frames, "frame")
    );
    match &map {
        None => msg.push_str(&format!("\nno landmark map yet: {}", map_hint(&path))),
        Some(m) => match map_problem(m, model.num_vertices(), &settings, &path) {
            None => msg.push_str(&format!(", {} mapped", plural(m.len(), "landmark"))),
            Some(problem) => msg.push_str(&format!("\n{problem}")),
        },
    }
    Ok(msg)
}

/// How to give a session at `path` a map, for messages.
fn map_hint(path: &Path) -> String {
    format!(
        "label the head in the TUI (view 2) or `lipmap import {} --mapping FILE`",
        path.display()
    )
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

pub fn run_import(a: &ImportArgs) -> Result<String> {
    if !a.clip.is_given() && a.mapping.is_none() {
        bail!("give a clip to add (--frames and --landmarks) or a landmark map (--mapping FILE)");
    }
    let path = session_path(&a.session);
    let _lock = SessionLock::acquire(&path)?;
    let mut session = load_session(&path)?;
    // Read everything before changing the session, so a bad input changes nothing.
    let clip = a.clip.is_given().then(|| read_clip(&a.clip)).transpose()?;
    let mut lines = Vec::new();
    if let Some(file) = &a.mapping {
        lines.push(set_map_from_file(&mut session, file, &path)?);
    }
    if let Some(clip) = clip {
        let frames = clip.tracked.len();
        let name = clip.name.clone();
        session.add_clip(clip)?;
        lines.insert(
            0,
            format!(
                "{}: added clip `{name}` with {} of landmarks",
                path.display(),
                plural(frames, "frame")
            ),
        );
    }
    session.save(&path)?;
    Ok(lines.join("\n"))
}

/// Points the session's map at `file` (checked against the model when the session has one),
/// dropping any inline map labelled in the TUI and the cached fits made with another map.
/// Returns the message saying what was replaced.
fn set_map_from_file(session: &mut Session, file: &Path, path: &Path) -> Result<String> {
    let map = landmark_map_toml::read_landmark_map(file)?;
    let n_vertices = match &session.model {
        Some(m) => {
            let n = model_source::load_model(&m.path, m.blendshapes.as_deref())?.num_vertices();
            check_map_vertices(&map, n, Some(file))?;
            Some(n)
        }
        None => None,
    };
    let old = session.landmark_map.clone();
    let previous = old.resolve().ok().flatten();
    let file_abs = crate::session::absolute(file);
    let mut msg = format!(
        "{}: landmark map set to {} ({})",
        path.display(),
        file.display(),
        plural(map.len(), "landmark")
    );
    let mut replaced = Vec::new();
    if let Some(inline) = old.inline_map() {
        replaced
            .push(format!("the map labelled in the TUI ({})", plural(inline.len(), "landmark")));
    }
    if let Some(f) = old.file.as_ref().filter(|f| **f != file_abs) {
        replaced.push(format!("the map file {}", f.display()));
    }
    if !replaced.is_empty() {
        msg.push_str(&format!("; replaces {}", replaced.join(" and ")));
    }
    session.landmark_map.file = Some(file_abs);
    session.landmark_map.inline = None;
    // The cache is keyed by the map's file name, not its content: drop fits made with a
    // different map so a map edited in place is not mistaken for the old one.
    if previous.is_some_and(|p| p.to_vertex != map.to_vertex) && !session.fit_cache.is_empty() {
        session.fit_cache.clear();
        msg.push_str("; cached fits dropped");
    }
    if let Some(problem) =
        n_vertices.and_then(|n| map_problem(&map, n, &session.fit_settings, path))
    {
        msg.push_str(&format!("\n{problem}"));
    }
    Ok(msg)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cli::{Cli, Command};
    use clap::Parser;

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
    fn import_takes_a_map_alone_and_new_still_needs_a_clip() {
        let cli = Cli::try_parse_from(["lipmap", "import", "s", "--mapping", "m.toml"]).unwrap();
        let Command::Import(a) = cli.command else { panic!("not import") };
        assert!(!a.clip.is_given());
        assert_eq!(a.mapping.as_deref(), Some(Path::new("m.toml")));
        // A clip option without the clip's frames and landmarks is refused by clap.
        assert!(Cli::try_parse_from(["lipmap", "import", "s", "--fps", "3"]).is_err());
        assert!(Cli::try_parse_from(["lipmap", "import", "s", "--frames", "f"]).is_err());
        // `new` needs frames and landmarks but no map.
        let new = ["lipmap", "new", "s", "--frames", "f", "--landmarks", "l", "--model", "m"];
        let Command::New(a) = Cli::try_parse_from(new).unwrap().command else { panic!() };
        assert!(a.mapping.is_none() && a.clip.is_given());
        assert!(Cli::try_parse_from(["lipmap", "new", "s", "--model", "m"]).is_err());
    }
}
