//! Jobs: the slow work (frame decoding, fitting, the analysis, the speech-driven head, the
//! quality cross-validation, transferred heads, the tracker, the map suggestions) on threads
//! of their own, replying with `Action`s over a channel so the UI thread never blocks.
//!
//! Each long-lived job has a one-request `Slot`: a new request replaces the pending one.
//! Replies carry the frame number or generation they answer; `update` drops stale ones.
//! One-off jobs (a head's set-up, the speech-driven head, the quality cross-validation, the
//! clip's image checks) run with `Jobs::run_once`. What each job computes is in its file;
//! this file owns the threads.

mod analysis;
mod fit;
mod heads;
mod images;
mod session;
mod slot;
mod suggest;
mod track;

pub use analysis::{AnalysisJob, analyse_for_tui};
pub use fit::{FitJob, fit_for_tui};
pub use heads::{HeadFrameJob, prepare_head_for_tui, transfer_frame_for_tui};
pub use images::check_images_for_tui;
pub use session::{quality_for_tui, speech_for_tui};
pub use suggest::{SuggestJob, suggest_for_tui};
pub use track::{MAX_BOX_FRAMES, TrackJob, TrackerSource, track_for_tui};

use crate::tui::action::Action;
use crate::tui::app::FrameProvider;
use crate::tui::screens::head::HeadFrame;
use slot::Slot;
use std::sync::mpsc::Sender;
use std::sync::{Arc, Mutex};

pub struct Jobs {
    frames: Arc<Slot<Vec<usize>>>,
    fits: Arc<Slot<FitJob>>,
    analyses: Arc<Slot<AnalysisJob>>,
    side_frames: Arc<Slot<usize>>,
    head_frames: Arc<Slot<HeadFrameJob>>,
    tracks: Arc<Slot<TrackJob>>,
    suggestions: Arc<Slot<SuggestJob>>,
    tx: Sender<Action>,
}

impl Jobs {
    /// Starts one decoding thread over `provider` and one fitting thread, replying on `tx`.
    pub fn start(provider: Arc<dyn FrameProvider>, tx: Sender<Action>) -> Self {
        let frames: Arc<Slot<Vec<usize>>> = Arc::new(Slot::new());
        let fits: Arc<Slot<FitJob>> = Arc::new(Slot::new());
        let atx = tx.clone();
        let own_tx = tx.clone();
        {
            let slot = frames.clone();
            let tx = tx.clone();
            std::thread::spawn(move || {
                while let Some(list) = slot.take() {
                    for frame in list {
                        let reply = match provider.load(frame) {
                            Ok(img) => Action::FrameLoaded { frame, image: Arc::new(img) },
                            Err(e) => Action::FrameFailed { frame, error: format!("{e:#}") },
                        };
                        if tx.send(reply).is_err() {
                            return;
                        }
                        // A newer request wins over the rest of this prefetch list.
                        if slot.has_pending() {
                            break;
                        }
                    }
                }
            });
        }
        {
            let slot = fits.clone();
            std::thread::spawn(move || {
                while let Some(job) = slot.take() {
                    let generation = job.generation;
                    let total = job.frames.len();
                    let ptx = Mutex::new(tx.clone());
                    let progress = |done: usize| {
                        if let Ok(t) = ptx.lock() {
                            let _ = t.send(Action::FitProgress { generation, done, total });
                        }
                    };
                    // A panic inside the fit must not take the UI down with it.
                    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                        fit_for_tui(&job, &progress)
                    }));
                    let reply = match result {
                        Ok(fits) => Action::FitDone { generation, fits },
                        Err(_) => {
                            Action::FitFailed { generation, error: "the fit panicked".into() }
                        }
                    };
                    if tx.send(reply).is_err() {
                        return;
                    }
                }
            });
        }
        let head_frames: Arc<Slot<HeadFrameJob>> = Arc::new(Slot::new());
        {
            let slot = head_frames.clone();
            let tx = atx.clone();
            std::thread::spawn(move || {
                while let Some(job) = slot.take() {
                    let (head, frame) = (job.head, job.fit.frame);
                    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                        transfer_frame_for_tui(&job)
                    }));
                    let shape = Err("the transfer panicked".to_string());
                    let reply = result.unwrap_or(HeadFrame { head, frame, shape });
                    if tx.send(Action::HeadFrameReady(reply)).is_err() {
                        return;
                    }
                }
            });
        }
        let analyses: Arc<Slot<AnalysisJob>> = Arc::new(Slot::new());
        {
            let slot = analyses.clone();
            std::thread::spawn(move || {
                while let Some(job) = slot.take() {
                    let generation = job.generation;
                    let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                        analyse_for_tui(&job)
                    }));
                    let reply = match result {
                        Ok(data) => Action::AnalysisReady { generation, data },
                        Err(_) => Action::Status("the analysis failed (panic)".into()),
                    };
                    if atx.send(reply).is_err() {
                        return;
                    }
                }
            });
        }
        Self {
            frames,
            fits,
            analyses,
            side_frames: Arc::new(Slot::new()),
            head_frames,
            tracks: Arc::new(Slot::new()),
            suggestions: Arc::new(Slot::new()),
            tx: own_tx,
        }
    }

    /// Runs a one-off job (a transferred head's set-up, the speech-driven head) on a thread
    /// of its own and sends its reply; a panic replies `panicked` instead.
    pub fn run_once(&self, what: &'static str, job: impl FnOnce() -> Action + Send + 'static) {
        let tx = self.tx.clone();
        std::thread::spawn(move || {
            let reply = std::panic::catch_unwind(std::panic::AssertUnwindSafe(job))
                .unwrap_or_else(|_| Action::Status(format!("{what} failed (panic)")));
            let _ = tx.send(reply);
        });
    }

    /// Asks for a transferred head's frame, replacing any pending request.
    pub fn request_head_frame(&self, job: HeadFrameJob) {
        self.head_frames.put(job);
    }

    /// Starts the side view's decoding thread over `provider` (clips with a side view).
    pub fn start_side_frames(&self, provider: Arc<dyn FrameProvider>, tx: Sender<Action>) {
        let slot = self.side_frames.clone();
        std::thread::spawn(move || {
            while let Some(frame) = slot.take() {
                let reply = match provider.load(frame) {
                    Ok(img) => Action::SideFrameLoaded { frame, image: Arc::new(img) },
                    Err(e) => Action::SideFrameFailed { frame, error: format!("{e:#}") },
                };
                if tx.send(reply).is_err() {
                    return;
                }
            }
        });
    }

    /// Starts the tracker's thread: frames decoded by `provider`, the tracker read once from
    /// `source` (shared across clips).
    pub fn start_tracker(&self, provider: Arc<dyn FrameProvider>, source: Arc<TrackerSource>) {
        let (slot, tx) = (self.tracks.clone(), self.tx.clone());
        std::thread::spawn(move || {
            while let Some(job) = slot.take() {
                let say = |text: String| {
                    let _ = tx.send(Action::Status(text));
                };
                let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                    track_for_tui(&source, provider.as_ref(), job, &say)
                }));
                let reply = result.unwrap_or_else(|_| Action::TrackerFailed {
                    error: "the tracker panicked".into(),
                });
                if tx.send(reply).is_err() {
                    return;
                }
            }
        });
    }

    /// Starts the map suggestions' thread: the shape predictor read once from `source`
    /// (shared with the tracker's job and across clips).
    pub fn start_suggestions(&self, source: Arc<TrackerSource>) {
        let (slot, tx) = (self.suggestions.clone(), self.tx.clone());
        std::thread::spawn(move || {
            while let Some(job) = slot.take() {
                let say = |text: String| {
                    let _ = tx.send(Action::Status(text));
                };
                let landmark = job.landmark;
                let result = std::panic::catch_unwind(std::panic::AssertUnwindSafe(|| {
                    suggest_for_tui(&source, job, &say)
                }));
                let reply = result.unwrap_or_else(|_| Action::MapSuggested {
                    landmark,
                    suggested: Err("the suggestion panicked".into()),
                });
                if tx.send(reply).is_err() {
                    return;
                }
            }
        });
    }

    /// Asks for map suggestions, replacing any pending request.
    pub fn request_suggestion(&self, job: SuggestJob) {
        self.suggestions.put(job);
    }

    /// Asks the tracker for a re-alignment or a track from a face box, replacing any
    /// pending request.
    pub fn request_track(&self, job: TrackJob) {
        self.tracks.put(job);
    }

    /// Asks for a side-view frame, replacing any pending request.
    pub fn request_side_frame(&self, frame: usize) {
        self.side_frames.put(frame);
    }

    /// Asks for the analysis tables, replacing any pending request.
    pub fn request_analysis(&self, job: AnalysisJob) {
        self.analyses.put(job);
    }

    /// Asks for frames to be decoded (first one first), replacing any pending request.
    pub fn request_frames(&self, frames: Vec<usize>) {
        self.frames.put(frames);
    }

    /// Asks for a fit, replacing any pending (not yet started) one.
    pub fn request_fit(&self, job: FitJob) {
        self.fits.put(job);
    }
}

impl Drop for Jobs {
    fn drop(&mut self) {
        // Threads finish their current item and exit; a running fit is not waited for.
        self.frames.close();
        self.fits.close();
        self.analyses.close();
        self.side_frames.close();
        self.head_frames.close();
        self.tracks.close();
        self.suggestions.close();
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::tui::app::FrameImage;
    use std::sync::mpsc;
    use std::time::Duration;

    struct Slow;
    impl FrameProvider for Slow {
        fn load(&self, frame: usize) -> anyhow::Result<FrameImage> {
            std::thread::sleep(Duration::from_millis(30));
            if frame == 99 {
                anyhow::bail!("broken frame");
            }
            Ok(FrameImage { width: 1, height: 1, rgb: vec![frame as u8, 0, 0] })
        }
    }

    #[test]
    fn newest_request_wins_and_errors_reply() {
        let (tx, rx) = mpsc::channel();
        let w = Jobs::start(Arc::new(Slow), tx);
        w.request_frames(vec![1, 2, 3, 4, 5, 6]);
        std::thread::sleep(Duration::from_millis(10));
        w.request_frames(vec![99]);
        let mut got = Vec::new();
        while let Ok(a) = rx.recv_timeout(Duration::from_millis(500)) {
            got.push(a);
            if matches!(got.last(), Some(Action::FrameFailed { .. })) {
                break;
            }
        }
        let frames: Vec<usize> = got
            .iter()
            .filter_map(|a| match a {
                Action::FrameLoaded { frame, .. } => Some(*frame),
                _ => None,
            })
            .collect();
        // Frame 1 was being decoded when 99 arrived; the rest of the prefetch was dropped.
        assert_eq!(frames, vec![1]);
        assert!(matches!(got.last(), Some(Action::FrameFailed { frame: 99, .. })));
    }
}
