//! `lipmap track` (frames in, iBUG-68 landmarks out, tracked by lipmap's own reading of
//! dlib's shape predictor) and `lipmap propagate` (re-align a corrected frame and the frames
//! after it); the use cases are `workflow::track`.

use crate::cli::convert::landmark_output_format;
use crate::cli::output::plural;
use crate::cli::progress::{frames_bar, show_on};
use crate::io::landmark_format::{self, LandmarkFormat};
use crate::landmarks::PointNo;
use crate::track::realign::{PropagateOptions, PropagationEnd};
use crate::workflow::track::{
    TrackerFiles, load_tracker, propagate_session_correction, track_path,
};
use anyhow::{Result, bail};
use std::io::Write;
use std::path::PathBuf;

/// The files the tracker reads.
#[derive(clap::Args, Debug, Clone, Default)]
pub struct TrackerArgs {
    /// dlib's 68-point shape predictor (default:
    /// /usr/share/dlib/shape_predictor_68_face_landmarks.dat, Debian `libdlib-data`).
    #[arg(long, value_name = "FILE")]
    pub predictor: Option<PathBuf>,
    /// An OpenCV Haar face cascade for the first frame (default:
    /// /usr/share/opencv4/haarcascades/haarcascade_frontalface_alt2.xml, Debian `opencv-data`).
    #[arg(long, value_name = "FILE.xml")]
    pub detector: Option<PathBuf>,
}

impl TrackerArgs {
    pub fn files(&self) -> TrackerFiles {
        TrackerFiles { predictor: self.predictor.clone(), detector: self.detector.clone() }
    }
}

/// Track iBUG-68 landmarks through a clip's frames.
#[derive(clap::Args, Debug)]
pub struct TrackArgs {
    /// Frames: a folder of images (PNG/JPEG/PPM) or a video file (needs ffmpeg).
    pub frames: PathBuf,
    /// Output landmarks; the extension picks the format unless --to is given (.csv lipmap
    /// CSV, .xml dlib XML, no extension a folder of .pts).
    #[arg(long)]
    pub out: PathBuf,
    /// Output format: pts-dir, openface, dlib, csv.
    #[arg(long)]
    pub to: Option<String>,
    /// Frames per second (for the timestamps of OpenFace CSV; default: the video's, or 25).
    #[arg(long)]
    pub fps: Option<f64>,
    #[command(flatten)]
    pub tracker: TrackerArgs,
}

/// Runs `lipmap track`; prints what was written.
///
/// # Errors
/// Unreadable frames, predictor or detector; no face in any frame; the output cannot be
/// written.
pub fn run_track(args: &TrackArgs, out: &mut impl Write) -> Result<crate::cli::Outcome> {
    let format = landmark_output_format(&args.out, args.to.as_deref())?;
    if format == LandmarkFormat::Pts {
        bail!(
            "{}: a single .pts file holds one frame; write a folder (no extension) or a .csv",
            args.out.display()
        );
    }
    let tracker = load_tracker(&args.tracker.files())?;
    let bar = frames_bar(0, "tracking");
    let started = std::time::Instant::now();
    let tracked = track_path(&tracker, &args.frames, args.fps, &show_on(&bar))?;
    let seconds = started.elapsed().as_secs_f64();
    landmark_format::write_track(&tracked.track, &args.out, format)?;
    let n = tracked.track.len();
    writeln!(
        out,
        "{} tracked in {seconds:.2} s ({:.1} ms a frame, decoding included) -> {} ({format}); \
         face detected on {}, lost on {}",
        plural(n, "frame"),
        1e3 * seconds / n.max(1) as f64,
        args.out.display(),
        plural(tracked.detected.len(), "frame"),
        tracked.lost.len()
    )?;
    if let Some(first) = tracked.lost.first() {
        crate::cli::output::eprint_line(format_args!(
            "lipmap: warning: no face on {} (first: frame {first}); those frames are written as not visible",
            plural(tracked.lost.len(), "frame")
        ));
        return Ok(crate::cli::Outcome::Partial);
    }
    Ok(crate::cli::Outcome::Ok)
}

/// Re-align a corrected frame of a session from its corrected points, then the following
/// frames until the tracker agrees again.
#[derive(clap::Args, Debug)]
pub struct PropagateArgs {
    /// Session file or name.
    pub session: String,
    /// The corrected frame (0-based).
    #[arg(long)]
    pub frame: usize,
    /// The clip (default: the first).
    #[arg(long)]
    pub clip: Option<String>,
    /// Re-align at most this many frames after the corrected one.
    #[arg(long, default_value_t = PropagateOptions::default().max_frames)]
    pub max_frames: usize,
    #[command(flatten)]
    pub tracker: TrackerArgs,
}

/// Runs `lipmap propagate`; prints the frames changed.
///
/// # Errors
/// As `workflow::track::propagate_session_correction`.
pub fn run_propagate(args: &PropagateArgs, out: &mut impl Write) -> Result<()> {
    let tracker = load_tracker(&args.tracker.files())?;
    let opts = PropagateOptions { max_frames: args.max_frames, ..Default::default() };
    let p = propagate_session_correction(
        &args.session,
        args.clip.as_deref(),
        args.frame,
        &tracker,
        &opts,
    )?;
    let last = p.frames.last().copied().unwrap_or(args.frame);
    writeln!(
        out,
        "{}: frame {} re-aligned from {} ({}), and {} after it (to frame {last})",
        p.clip,
        args.frame,
        plural(p.held.len(), "corrected point"),
        p.held.iter().map(|&i| PointNo(i).to_string()).collect::<Vec<_>>().join(","),
        plural(p.frames.len() - 1, "frame"),
    )?;
    let why = match p.end {
        PropagationEnd::Agreed { frame } => format!("frame {frame}: the tracker agrees again"),
        PropagationEnd::Lost { frame, point } => {
            format!(
                "frame {frame}: point {}'s patch was lost (correct it there and propagate again)",
                PointNo(point)
            )
        }
        PropagationEnd::Parted { frame, point } => format!(
            "frame {frame}: point {} parts from the tracker's by more than your correction (check it there)",
            PointNo(point)
        ),
        PropagationEnd::NoFace { frame } => format!("frame {frame}: the tracker has no face there"),
        PropagationEnd::MaxFrames => format!("--max-frames {} reached", args.max_frames),
        PropagationEnd::ClipEnd => "the clip's end".to_string(),
    };
    writeln!(out, "stopped: {why}")?;
    Ok(())
}
