//! `lipmap new` and `lipmap import`: create a session from frames, tracked landmarks, a phone
//! alignment, a head mesh, a model and a landmark map; add further clips to a session.

use crate::cli::phones::tier_choice;
use crate::fit::FitSettings;
use crate::io::frames::{FrameOptions, FrameSource};
use crate::io::{alignment_format, landmark_format, landmark_map_toml, model_source, obj};
use crate::landmarks::LandmarkSet;
use crate::session::{Clip, FramesRef, ModelRef, Session, SessionLock, View};
use anyhow::{Context, Result, bail};
use std::path::{Path, PathBuf};

/// One clip's inputs.
#[derive(clap::Args, Debug, Clone)]
pub struct ClipArgs {
    /// Front-view frames: a folder of images (PNG/JPEG/PPM) or a video file (needs ffmpeg).
    #[arg(long)]
    pub frames: PathBuf,
    /// Frames per second (default: the video's, or 25 for an image folder).
    #[arg(long)]
    pub fps: Option<f64>,
    /// Tracked landmarks: .pts file or folder, OpenFace CSV, dlib XML, lipmap CSV.
    #[arg(long)]
    pub landmarks: PathBuf,
    /// Phone alignment: TextGrid, HTK/Festival .lab, or start,end,phone CSV.
    #[arg(long)]
    pub alignment: Option<PathBuf>,
    /// TextGrid tier (name or 1-based number).
    #[arg(long)]
    pub tier: Option<String>,
    /// Side-view frames (folder or video), for protrusion.
    #[arg(long)]
    pub side_frames: Option<PathBuf>,
    /// Side-view frames per second (default: the front view's).
    #[arg(long)]
    pub side_fps: Option<f64>,
    /// Seconds from the front view's frame 0 to the side view's frame 0.
    #[arg(long, default_value_t = 0.0, allow_hyphen_values = true)]
    pub side_offset: f64,
    /// Clip name (default: the landmark file's stem).
    #[arg(long)]
    pub clip: Option<String>,
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
    /// Landmark map in eos TOML format (iBUG ids 1-based).
    #[arg(long)]
    pub mapping: PathBuf,
    /// Landmark set for fitting.
    #[arg(long, default_value = "F4")]
    pub set: LandmarkSet,
    /// Overwrite an existing session file.
    #[arg(long)]
    pub force: bool,
}

/// Add a clip to an existing session.
#[derive(clap::Args, Debug)]
pub struct ImportArgs {
    /// Session file or name.
    pub session: String,
    #[command(flatten)]
    pub clip: ClipArgs,
}

/// `NAME` -> sessions/NAME.lipmap.json; anything with a slash or a .json ending is a path.
pub fn session_path(s: &str) -> PathBuf {
    if s.contains('/') || s.ends_with(".json") {
        PathBuf::from(s)
    } else {
        crate::session::default_path(s)
    }
}

/// Reads one clip's files into a `Clip`, checking them before anything is written.
///
/// # Errors
/// Any unreadable input, naming the file.
pub fn read_clip(a: &ClipArgs) -> Result<Clip> {
    let opts = FrameOptions { fps: a.fps, ..FrameOptions::default() };
    let frames = FrameSource::open(&a.frames, &opts)?;
    let source = if a.frames.is_dir() {
        FramesRef::Images { dir: crate::session::absolute(&a.frames) }
    } else {
        FramesRef::Video { file: crate::session::absolute(&a.frames) }
    };
    let mut front = View::new(source, frames.fps());
    front.size = Some(frames.size());
    let tracked = landmark_format::read_track(&a.landmarks)?;
    if tracked.is_empty() {
        bail!("{}: no frames of landmarks", a.landmarks.display());
    }
    if let Some(last) = tracked.frames.last()
        && last.frame >= frames.len()
    {
        eprintln!(
            "lipmap: warning: {} has landmarks up to frame {} but {} has {} frames",
            a.landmarks.display(),
            last.frame,
            a.frames.display(),
            frames.len()
        );
    }
    let name = a.clip.clone().unwrap_or_else(|| {
        a.landmarks.file_stem().map_or("clip".into(), |s| s.to_string_lossy().into_owned())
    });
    let mut clip = Clip::new(name, front);
    clip.tracked = tracked;
    clip.landmarks_file = Some(crate::session::absolute(&a.landmarks));
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
        view.offset_s = a.side_offset;
        clip.side = Some(view);
    }
    Ok(clip)
}

pub fn run_new(a: &NewArgs) -> Result<String> {
    let path = session_path(&a.session);
    if path.exists() && !a.force {
        bail!("{}: already exists (use --force to replace it)", path.display());
    }
    // Read and check every input before writing anything.
    let clip = read_clip(&a.clip)?;
    let model = model_source::load_model(&a.model, a.blendshapes.as_deref())?;
    let map = landmark_map_toml::read_landmark_map(&a.mapping)?;
    check_map(&map, model.num_vertices(), &a.mapping)?;
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
    session.landmark_map.file = Some(crate::session::absolute(&a.mapping));
    session.fit_settings = FitSettings { set: a.set, ..FitSettings::default() };
    let frames = clip.tracked.len();
    let name = clip.name.clone();
    session.add_clip(clip)?;
    session.save(&path)?;
    Ok(format!("{}: new session, clip `{name}` with {frames} frames of landmarks", path.display()))
}

pub fn run_import(a: &ImportArgs) -> Result<String> {
    let path = session_path(&a.session);
    let _lock = SessionLock::acquire(&path)?;
    let mut session = Session::load(&path)?;
    let clip = read_clip(&a.clip)?;
    let frames = clip.tracked.len();
    let name = clip.name.clone();
    session.add_clip(clip)?;
    session.save(&path)?;
    Ok(format!("{}: added clip `{name}` with {frames} frames of landmarks", path.display()))
}

fn check_map(map: &crate::model::LandmarkMap, n_vertices: usize, path: &Path) -> Result<()> {
    if let Some((&lm, &v)) = map.to_vertex.iter().find(|(_, v)| **v >= n_vertices) {
        bail!(
            "{}: landmark {} maps to vertex {v} but the model has {n_vertices} vertices",
            path.display(),
            lm + 1
        );
    }
    if map.is_empty() {
        bail!("{}: maps no landmarks", path.display());
    }
    Ok(())
}

/// Opens a session for a command that changes it: lock first, then load.
pub fn open_for_edit(s: &str) -> Result<(PathBuf, SessionLock, Session)> {
    let path = session_path(s);
    let lock = SessionLock::acquire(&path)?;
    let session = Session::load(&path).with_context(|| format!("{}", path.display()))?;
    Ok((path, lock, session))
}
