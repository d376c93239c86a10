//! Worker threads for the slow work (frame decoding, fitting, the analysis, the
//! speech-driven head, transferred heads) that replies with `Action`s over a channel, so the
//! UI thread never blocks.
//!
//! Each worker has a one-request slot: a new request replaces the pending one (flipping
//! through 50 frames decodes the newest, a drag does not queue 50 fits). Replies carry the
//! frame number or fit generation; `update` drops stale ones.

use crate::alignment::Alignment;
use crate::fit::{FitSettings, FrameFit};
use crate::landmarks::{FrameLandmarks, Track};
use crate::model::{LandmarkMap, MorphableModel};
use crate::tui::action::Action;
use crate::tui::app::FrameProvider;
use crate::tui::app::{
    AnalysisData, AnalysisRow, AnalysisTable, HeadFrame, PreparedHead, Trajectory,
};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::Sender;
use std::sync::{Arc, Condvar, Mutex};

/// A single pending request, replaced by newer ones.
struct Slot<T> {
    pending: Mutex<Option<T>>,
    wake: Condvar,
    closed: AtomicBool,
}

impl<T> Slot<T> {
    fn new() -> Self {
        Self { pending: Mutex::new(None), wake: Condvar::new(), closed: AtomicBool::new(false) }
    }

    fn put(&self, req: T) {
        if let Ok(mut p) = self.pending.lock() {
            *p = Some(req);
            self.wake.notify_one();
        }
    }

    /// Blocks until a request arrives; `None` once closed.
    fn take(&self) -> Option<T> {
        let mut p = self.pending.lock().ok()?;
        loop {
            if self.closed.load(Ordering::Acquire) {
                return None;
            }
            if let Some(r) = p.take() {
                return Some(r);
            }
            p = self.wake.wait(p).ok()?;
        }
    }

    fn has_pending(&self) -> bool {
        self.pending.lock().map(|p| p.is_some()).unwrap_or(false)
    }

    fn close(&self) {
        self.closed.store(true, Ordering::Release);
        if let Ok(_p) = self.pending.lock() {
            self.wake.notify_all();
        }
    }
}

/// Everything a fit needs, copied so the worker does not share the `App`.
pub struct FitJob {
    pub generation: u64,
    pub model: Arc<MorphableModel>,
    pub map: LandmarkMap,
    pub settings: FitSettings,
    pub frames: Vec<FrameLandmarks>,
    pub image_height: f64,
}

/// Runs the fit for the TUI: the one call into `crate::fit`, kept here so API changes stay
/// local. `progress` receives the number of frames done.
pub fn fit_for_tui(job: &FitJob, progress: &dyn Fn(usize)) -> Vec<FrameFit> {
    crate::fit::fit_clip(
        &job.model,
        &job.map,
        &job.frames,
        job.image_height,
        &job.settings,
        Some(progress),
    )
}

/// Everything the analysis needs: the clip's effective landmarks, phones and fits.
pub struct AnalysisJob {
    pub generation: u64,
    pub name: String,
    pub model: Arc<MorphableModel>,
    pub map: LandmarkMap,
    pub track: Track,
    pub alignment: Alignment,
    pub fps: f64,
    pub fits: Vec<FrameFit>,
    /// The head mesh the app shows: the head's facial indices are taken on it (or on the
    /// model's mean when it is not the model's topology), shown after the error tables.
    pub head: Option<Arc<crate::model::Mesh>>,
    /// The side view's P per front frame (corrections applied), when the clip has one.
    pub side_p: Option<Vec<Option<f64>>>,
}

/// Measures the video and the fitted head and evaluates them with
/// `crate::workflow::evaluate_clip` (min–max normalised, as the published method), then turns
/// the report into the analysis view's tables and trajectories.
pub fn analyse_for_tui(job: &AnalysisJob) -> AnalysisData {
    use crate::measure::Measure;
    use crate::workflow::{ClipInput, DEFAULT_WORST_ROWS, Normalisation, evaluate_clip};
    let input = ClipInput {
        name: &job.name,
        alignment: &job.alignment,
        fps: job.fps,
        track: &job.track,
        fits: &job.fits,
        side_view: job.side_p.is_some(),
        side_p: job.side_p.as_deref(),
    };
    let evaluated =
        evaluate_clip(&job.model, &job.map, &input, Normalisation::MinMax, DEFAULT_WORST_ROWS);
    let (u, report) = (&evaluated.utterance, &evaluated.report);
    let first_frame_of = |label: &str| {
        let phones = &crate::reference::current().phones;
        let key = phones.key_of(label);
        job.alignment
            .phones
            .iter()
            .find(|p| phones.key_of(&p.label) == key)
            .map(|p| Alignment::frames_of(p, job.fps).start)
    };
    // The facial indices of speaker and head from what the app holds (no disk reads), when
    // a map and the index points allow them.
    let index_tables = crate::workflow::indices::index_tables(
        &job.model,
        &job.map,
        job.head.as_deref(),
        &job.name,
        &job.track,
        &job.alignment,
        job.fps,
        &crate::reference::current().bounds,
    )
    .unwrap_or_default();
    let tables = [
        &report.phonemes,
        &report.visemes,
        &report.sentences,
        &report.worst_frames,
        &report.worst_fits,
    ]
    .into_iter()
    .chain(index_tables.iter())
    .map(|t| table_for_tui(t, &first_frame_of, t.title == report.phonemes.title))
    .collect();
    let normalised = u.min_max_normalised();
    let trajectories = Measure::ALL
        .into_iter()
        .filter(|m| {
            normalised.video.series(*m).iter().any(Option::is_some)
                || normalised.head.series(*m).iter().any(Option::is_some)
        })
        .map(|m| Trajectory {
            name: m.as_str().to_string(),
            video: frame_points(normalised.video.series(m)),
            model: frame_points(normalised.head.series(m)),
        })
        .collect();
    let warnings = evaluated.warnings.iter().map(|w| w.status_text().to_string()).collect();
    AnalysisData { tables, trajectories, warnings }
}

/// A per-frame series as chart points (frame, value), gaps left out.
fn frame_points(s: &[Option<f64>]) -> Vec<(f64, f64)> {
    s.iter().enumerate().filter_map(|(f, v)| v.map(|v| (f as f64, v))).collect()
}

/// Drives clip `clip`'s head from its audio with the session's speech model (the one call
/// into `workflow::speech_session`) and replies with its series, min–max normalised as the
/// analysis' trajectories are, or with why there are none. `session` is the worker's copy:
/// fits its cache lacks are made in it.
pub fn speech_for_tui(session: &mut crate::session::Session, clip: usize) -> Action {
    use crate::measure::Measure;
    match crate::workflow::speech_session::drive_clip_with_session_model(session, clip) {
        Ok(u) => {
            let normalised = u.min_max_normalised();
            let series = Measure::ALL
                .into_iter()
                .map(|m| (m.as_str().to_string(), frame_points(normalised.head.series(m))))
                .filter(|(_, pts)| !pts.is_empty())
                .collect();
            Action::SpeechReady { series }
        }
        Err(e) => Action::SpeechAbsent { why: crate::workflow::error_chain(&e) },
    }
}

/// Cross-validates quality prediction (SAQP) over the sentences of `session` (the worker's
/// copy, at `path`; fits its cache lacks are made in it) with the default settings, as
/// `lipmap saqp cv` does, and replies with the held-out sentences (each opening its clip)
/// and the per-synthesizer table, or with why there are none.
pub fn quality_for_tui(session: &mut crate::session::Session, path: &std::path::Path) -> Action {
    use crate::workflow::saqp::{
        SaqpSettings, cross_validate_corpus, held_out_table, open_session_corpus, synths_table,
    };
    let settings = SaqpSettings::default();
    let result = open_session_corpus(session, path, &settings.corpus, &|_| {}).and_then(|sc| {
        let clips: Vec<(String, usize)> = sc
            .corpus
            .sentences
            .iter()
            .zip(&sc.origins)
            .map(|(s, o)| (s.name.clone(), o.clip))
            .collect();
        let (frames, bridged) = (sc.frames, sc.bridged);
        cross_validate_corpus(sc, &settings).map(|cv| (cv, clips, frames, bridged))
    });
    let (cv, clips, frames, bridged) = match result {
        Ok(r) => r,
        Err(e) => return Action::QualityFailed { error: crate::workflow::error_chain(&e) },
    };
    let no_frame = |_: &str| None;
    let mut held = table_for_tui(&held_out_table(&cv.report), &no_frame, false);
    for row in &mut held.rows {
        let name = row.cells.first().map(String::as_str).unwrap_or_default();
        row.clip = clips.iter().find(|(n, _)| n == name).map(|(_, c)| *c);
    }
    let synths = table_for_tui(&synths_table(&cv.report), &no_frame, false);
    let best = cv.report.synths.iter().max_by(|a, b| a.pearson_r.total_cmp(&b.pearson_r));
    let summary = format!(
        "quality over {} sentences ({frames} frames, {bridged} bridged){}; Enter opens a sentence",
        cv.sentences,
        best.map_or(String::new(), |s| format!(
            ": best {} r {:.2}, RMSE {:.2} × a constant's",
            s.synth.name(),
            s.pearson_r,
            s.rmse / s.rmse_constant
        ))
    );
    Action::QualityReady { tables: vec![held, synths], summary }
}

/// Sets up the transfer onto a session's transferred head for the head view (the one call
/// into `workflow::transfer`, on a worker: it takes a good part of a second).
///
/// # Errors
/// One line: the session's model or map, the head or its map cannot be read, or the
/// transfer cannot be set up.
pub fn prepare_head_for_tui(
    session: &crate::session::Session,
    entry: &crate::session::TransferredHead,
) -> Result<PreparedHead, String> {
    use crate::workflow::transfer::{load_target, parse_mode, set_up_for_head};
    let prepare = || -> crate::workflow::Result<PreparedHead> {
        let res = crate::workflow::Resources::load(session)?;
        let target = load_target(&entry.mesh, &entry.mapping)?;
        let transfer = set_up_for_head(&res, &target, parse_mode(&entry.mode)?, &entry.mesh)?;
        Ok(PreparedHead::new(
            entry.name.clone(),
            entry.mode.clone(),
            transfer,
            target.mesh,
            &target.skin,
            &target.map,
        ))
    };
    prepare().map_err(|e| crate::workflow::error_chain(&e))
}

/// One frame of a transferred head to compute: the set-up head and the frame's fit.
pub struct HeadFrameJob {
    pub head: usize,
    pub prepared: Arc<PreparedHead>,
    pub model: Arc<MorphableModel>,
    pub fit: FrameFit,
}

/// The transferred head's shape for the job's fit, as `workflow::transfer::transfer_fits`
/// computes it, with the head's faces (the view hides what they cover).
pub fn transfer_frame_for_tui(job: &HeadFrameJob) -> HeadFrame {
    let source = crate::fit::fitted_shape(&job.model, &job.fit);
    let shape = job
        .prepared
        .transfer
        .apply(&source)
        .map(|s| {
            Arc::new(crate::model::Mesh::from_flat(s.as_slice(), job.prepared.mesh.faces.clone()))
        })
        .map_err(|e| e.to_string());
    HeadFrame { head: job.head, frame: job.fit.frame, shape }
}

/// An eval `Table` as an analysis table: a `frame` column gives the row's jump target; in the
/// phoneme table the phone's first occurrence does.
fn table_for_tui(
    t: &crate::eval::Table,
    first_frame_of: &dyn Fn(&str) -> Option<usize>,
    phones: bool,
) -> AnalysisTable {
    use crate::eval::Cell;
    let frame_col = t.headers.iter().position(|h| h == "frame");
    let rows = t
        .rows
        .iter()
        .map(|r| {
            let cells: Vec<String> = (0..t.headers.len())
                .map(|c| r.get(c).map_or(String::new(), |x| x.display(t.precision)))
                .collect();
            let keys = (0..t.headers.len())
                .map(|c| match r.get(c) {
                    Some(Cell::Num(v)) if v.is_finite() => Some(*v),
                    Some(Cell::Int(i)) => Some(*i as f64),
                    _ => None,
                })
                .collect();
            let frame = match (frame_col, r.get(frame_col.unwrap_or(usize::MAX))) {
                (Some(_), Some(Cell::Int(i))) => usize::try_from(*i).ok(),
                _ if phones => cells.first().and_then(|l| first_frame_of(l)),
                _ => None,
            };
            AnalysisRow { cells, keys, frame, clip: None }
        })
        .collect();
    AnalysisTable { title: t.title.clone(), columns: t.headers.clone(), rows }
}

/// The decoding, fitting, analysis and transferred-head threads.
pub struct Workers {
    frames: Arc<Slot<Vec<usize>>>,
    fits: Arc<Slot<FitJob>>,
    analyses: Arc<Slot<AnalysisJob>>,
    side_frames: Arc<Slot<usize>>,
    head_frames: Arc<Slot<HeadFrameJob>>,
    tx: Sender<Action>,
}

impl Workers {
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
        Self { frames, fits, analyses, side_frames: Arc::new(Slot::new()), head_frames, tx: own_tx }
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

impl Drop for Workers {
    fn drop(&mut self) {
        // Threads finish their current item and exit; a running fit is not waited for.
        self.frames.close();
        self.fits.close();
        self.analyses.close();
        self.side_frames.close();
        self.head_frames.close();
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
        let w = Workers::start(Arc::new(Slow), tx);
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

    #[test]
    fn a_transferred_head_follows_the_fitted_jaw() {
        use crate::tui::fixtures::{synthetic_model, synthetic_prepared_head, synthetic_track};
        let prepared = Arc::new(synthetic_prepared_head());
        let model = Arc::new(synthetic_model());
        let track = synthetic_track(1, 100, 100);
        let rest = prepared.mesh.vertices.clone();
        let shape_at = |jaw: f64| {
            let mut fit = crate::tui::fixtures::synthetic_fits(&track)[0].clone();
            fit.expression = vec![jaw];
            let job =
                HeadFrameJob { head: 0, prepared: prepared.clone(), model: model.clone(), fit };
            let f = transfer_frame_for_tui(&job);
            assert_eq!((f.head, f.frame), (0, 0));
            f.shape.unwrap()
        };
        // Closed: the head at rest (source and target are one mesh).
        let closed = shape_at(0.0);
        for (p, q) in closed.vertices.iter().zip(&rest) {
            assert!((p - q).norm() < 1e-6, "{p} vs {q}");
        }
        // Open: the lower front follows the 20-unit drop, the crown stays.
        let open = shape_at(1.0);
        let dy = |v: usize| open.vertices[v].y - rest[v].y;
        let chin = 1 + 7 * 16; // iBUG 8's vertex: ring 8, front meridian
        assert!((dy(chin) + 20.0).abs() < 2.0, "chin moved {}", dy(chin));
        assert!(dy(0).abs() < 2.0, "crown moved {}", dy(0));
        assert_eq!(open.faces, prepared.mesh.faces, "faces kept for hidden lines");
    }
}
