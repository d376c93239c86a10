//! The event loop: terminal events and job replies become actions, `update` applies them,
//! the effects it queued go to the jobs and the session, and the screen is redrawn when
//! something changed. The loop changes no state itself: what it learns (the terminal's size,
//! a journal error, the graphics note, how the previous clip was looked at) reaches the `App`
//! as an action too.
//!
//! Graphics: a `GraphicsState` (the terminal's image protocol, if any, and its cached
//! encoding) is owned here, not by the `App`, and drawn over the half-block image.
//!
//! Autosave: edits are saved once the user pauses (`AUTOSAVE_IDLE`) and never mid-drag; `q`
//! saves what is left before quitting. Until then every edit is in the session's journal
//! (`session::journal`), on disk before the next key is read, so a crash loses at most the
//! edit being made. TERM, INT and HUP leave like `q` (saving, unlocking, restoring the
//! terminal). The terminal is restored on return, error, signal and panic.

use super::action::Action;
use super::draw::draw;
use super::global::Carried;
use super::input::{key_to_action, mouse_to_action};
use super::jobs::{
    AnalysisJob, FitJob, HeadFrameJob, Jobs, TrackJob, TrackerSource, check_images_for_tui,
};
use super::keymap::Keymap;
use super::screens::frames::view::draw_graphics;
use super::session_bridge::SessionBridge;
use super::update::apply;
use super::widgets::graphics::{GraphicsChoice, GraphicsState, TermEnv};
use super::widgets::terminal::TerminalGuard;
use crate::tui::app::{App, Effect};
use ratatui::Terminal;
use ratatui::backend::Backend;
use ratatui::crossterm::event::{self, Event};
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::mpsc::{Receiver, channel};
use std::time::{Duration, Instant};

/// How long after the last edit the batch is saved.
pub const AUTOSAVE_IDLE: Duration = Duration::from_millis(400);
/// Longest wait for a terminal event before checking jobs and autosave.
const POLL: Duration = Duration::from_millis(30);

/// Opens the session at `session_path` (first clip) in the terminal UI until the user quits.
/// `keymap_path` overrides default keys (see `keymap`). The image goes through a terminal
/// graphics protocol when `LIPMAP_GRAPHICS` asks for one or auto-detection finds one (see
/// `run_with`).
///
/// # Errors
/// When the keymap or session cannot be read, the session is locked by another editor, or
/// the terminal fails. The terminal is restored before the error is returned.
pub fn run(session_path: &Path, keymap_path: Option<&Path>) -> anyhow::Result<()> {
    let graphics = GraphicsChoice::from_flag_or_env(None).map_err(anyhow::Error::msg)?;
    let options = RunOptions {
        keymap: keymap_path.map(Path::to_path_buf),
        graphics,
        clip: None,
        tracker: Default::default(),
    };
    run_with(session_path, &options)
}

/// How `run_with` opens the TUI.
#[derive(Clone, Debug, Default)]
pub struct RunOptions {
    /// A keymap file overriding default keys.
    pub keymap: Option<std::path::PathBuf>,
    /// Graphics protocol choice (`--graphics`): auto queries the terminal at startup (never
    /// inside tmux or over SSH), half-blocks otherwise; see `widgets::graphics`.
    pub graphics: GraphicsChoice,
    /// The clip to open first, by name (default: the first).
    pub clip: Option<String>,
    /// The tracker's files for re-aligning and face boxes (`None`s: Debian's paths).
    pub tracker: crate::workflow::track::TrackerFiles,
}

/// `run` with explicit options. Switching clips (`<`/`>`) or the map labelled (`m` in the
/// head view) saves, then reopens the session on the other clip or map inside the same
/// terminal session.
///
/// # Errors
/// As `run`; an unknown clip name.
pub fn run_with(session_path: &Path, options: &RunOptions) -> anyhow::Result<()> {
    let keymap = match &options.keymap {
        Some(p) => Keymap::load(p)?,
        None => Keymap::builtin()?,
    };
    let clip = match &options.clip {
        Some(name) => {
            let s = crate::workflow::read_session(session_path)?.session;
            crate::workflow::find_clip(&s, name)
                .map_err(|e| anyhow::Error::new(e).context(session_path.display().to_string()))?
        }
        None => 0,
    };
    let (mut app, mut bridge, mut provider) = SessionBridge::open(session_path, clip)?;
    let env = TermEnv::from_process();
    let graphics = options.graphics;
    let signals = Signals::register(session_path)?;
    let (mut guard, mut gfx) = TerminalGuard::enter_with(|| GraphicsState::detect(graphics, env))?;
    if app.status.is_empty() && !gfx.note.is_empty() {
        apply(&mut app, Action::Status(gfx.note.clone()));
    }
    // Read on the first re-alignment, face box or suggestion, then kept for every clip.
    let tracker = Arc::new(TrackerSource::new(options.tracker.clone()));
    loop {
        // A channel and jobs per clip: replies of the previous clip's jobs go nowhere.
        let (tx, rx) = channel();
        if let Some(job) = bridge.side_view_job() {
            let tx = tx.clone();
            std::thread::spawn(move || tx.send(job()));
        }
        bridge.start_saver(tx.clone());
        let jobs = Jobs::start(provider.clone(), tx.clone());
        jobs.start_tracker(provider.clone(), tracker.clone());
        jobs.start_suggestions(tracker.clone());
        let checks = check_images_for_tui(provider, app.track.clone(), app.flag_thresholds.clone());
        jobs.run_once("the image checks", checks);
        jobs.run_once("the speech-driven head", bridge.speech_job());
        if let Some(side) = bridge.side_frames() {
            jobs.start_side_frames(side, tx);
        }
        let size = guard.terminal.size()?;
        apply(&mut app, Action::Opened { width: size.width, height: size.height });
        let inputs = LoopInputs { keymap: &keymap, rx: &rx, signals: &signals };
        let result =
            event_loop(&mut guard.terminal, &mut app, &mut bridge, &jobs, &mut gfx, inputs);
        if signals.caught().is_some() {
            signals.loop_left();
        }
        drop(jobs);
        // Whatever happened in the loop, do not lose the last edits: let the saver finish,
        // then write what is left.
        bridge.finish_saving();
        if !app.save.is_clean()
            && let Err(e) = bridge.save(&app)
        {
            drop(guard);
            return Err(e);
        }
        if app.save.is_clean() {
            // Everything is in the session file: the journal has nothing more to give.
            let _ = bridge.clear_journal();
        }
        // Reopened on another clip, or labelling another map; the map labelled stays unless
        // another was asked for.
        let reopen = (app.switch_clip.is_some() || app.switch_map.is_some())
            && result.is_ok()
            && signals.caught().is_none();
        let next = reopen.then(|| {
            (app.switch_clip.unwrap_or(app.clip), app.switch_map.unwrap_or(app.head.label_role))
        });
        let Some((next, role)) = next else {
            drop(guard);
            drop(bridge);
            if let Some(name) = signals.caught() {
                // The edits are saved and the lock is released; say why lipmap stopped.
                anyhow::bail!("stopped by {name}; the session was saved");
            }
            return result;
        };
        drop(bridge);
        let previous = app;
        (app, bridge, provider) =
            match SessionBridge::open_labelling(session_path, next, Some(role)) {
                Ok(o) => o,
                Err(e) => {
                    drop(guard);
                    return Err(e);
                }
            };
        let carried = Carried::of(&previous, &bridge.clip_name());
        apply(&mut app, Action::Carry { from: Box::new(carried) });
    }
}

/// The signals that stop the editor (TERM, INT, HUP), caught so that leaving saves the
/// edits, releases the lock and restores the terminal instead of dying on the spot.
///
/// A watchdog backs this up. When the terminal goes away (an SSH connection dropped, a tmux
/// session killed) the HUP arrives while crossterm's reader spins on the dead terminal
/// without returning, so the event loop never sees the signal. If the loop has not come back
/// within [`SIGNAL_GRACE`], the watchdog releases this process's lock and exits; every
/// finished edit is already in the fsynced journal, which the next open replays.
struct Signals {
    caught: Arc<AtomicUsize>,
    /// Set once the event loop has returned (saving may then take its time).
    loop_left: Arc<AtomicBool>,
    ids: Vec<signal_hook::SigId>,
}

/// How long the event loop has to notice a stopping signal before the watchdog steps in.
const SIGNAL_GRACE: Duration = Duration::from_secs(3);

impl Signals {
    fn register(session: &Path) -> anyhow::Result<Self> {
        use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
        let caught = Arc::new(AtomicUsize::new(0));
        let loop_left = Arc::new(AtomicBool::new(false));
        let ids = [SIGTERM, SIGINT, SIGHUP]
            .into_iter()
            .map(|sig| signal_hook::flag::register_usize(sig, caught.clone(), sig as usize))
            .collect::<Result<Vec<_>, _>>()?;
        let (c, left) = (caught.clone(), loop_left.clone());
        let session = session.to_path_buf();
        std::thread::Builder::new()
            .name("signal watchdog".into())
            .spawn(move || stop_when_loop_is_stuck(&c, &left, &session))?;
        Ok(Self { caught, loop_left, ids })
    }

    /// The name of the signal caught, if any.
    fn caught(&self) -> Option<&'static str> {
        use signal_hook::consts::{SIGHUP, SIGINT, SIGTERM};
        match self.caught.load(Ordering::SeqCst) as i32 {
            0 => None,
            SIGTERM => Some("SIGTERM"),
            SIGINT => Some("SIGINT"),
            SIGHUP => Some("SIGHUP"),
            _ => Some("a signal"),
        }
    }

    /// The event loop has returned: the watchdog stands down.
    fn loop_left(&self) {
        self.loop_left.store(true, Ordering::SeqCst);
    }
}

/// The watchdog's body: waits for a stopping signal, gives the event loop [`SIGNAL_GRACE`] to
/// return, and otherwise releases the lock (when it is still this process's) and exits with
/// the shell's code for the signal.
fn stop_when_loop_is_stuck(caught: &AtomicUsize, loop_left: &AtomicBool, session: &Path) {
    let step = Duration::from_millis(100);
    let sig = loop {
        if loop_left.load(Ordering::SeqCst) {
            return;
        }
        match caught.load(Ordering::SeqCst) {
            0 => std::thread::sleep(step),
            sig => break sig,
        }
    };
    let deadline = Instant::now() + SIGNAL_GRACE;
    while Instant::now() < deadline {
        if loop_left.load(Ordering::SeqCst) {
            return;
        }
        std::thread::sleep(step);
    }
    crate::workflow::session::release_lock_if_ours(session);
    std::process::exit(128 + sig as i32);
}

impl Drop for Signals {
    fn drop(&mut self) {
        self.loop_left();
        // Back to the default actions once the editor is gone.
        for id in self.ids.drain(..) {
            signal_hook::low_level::unregister(id);
        }
    }
}

/// Where the event loop's actions come from: keys (through the keymap), job replies and
/// the stopping signals.
struct LoopInputs<'a> {
    keymap: &'a Keymap,
    rx: &'a Receiver<Action>,
    signals: &'a Signals,
}

fn event_loop<B: Backend>(
    terminal: &mut Terminal<B>,
    app: &mut App,
    bridge: &mut SessionBridge,
    jobs: &Jobs,
    gfx: &mut GraphicsState,
    inputs: LoopInputs<'_>,
) -> anyhow::Result<()>
where
    B::Error: Send + Sync + 'static,
{
    let LoopInputs { keymap, rx, signals } = inputs;
    let mut redraw = true;
    let mut seen_edits = app.save.unsaved();
    let mut last_edit = Instant::now();
    let mut journaled = app.save.changes();
    // Playback's next frame is due then.
    let mut next_tick: Option<Instant> = None;
    loop {
        run_effects(app, bridge, jobs);
        if app.save.should_quit() || signals.caught().is_some() {
            return Ok(());
        }
        // Every finished edit goes to the journal before the next input is read (a drag is
        // written when it ends: it is one edit).
        if app.save.changes() != journaled && !app.frames.dragging {
            journaled = app.save.changes();
            if let Err(e) = bridge.journal(app) {
                apply(app, Action::Status(format!("edits not journaled: {e:#}")));
                redraw = true;
            }
        }
        if app.save.is_clean()
            && let Err(e) = bridge.clear_journal()
        {
            apply(app, Action::Status(format!("journal not removed: {e:#}")));
        }
        if app.save.unsaved() != seen_edits {
            seen_edits = app.save.unsaved();
            last_edit = Instant::now();
        }
        // Autosave waits for a pause in editing; whether to save then is `update`'s call.
        if last_edit.elapsed() >= AUTOSAVE_IDLE {
            apply(app, Action::Idle);
            if !app.effects.is_empty() {
                run_effects(app, bridge, jobs);
                seen_edits = app.save.unsaved();
                redraw = true;
            }
        }
        // A background encoding finished: show it.
        if gfx.poll() {
            redraw = true;
        }
        if redraw {
            terminal.draw(|f| {
                draw(app, keymap, f);
                draw_graphics(app, gfx, f);
            })?;
            redraw = false;
        }
        let wait = match (app.playing, next_tick) {
            (false, _) => {
                next_tick = None;
                POLL
            }
            (true, None) => {
                next_tick = Some(Instant::now() + frame_interval(app.fps));
                POLL
            }
            (true, Some(due)) => {
                let now = Instant::now();
                if now >= due {
                    apply(app, Action::PlayTick);
                    // A tick more than a frame late is not caught up with a burst of frames:
                    // playback slows down instead (a slow draw must not starve the keys,
                    // which are still read below, without waiting).
                    let interval = frame_interval(app.fps);
                    let floor = now.checked_sub(interval).unwrap_or(due);
                    next_tick = Some(due.max(floor) + interval);
                    redraw = true;
                    Duration::ZERO
                } else {
                    POLL.min(due - now)
                }
            }
        };
        if event::poll(wait)? {
            // Take every event already waiting before drawing again: a burst of keys is
            // applied (and journaled) at once rather than one frame each.
            loop {
                let action = match event::read()? {
                    Event::Key(k) => key_to_action(app, keymap, &k),
                    Event::Mouse(m) => mouse_to_action(&m),
                    Event::Resize(w, h) => Some(Action::Resize { width: w, height: h }),
                    _ => None,
                };
                if let Some(a) = action {
                    apply(app, a);
                }
                run_effects(app, bridge, jobs);
                if app.save.should_quit() || !event::poll(Duration::ZERO)? {
                    break;
                }
            }
            redraw = true;
        }
        while let Ok(a) = rx.try_recv() {
            apply(app, a);
            redraw = true;
        }
    }
}

/// One frame's time at `fps` (25 fps when the rate is unusable).
fn frame_interval(fps: f64) -> Duration {
    let fps = if fps.is_finite() && fps > 0.0 { fps } else { 25.0 };
    Duration::from_secs_f64(1.0 / fps)
}

/// Carries out queued effects.
fn run_effects(app: &mut App, bridge: &mut SessionBridge, jobs: &Jobs) {
    for effect in app.take_effects() {
        match effect {
            Effect::LoadFrames(frames) => jobs.request_frames(frames),
            Effect::LoadSideFrame(frame) => jobs.request_side_frame(frame),
            Effect::Fit { generation, frames } => {
                if let Some(job) = FitJob::of(app, generation, frames.as_deref()) {
                    jobs.request_fit(job);
                }
            }
            Effect::Save { generation } => {
                // Written on the saver thread; `Saved` comes back through the channel.
                if let Err(e) = bridge.save_in_background(app, generation) {
                    apply(app, Action::SaveFailed { error: format!("{e:#}") });
                }
            }
            Effect::StoreFits { fits } => {
                let stored = bridge.write_back(app).and_then(|()| bridge.store_fits(app, fits));
                let reply = match stored {
                    Ok(()) => Action::FitsStored,
                    Err(e) => Action::FitsNotStored { error: format!("{e:#}") },
                };
                apply(app, reply);
            }
            Effect::LoadMap => {
                let reply = match bridge.load_map_file() {
                    Ok((path, map)) => Action::MapLoaded { map, path: path.display().to_string() },
                    Err(e) => Action::Status(format!("map not loaded: {e:#}")),
                };
                apply(app, reply);
            }
            Effect::SaveMap => {
                let msg = match bridge.save_map(app) {
                    Ok(p) => format!("landmark map written to {}", p.display()),
                    Err(e) => format!("map not saved: {e:#}"),
                };
                apply(app, Action::Status(msg));
            }
            Effect::Analyse { generation } => {
                if let Some(job) = AnalysisJob::of(app, generation, bridge.clip_name()) {
                    jobs.request_analysis(job);
                }
            }
            Effect::AssessQuality => {
                // The job reads the session as last written back, with every correction.
                if let Err(e) = bridge.write_back(app) {
                    apply(app, Action::QualityFailed { error: format!("{e:#}") });
                    continue;
                }
                jobs.run_once("the quality cross-validation", bridge.quality_job());
            }
            Effect::PrepareHead(index) => match bridge.head_setup_job(index) {
                Some(job) => jobs.run_once("the transferred head's set-up", job),
                None => {
                    apply(app, Action::HeadPrepared { index, head: Err("no such head".into()) })
                }
            },
            Effect::TransferFrame { head, frame } => {
                if let Some(job) = HeadFrameJob::of(app, head, frame) {
                    jobs.request_head_frame(job);
                }
            }
            Effect::SuggestMap { labels, landmark } => {
                jobs.request_suggestion(bridge.suggest_job(labels, landmark));
            }
            Effect::Realign { frame } => {
                if let Some(job) = TrackJob::realign(app, frame) {
                    jobs.request_track(job);
                }
            }
            Effect::TrackFromBox { frame, face } => {
                if let Some(job) = TrackJob::from_box(app, frame, face) {
                    jobs.request_track(job);
                }
            }
            Effect::Quit => {}
        }
    }
}
