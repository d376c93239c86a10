//! `lipmap new` and `lipmap import`: the flags that describe a session's inputs, and the
//! messages; the use cases are `workflow::create`.

use crate::cli::output::plural;
use crate::cli::phones::tier_choice;
use crate::cli::progress::print_warnings;
use crate::landmarks::LandmarkSet;
use crate::workflow::audio::{AudioInput, AudioSource};
use crate::workflow::create::{
    ClipInputs, HeadMesh, HeadSet, Import, LandmarkInput, MapSet, MapState, NewSession,
    ReplacedMap, SideInputs, create_session, import_into_session, map_hint,
};
use crate::workflow::session_path;
use anyhow::{Result, bail};
use std::path::{Path, PathBuf};

/// One clip's inputs. `--frames` and `--landmarks` are optional here only so that
/// `lipmap import SESSION --mapping FILE` can leave the clip out (clap still requires fields
/// of an optional flattened struct); `lipmap new` makes them required (see `cli::Command`),
/// and any other clip option needs them.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct ClipArgs {
    /// Front-view frames: a folder of images (PNG/JPEG/PPM) or a video file (needs ffmpeg).
    #[arg(long, requires = "landmark_source")]
    pub frames: Option<PathBuf>,
    /// Frames per second (default: the video's, or 25 for an image folder, with a notice).
    #[arg(long, requires = "frames")]
    pub fps: Option<f64>,
    /// Tracked landmarks: .pts file or folder, OpenFace CSV, dlib XML, lipmap CSV, eos CSV.
    #[arg(long, requires = "frames", group = "landmark_source")]
    pub landmarks: Option<PathBuf>,
    /// Track the landmarks with lipmap's own tracker (dlib's shape predictor) instead of
    /// reading them (`lipmap track`; --predictor and --detector name its files).
    #[arg(long, requires = "frames", group = "landmark_source")]
    pub track: bool,
    #[command(flatten)]
    pub tracker: crate::cli::track_cmd::TrackerArgs,
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
    /// above it when the folder is called e.g. `frames` or `images`). With `import --audio`
    /// and no --frames: the existing clip to give the audio to (default: the first).
    #[arg(long)]
    pub clip: Option<String>,
    /// The clip's speech as a WAV file (for `lipmap speech`); `video` takes the audio track
    /// of the clip's video (needs ffmpeg; written beside the session as SESSION.CLIP.wav).
    #[arg(long, value_name = "FILE.wav|video")]
    pub audio: Option<PathBuf>,
    /// Seconds from the front view's frame 0 to the audio's first sample (default 0).
    #[arg(long, allow_hyphen_values = true, requires = "audio")]
    pub audio_offset: Option<f64>,
}

impl ClipArgs {
    /// Whether a clip was given at all.
    pub fn is_given(&self) -> bool {
        self.frames.is_some() || self.landmarks.is_some() || self.track
    }

    /// The audio flags (`None` without --audio). A file literally named `video` is given as
    /// `./video`.
    pub fn audio(&self) -> Option<AudioInput> {
        self.audio.as_ref().map(|a| AudioInput {
            source: if a.as_os_str() == "video" {
                AudioSource::VideoTrack
            } else {
                AudioSource::Wav(a.clone())
            },
            offset_s: self.audio_offset.unwrap_or(0.0),
        })
    }

    /// The clip's inputs for the workflow (`None` when no clip was given).
    ///
    /// # Errors
    /// Only one of the frames and the landmarks was given.
    pub fn inputs(&self) -> Result<Option<ClipInputs>> {
        if !self.is_given() {
            return Ok(None);
        }
        let landmarks = match (&self.landmarks, self.track) {
            (Some(file), false) => Some(LandmarkInput::File(file.clone())),
            (None, true) => Some(LandmarkInput::Track(self.tracker.files())),
            _ => None,
        };
        let (Some(frames), Some(landmarks)) = (&self.frames, landmarks) else {
            bail!("a clip needs --frames and --landmarks (or --track)");
        };
        Ok(Some(ClipInputs {
            frames: frames.clone(),
            fps: self.fps,
            landmarks,
            alignment: self
                .alignment
                .clone()
                .map(|file| (file, self.tier.as_deref().map(tier_choice))),
            side: self.side_frames.clone().map(|frames| SideInputs {
                frames,
                fps: self.side_fps,
                offset_s: self.side_offset.unwrap_or(0.0),
            }),
            name: self.clip.clone(),
            audio: self.audio(),
        }))
    }
}

/// Create a session.
#[derive(clap::Args, Debug)]
pub struct NewArgs {
    /// Session file, or a bare name for sessions/NAME.lipmap.json.
    pub session: String,
    #[command(flatten)]
    pub clip: ClipArgs,
    /// Head mesh (OBJ) the motion drives. When it is another mesh than the model (another
    /// vertex count) it gets a map of its own, labelled in the TUI (view 2); the model keeps
    /// --mapping for fitting.
    #[arg(long)]
    pub head: Option<PathBuf>,
    /// Morphable model: eos .bin, .npz, folder of .npy parts, lipmap model, folder of pose OBJs.
    #[arg(long)]
    pub model: PathBuf,
    /// Expression blendshapes (eos .bin, folder of .target or OBJ).
    #[arg(long)]
    pub blendshapes: Option<PathBuf>,
    /// The model's landmark map in eos TOML format (iBUG ids 1-based) or its JSON, what `fit` uses.
    /// Optional: the model can be labelled in the TUI (view 2), or a map set later with
    /// `lipmap import SESSION --mapping FILE`.
    #[arg(long)]
    pub mapping: Option<PathBuf>,
    /// Landmark set for fitting.
    #[arg(long, default_value = "F4")]
    pub set: LandmarkSet,
    /// Overwrite an existing session file.
    #[arg(long)]
    pub force: bool,
    /// Use a --mapping that fails the map checks (`lipmap map check`: shared vertices,
    /// left/right swaps, no landmarks, a mesh that is not a surface) anyway.
    #[arg(long)]
    pub accept_map_warnings: bool,
}

/// Add a clip to an existing session, and/or set or replace its landmark map or head mesh.
#[derive(clap::Args, Debug)]
pub struct ImportArgs {
    /// Session file or name.
    pub session: String,
    /// The clip to add (--frames and --landmarks; leave out to only set the map).
    #[command(flatten)]
    pub clip: ClipArgs,
    /// Set the model's landmark map (what `fit` uses) to this eos TOML file, replacing the
    /// map file it named and any map labelled in the TUI.
    #[arg(long)]
    pub mapping: Option<PathBuf>,
    /// Set the head's own map (what `transfer` and `indices` use) to this eos TOML file, for
    /// a head that is another mesh than the model.
    #[arg(long, value_name = "MAP.toml")]
    pub head_mapping: Option<PathBuf>,
    /// Make this OBJ the session's head mesh (the one labelled in the TUI's view 2), replacing
    /// the head it named; the session's map is checked on it.
    #[arg(long, value_name = "HEAD.obj")]
    pub head: Option<PathBuf>,
    /// Use a --mapping or --head-mapping that fails the map checks (`lipmap map check`)
    /// anyway.
    #[arg(long)]
    pub accept_map_warnings: bool,
}

/// Creates the session and says what it holds (warnings go to stderr first).
pub fn run_new(a: &NewArgs) -> Result<String> {
    let Some(clip) = a.clip.inputs()? else {
        bail!("a clip needs --frames and --landmarks (or --track)")
    };
    let created = create_session(&NewSession {
        path: session_path(&a.session),
        clip,
        head: a.head.clone(),
        model: a.model.clone(),
        blendshapes: a.blendshapes.clone(),
        mapping: a.mapping.clone(),
        set: a.set,
        force: a.force,
        accept_map_warnings: a.accept_map_warnings,
    })?;
    print_warnings(&created.warnings);
    let path = &created.path;
    let mut msg = format!(
        "{}: new session, clip `{}` with {} of landmarks",
        path.display(),
        created.clip.name,
        plural(created.clip.frames, "frame")
    );
    match &created.map {
        MapState::Missing => {
            msg.push_str(&format!("\nno model map yet (what `fit` uses): {}", map_hint(path)))
        }
        MapState::Usable(n) => msg.push_str(&format!(", {} mapped", plural(*n, "landmark"))),
        MapState::Problem(problem) => msg.push_str(&format!("\n{problem}")),
    }
    if let Some(head) = &created.head {
        msg.push('\n');
        msg.push_str(&maps_line(head, path));
    }
    Ok(msg)
}

/// Adds to the session and says what changed.
pub fn run_import(a: &ImportArgs) -> Result<String> {
    let clip = a.clip.inputs()?;
    if clip.is_none() && a.clip.clip.is_some() && a.clip.audio.is_none() {
        bail!("--clip without --frames names the clip to give --audio to; add --audio FILE.wav");
    }
    let imported = import_into_session(&Import {
        path: session_path(&a.session),
        audio: if clip.is_none() { a.clip.audio().map(|i| (i, a.clip.clip.clone())) } else { None },
        clip,
        mapping: a.mapping.clone(),
        head: a.head.clone(),
        head_mapping: a.head_mapping.clone(),
        accept_map_warnings: a.accept_map_warnings,
    })?;
    print_warnings(&imported.warnings);
    let path = &imported.path;
    let mut lines = Vec::new();
    if let Some(clip) = &imported.clip {
        lines.push(format!(
            "{}: added clip `{}` with {} of landmarks",
            path.display(),
            clip.name,
            plural(clip.frames, "frame")
        ));
    }
    if let Some(map) = &imported.map {
        lines.push(map_set_message(map, path));
    }
    if let Some(head) = &imported.head {
        lines.push(head_set_message(head, path));
    }
    if let Some((file, check)) = &imported.head_map {
        lines.push(format!(
            "{}: head map set to {} (what `transfer` and `indices` use); on the head: {}",
            path.display(),
            file.display(),
            check.summary()
        ));
    }
    if let Some((clip, file)) = &imported.audio {
        lines.push(format!("{}: clip `{clip}` has audio {}", path.display(), file.display()));
    }
    Ok(lines.join("\n"))
}

/// One line saying what each map is for, once a head is given.
fn maps_line(head: &HeadMesh, path: &Path) -> String {
    if head.needs_own_map() {
        format!(
            "maps: the model map is what `fit` uses; {} is another mesh ({} vertices, the model \
             {}), so its own head map is what `transfer` and `indices` use: label it in the TUI \
             (`lipmap tui {}`, view 2)",
            head.file.display(),
            head.vertices,
            head.model_vertices,
            path.display()
        )
    } else {
        format!(
            "maps: {} is the model's own mesh, so one map serves `fit`, `transfer` and `indices`",
            head.file.display()
        )
    }
}

/// What setting a head did, as `import` prints it, and how to label the head next.
fn head_set_message(head: &HeadSet, path: &Path) -> String {
    let mut msg = format!(
        "{}: head mesh set to {} ({} vertices)",
        path.display(),
        head.file.display(),
        head.vertices
    );
    if let Some(old) = &head.replaced {
        msg.push_str(&format!("; replaces {}", old.display()));
    }
    if head.own_map {
        msg.push_str(
            "\nit is another mesh than the model: the model map stays what `fit` uses; the head's \
             own map is what `transfer` and `indices` use",
        );
    }
    let suggest = format!(
        "label 4-6 landmarks in the TUI (view 2), then `lipmap map suggest {} --out MAP.toml` labels the rest",
        path.display()
    );
    match &head.map_check {
        None => msg.push_str(&format!("\nno map for this head yet: {suggest}")),
        Some(check) if check.is_plausible() => {
            msg.push_str(&format!("\nthe head's map on this head: {}", check.summary()));
        }
        Some(check) => msg.push_str(&format!(
            "\nthe head's map does not fit this head (labelled on another mesh?): {}\n\
             relabel: {suggest}",
            check.summary()
        )),
    }
    msg
}

/// What setting a map file did, as `import` prints it.
fn map_set_message(map: &MapSet, path: &Path) -> String {
    let mut msg = format!(
        "{}: model map (what `fit` uses) set to {} ({})",
        path.display(),
        map.file.display(),
        plural(map.landmarks, "landmark")
    );
    let replaced: Vec<String> = map
        .replaced
        .iter()
        .map(|r| match r {
            ReplacedMap::Labelled(n) => {
                format!("the map labelled in the TUI ({})", plural(*n, "landmark"))
            }
            ReplacedMap::File(f) => format!("the map file {}", f.display()),
        })
        .collect();
    if !replaced.is_empty() {
        msg.push_str(&format!("; replaces {}", replaced.join(" and ")));
    }
    if map.fits_dropped {
        msg.push_str("; cached fits dropped");
    }
    if let Some(problem) = &map.problem {
        msg.push_str(&format!("\n{problem}"));
    }
    msg
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cli::{Cli, Command};
    use clap::Parser;

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
        // A head alone is an import too.
        let cli = Cli::try_parse_from(["lipmap", "import", "s", "--head", "h.obj"]).unwrap();
        let Command::Import(a) = cli.command else { panic!("not import") };
        assert_eq!(a.head.as_deref(), Some(Path::new("h.obj")));
    }
}
