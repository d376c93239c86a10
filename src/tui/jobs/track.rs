//! The tracker's job: re-aligns a frame to its corrected points, or tracks from a face box
//! the user drew, with lipmap's tracker (`workflow::track`). The predictor (100 MB) is read
//! from its files on the first request and kept for the rest of the TUI session, every clip
//! included ([`TrackerSource`], which also keeps the predictor map suggestions read).

use crate::landmarks::{FrameLandmarks, Track};
use crate::track::realign::PropagateOptions;
use crate::track::{FaceBox, GrayImage, ShapePredictor};
use crate::tui::action::Action;
use crate::tui::app::{App, FrameImage, FrameProvider};
use crate::workflow::map::read_suggestion_predictor;
use crate::workflow::track::{
    Tracker, TrackerFiles, corrected_points, load_tracker, realign_frame, track_from_box,
};
use std::sync::{Arc, Mutex};

/// Frames a face box's track goes on for at most, when it keeps disagreeing with the
/// clip's landmarks (the tracker lost the face for that long).
pub const MAX_BOX_FRAMES: usize = 1000;

/// What the tracker's job is asked, copied from the `App` so the job does not share it.
#[derive(Clone, Debug)]
pub enum TrackJob {
    /// Re-align this frame's landmarks to their corrected points, from the tracker's own
    /// landmarks of the frame (`tracked`, when the clip has them); the image when the frames
    /// screen has it decoded (else the job decodes it).
    Realign {
        landmarks: FrameLandmarks,
        tracked: Option<FrameLandmarks>,
        image: Option<Arc<FrameImage>>,
    },
    /// Track from `face` on the first of `frames` (the clip's landmarks from that frame on).
    FromBox { face: FaceBox, frames: Track },
}

impl TrackJob {
    /// Re-aligning frame `frame` of the app's track; `None` when it has no such frame.
    pub fn realign(app: &App, frame: usize) -> Option<Self> {
        let landmarks = app.track.get(frame)?.clone();
        let tracked = app.tracked.get(frame).cloned();
        let image = app.frames.cache.images.get(&frame).cloned();
        Some(Self::Realign { landmarks, tracked, image })
    }

    /// Tracking from the box `[left, top, side]` on frame `frame`: the app's landmarks of
    /// that frame and of up to [`MAX_BOX_FRAMES`] after it. `None` when it has no such frame.
    pub fn from_box(app: &App, frame: usize, face: [f64; 3]) -> Option<Self> {
        let start = app.track.frames.iter().position(|f| f.frame == frame)?;
        let end = (start + 1 + MAX_BOX_FRAMES).min(app.track.frames.len());
        let [left, top, side] = face;
        Some(Self::FromBox {
            face: FaceBox { left, top, width: side, height: side },
            frames: Track::new(app.track.frames[start..end].to_vec()),
        })
    }
}

/// The tracker's files and, once read, the tracker and the predictor alone (map suggestions
/// need no face detector); shared by every clip's job.
#[derive(Default)]
pub struct TrackerSource {
    files: TrackerFiles,
    loaded: Mutex<Option<Arc<Tracker>>>,
    predictor: Mutex<Option<Arc<ShapePredictor>>>,
}

impl TrackerSource {
    pub fn new(files: TrackerFiles) -> Self {
        Self { files, loaded: Mutex::new(None), predictor: Mutex::new(None) }
    }

    /// The shape predictor for suggestions on the head's own face, read on first use as
    /// `lipmap map suggest` reads it (`--predictor`, else Debian's file); `Ok(Err(why))` when
    /// there is none, the line both fronts say as they match to the speaker instead. Not
    /// kept when missing: the next request tries again.
    ///
    /// # Errors
    /// A predictor named by `--predictor` that cannot be read.
    pub fn suggestion_predictor(
        &self,
        say: &dyn Fn(String),
    ) -> crate::workflow::Result<Result<Arc<ShapePredictor>, String>> {
        let broken = || crate::workflow::Error::Invalid("the predictor's lock broke".into());
        let mut slot = self.predictor.lock().map_err(|_| broken())?;
        if let Some(p) = slot.as_ref() {
            return Ok(Ok(p.clone()));
        }
        say("reading the shape predictor (once per session)…".into());
        let read = read_suggestion_predictor(self.files.predictor.as_deref())?.map(Arc::new);
        if let Ok(p) = &read {
            *slot = Some(p.clone());
        }
        Ok(read)
    }

    /// The tracker, read on first use (`say` hears that it is being read). A file that is
    /// missing is said in one line naming the flag that gives it; the next request tries
    /// again (the user may have installed it meanwhile).
    fn get(&self, say: &dyn Fn(String)) -> Result<Arc<Tracker>, String> {
        let mut slot = self.loaded.lock().map_err(|_| "the tracker's lock broke".to_string())?;
        if let Some(t) = slot.as_ref() {
            return Ok(t.clone());
        }
        say("reading the shape predictor (once per session)…".into());
        let t = load_tracker(&self.files).map_err(|e| status_line(&e))?;
        let t = Arc::new(t);
        *slot = Some(t.clone());
        Ok(t)
    }
}

/// Why the tracker cannot be read, in one status line: a missing file with the package that
/// installs it and the flag that names another.
fn status_line(e: &crate::workflow::Error) -> String {
    match e {
        crate::workflow::Error::NoTrackerFile { what, path, package, flag } => format!(
            "no {what} at {}: `apt-get install {package}`, or reopen `lipmap tui SESSION` with {flag} FILE (as `lipmap track` takes it)",
            path.display()
        ),
        e => format!("tracker: {}", crate::workflow::error_chain(e)),
    }
}

fn gray(img: &FrameImage) -> GrayImage {
    GrayImage::from_rgb(img.width as usize, img.height as usize, &img.rgb)
}

/// Answers a request: the tracker read (once) from `source`, frames decoded by `provider`.
/// Returns `Realigned`, `TrackedFromBox` or `TrackerFailed`; `say` hears progress.
pub fn track_for_tui(
    source: &TrackerSource,
    provider: &dyn FrameProvider,
    job: TrackJob,
    say: &dyn Fn(String),
) -> Action {
    let tracker = match source.get(say) {
        Ok(t) => t,
        Err(error) => return Action::TrackerFailed { error },
    };
    let decode = |frame: usize| -> crate::workflow::Result<GrayImage> {
        provider
            .load(frame)
            .map(|img| gray(&img))
            .map_err(|e| crate::workflow::Error::Invalid(format!("frame {frame}: {e:#}")))
    };
    match job {
        TrackJob::Realign { landmarks, tracked, image } => {
            let image = match image {
                Some(img) => Ok(gray(&img)),
                None => decode(landmarks.frame),
            };
            let held = corrected_points(&landmarks);
            let realigned = image.and_then(|img| {
                realign_frame(&tracker, img.view(), &landmarks, tracked.as_ref(), &held)
            });
            match realigned {
                Ok(after) => {
                    Action::Realigned { before: Box::new(landmarks), after: Box::new(after) }
                }
                Err(e) => Action::TrackerFailed { error: crate::workflow::error_chain(&e) },
            }
        }
        TrackJob::FromBox { face, frames } => {
            let Some(first) = frames.frames.first().map(|f| f.frame) else {
                return Action::TrackerFailed { error: "no frame to track".into() };
            };
            let opts = PropagateOptions { max_frames: MAX_BOX_FRAMES, ..Default::default() };
            let mut done = 0usize;
            let image = |f: usize| {
                done += 1;
                if done.is_multiple_of(50) {
                    say(format!("tracking from the face box: frame {f}…"));
                }
                decode(f)
            };
            match track_from_box(&tracker, face, &frames, first, image, &opts) {
                Ok(frames) => Action::TrackedFromBox { frames },
                Err(e) => Action::TrackerFailed { error: crate::workflow::error_chain(&e) },
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_missing_predictor_is_one_line_naming_the_package_and_the_flag() {
        let e = crate::workflow::Error::NoTrackerFile {
            what: "shape predictor",
            path: crate::track::DEBIAN_PREDICTOR_PATH.into(),
            package: "libdlib-data",
            flag: "--predictor",
        };
        assert_eq!(
            status_line(&e),
            "no shape predictor at /usr/share/dlib/shape_predictor_68_face_landmarks.dat: \
             `apt-get install libdlib-data`, or reopen `lipmap tui SESSION` with --predictor FILE \
             (as `lipmap track` takes it)"
        );
    }
}
