//! The adapter between a `Session` and the TUI's `App`: open (lock, load, frames, mesh,
//! model, map, cached fits), write the App's corrections, reviewed frames and map back into
//! the session, and save atomically through `Session::save`.
//!
//! The App never sees the session's types, so the TUI's update and drawing work (and are
//! tested) on plain data; only this file changes when the session format does.

use super::action::Action;
use crate::fit::FrameFit;
use crate::io::frames::FrameSource;
use crate::landmarks::PointSource;
use crate::landmarks::edit::corrections;
use crate::model::{LandmarkMap, Mesh};
use crate::session::{MapRole, Session};
use crate::tui::app::{App, FrameImage, FrameProvider};
use crate::workflow::session::JournalEntry;
use anyhow::Context;
use std::path::{Path, PathBuf};
use std::sync::mpsc::Sender;
use std::sync::{Arc, Condvar, Mutex};

/// Megabytes of decoded frames the session's frame source may cache (on top of the App's).
const FRAME_CACHE_MB: usize = 256;

/// Frames of a session clip, decoded by the session's `FrameSource`.
pub struct SessionFrames(pub FrameSource);

impl FrameProvider for SessionFrames {
    fn load(&self, frame: usize) -> anyhow::Result<FrameImage> {
        let img = self.0.get(frame)?;
        Ok(FrameImage { width: img.width(), height: img.height(), rgb: img.as_raw().clone() })
    }
}

/// Frames that cannot be shown (the session's frames are missing): every load fails with
/// the reason, and the TUI still edits landmarks over a black background.
pub struct NoFrames(pub String);

impl FrameProvider for NoFrames {
    fn load(&self, _frame: usize) -> anyhow::Result<FrameImage> {
        anyhow::bail!("{}", self.0)
    }
}

/// The saver thread's inbox: the newest snapshot not yet written, and whether to stop.
#[derive(Default)]
struct SaveQueue {
    next: Option<(Session, PathBuf, u64)>,
    closed: bool,
}

struct Saver {
    queue: Arc<(Mutex<SaveQueue>, Condvar)>,
    thread: Option<std::thread::JoinHandle<()>>,
}

impl Drop for SessionBridge {
    fn drop(&mut self) {
        self.finish_saving();
    }
}

/// An open session (the workflow's `EditSession`: file, lock released on drop, journal) and
/// the clip being edited.
pub struct SessionBridge {
    edit: crate::workflow::EditSession,
    pub clip: usize,
    /// Which mesh's map the head view labels (see `workflow::map::label_role`).
    role: MapRole,
    /// Map as loaded, so an unchanged map from a file is not copied inline.
    loaded_map: Option<LandmarkMap>,
    /// The map file this bridge wrote (the only map file it may overwrite).
    written_map: Option<PathBuf>,
    /// The thread writing session snapshots, once started.
    saver: Option<Saver>,
}

impl SessionBridge {
    /// Locks and loads the session at `path` and builds the App for clip `clip`, with the
    /// frame provider for its images, labelling the mesh that needs a map. Missing frames,
    /// mesh or model are reported in the status line rather than refusing to open:
    /// landmarks can be corrected without them.
    ///
    /// # Errors
    /// When the session cannot be locked or read, or has no clip `clip`.
    pub fn open(path: &Path, clip: usize) -> anyhow::Result<(App, Self, Arc<dyn FrameProvider>)> {
        Self::open_labelling(path, clip, None)
    }

    /// As [`SessionBridge::open`], the head view labelling the map of `role` when the session
    /// has it (see `workflow::map::label_role_or`).
    ///
    /// # Errors
    /// As [`SessionBridge::open`].
    pub fn open_labelling(
        path: &Path,
        clip: usize,
        role: Option<MapRole>,
    ) -> anyhow::Result<(App, Self, Arc<dyn FrameProvider>)> {
        // Locked, loaded, a crashed editor's journal replayed (or set aside when it cannot
        // be): the one way a session is opened for editing.
        let mut edit = crate::workflow::open_for_edit_at(path)?;
        let restored = !edit.restored.is_empty();
        let mut problems: Vec<String> =
            std::mem::take(&mut edit.notices).iter().map(|w| w.status_text().to_string()).collect();
        let session = &edit.session;
        let c = session.clip(clip)?;
        let tracked = c.tracked()?.as_ref().clone();
        let track = c.corrections.effective_track(&tracked);
        let mut app = App::new(format!("{} · {}", session.name, c.name), tracked, track);
        app.reviewed = c.corrections.reviewed.clone();
        app.alignment = c.alignment.clone();
        app.fps = c.front.fps;
        app.frames.cache.size = c.front.size.map(|[w, h]| (w, h));
        app.fit_settings = session.fit_settings.clone();
        app.lip_contact_px = session.lip_contact_precision();
        if restored {
            // Not on disk in the session file yet: autosave writes them.
            app.save.edit_made();
        }

        let provider: Arc<dyn FrameProvider> = match session.open_frames(clip, FRAME_CACHE_MB) {
            Ok(src) => {
                let [w, h] = src.size();
                if w > 0 && h > 0 {
                    app.frames.cache.size = Some((w, h));
                }
                Arc::new(SessionFrames(src))
            }
            Err(e) => {
                problems.push(format!("frames: {e}"));
                Arc::new(NoFrames(e.to_string()))
            }
        };
        // The head view labels the mesh that needs a map: the model's (its mean) or the head's.
        let role = crate::workflow::map::label_role_or(session, role);
        let label_file = crate::workflow::map::mesh_file_of(session, role).map(Path::to_path_buf);
        let file_name = |p: Option<&Path>| {
            p.and_then(Path::file_name)
                .map_or_else(String::new, |n| n.to_string_lossy().into_owned())
        };
        let other = match role {
            MapRole::Model => MapRole::Head,
            MapRole::Head => MapRole::Model,
        };
        app.head.other_mesh_name = if session.head_has_own_map() {
            file_name(crate::workflow::map::mesh_file_of(session, other))
        } else {
            String::new()
        };
        let labels_model_mean =
            session.model.as_ref().is_some_and(|m| Some(&m.path) == label_file.as_ref());
        app.head.label_role = role;
        app.head.label_mesh_name = file_name(label_file.as_deref());
        app.head.head_has_own_map = session.head_has_own_map();
        // A figure's helper and joint geometry is never offered for labelling, nor drawn but
        // for the eyes, teeth and tongue.
        let obj = |p: &Path| p.extension().is_some_and(|e| e.eq_ignore_ascii_case("obj"));
        let parts = |f: fn(&Path) -> crate::io::error::Result<Option<Vec<bool>>>| {
            label_file.as_deref().filter(|p| obj(p)).and_then(|p| f(p).ok().flatten()).map(Arc::new)
        };
        let (candidates, occluders) =
            (parts(crate::io::obj::labelable_vertices), parts(crate::io::obj::occluding_vertices));
        if let Some(mesh_path) = label_file.as_ref().filter(|_| !labels_model_mean) {
            match crate::io::obj::read_obj(mesh_path) {
                Ok(mesh) => {
                    app.set_label_mesh(Arc::new(mesh), candidates.clone(), occluders.clone())
                }
                Err(e) => problems.push(format!("mesh: {e}")),
            }
        }
        if let Some(m) = &session.model {
            match crate::io::model_source::load_model(&m.path, m.blendshapes.as_deref()) {
                Ok(model) => {
                    if labels_model_mean {
                        app.set_label_mesh(Arc::new(model.mean_mesh()), candidates, occluders);
                    }
                    app.model = Some(Arc::new(model));
                }
                Err(e) => problems.push(format!("model: {e:#}")),
            }
        }
        // The session's rule: an inline map (from labelling) wins over the file.
        let mut resolve = |r: &crate::session::MapRef, what: &str| {
            r.resolve().unwrap_or_else(|e| {
                problems.push(format!("{what}: {e}"));
                None
            })
        };
        let map = resolve(session.map_of(role), "map");
        if role == MapRole::Head {
            app.model_map = resolve(&session.landmark_map, "model map");
        }
        app.map = map.clone();
        if role == MapRole::Model && session.head_has_own_map() {
            app.other_head = other_head(session, &mut problems);
        }
        app.frame_head();
        // The cache only saves time: a cache file that cannot be read is said, and the
        // frames are fitted again.
        match session.cached_fits(clip, &session.fit_settings) {
            Ok(fits) => app.fits.by_frame.extend(fits.into_iter().map(|f| (f.frame, f))),
            Err(e) => problems.push(format!("cached fits: {e}")),
        }
        if !app.fits.by_frame.is_empty() {
            app.recompute_flags();
        }
        if c.side.is_some() {
            app.side = crate::tui::screens::side::SideState::Measuring;
        }
        app.clip_names = session.clips.iter().map(|c| c.name.clone()).collect();
        app.head.heads = crate::tui::screens::head::TransferredHeads::named(
            session.transferred_heads.iter().map(|h| h.name.clone()).collect(),
        );
        app.clip = clip;
        if !problems.is_empty() {
            app.status = problems.join("; ");
        }
        let bridge = Self { edit, clip, role, loaded_map: map, written_map: None, saver: None };
        Ok((app, bridge, provider))
    }

    /// Writes the App's corrections, reviewed frames and (changed) landmark map into the
    /// session in memory. The tracker's landmarks are never touched.
    ///
    /// # Errors
    /// When a correction is rejected by the session (non-finite, bad index).
    pub fn write_back(&mut self, app: &App) -> anyhow::Result<()> {
        let layer = self.edit_layer(app)?;
        let c = self.edit.session.clip_mut(self.clip).context("the clip disappeared")?;
        c.corrections = layer.corrections;
        if app.side.view().is_some() {
            c.profile_corrections = layer.profile_corrections;
        }
        if let Some(map) = layer.landmark_map {
            self.edit.session.map_of_mut(self.role).inline = Some(map);
        }
        Ok(())
    }

    /// The App's edits of this clip as the session stores them: corrections, reviewed
    /// frames, side-view corrections (the session's own when the side view is not loaded)
    /// and the map when it was changed.
    fn edit_layer(&self, app: &App) -> anyhow::Result<JournalEntry> {
        let c = self.edit.session.clips.get(self.clip).context("the clip disappeared")?;
        let mut fresh = crate::session::Corrections::default();
        for (frame, index, p) in corrections(&app.tracked, &app.track) {
            // Placeholders of frames the tracker missed are not corrections.
            if p.source == PointSource::Tracked && app.tracked.get(frame).is_none() {
                continue;
            }
            fresh.set(frame, index, p).map_err(|m| anyhow::anyhow!(m))?;
        }
        fresh.reviewed = app.reviewed.clone();
        let profile_corrections = match app.side.view() {
            Some(side) => side.track.corrected.clone(),
            None => c.profile_corrections.clone(),
        };
        let landmark_map = app
            .map
            .as_ref()
            .filter(|m| self.loaded_map.as_ref() != Some(*m))
            .map(|m| m.to_vertex.clone());
        Ok(JournalEntry {
            clip: c.name.clone(),
            corrections: fresh,
            profile_corrections,
            landmark_map,
            map_role: self.role,
        })
    }

    /// Appends the App's edit layer to the journal, on disk when this returns.
    ///
    /// # Errors
    /// As `write_back`; the journal cannot be written.
    pub fn journal(&mut self, app: &App) -> anyhow::Result<()> {
        let entry = self.edit_layer(app)?;
        Ok(self.edit.record(&entry)?)
    }

    /// Removes the journal: call when the session file holds every edit.
    ///
    /// # Errors
    /// The journal exists and cannot be removed.
    pub fn clear_journal(&mut self) -> anyhow::Result<()> {
        Ok(self.edit.retire_journal()?)
    }

    /// The side view's measurement for a job's thread (it decodes every side frame), when
    /// the clip has a side view: replies `SideReady` or `SideFailed`.
    pub fn side_view_job(&self) -> Option<impl FnOnce() -> Action + Send + 'static> {
        let c = self.edit.session.clips.get(self.clip)?;
        let side = c.side.clone()?;
        let (session, clip) = (self.edit.session.clone(), self.clip);
        Some(move || {
            let measured = crate::workflow::side_view_track(&session, clip)
                .map_err(anyhow::Error::from)
                .and_then(|found| found.context("the clip has no side view"));
            match measured {
                Ok((setup, track)) => Action::SideReady {
                    side: Box::new(crate::tui::screens::side::SideView {
                        n_frames: track.automatic.len(),
                        setup,
                        track,
                        fps: side.fps,
                        offset_s: side.offset_s,
                        images: Default::default(),
                        image_errors: Default::default(),
                    }),
                },
                Err(e) => Action::SideFailed { error: format!("{e:#}") },
            }
        })
    }

    /// The speech-driven head of this clip for a job's thread (it may fit what the cache
    /// lacks and inverts the whole clip's audio): replies `SpeechReady` or `SpeechAbsent`.
    pub fn speech_job(&self) -> impl FnOnce() -> Action + Send + 'static {
        let (mut session, clip) = (self.edit.session.clone(), self.clip);
        move || super::jobs::speech_for_tui(&mut session, clip)
    }

    /// Map suggestions from `labels` for the suggestions' job, on the session as last
    /// written back (its meshes and clip), for the mesh this bridge labels.
    pub fn suggest_job(
        &self,
        labels: LandmarkMap,
        landmark: Option<usize>,
    ) -> super::jobs::SuggestJob {
        super::jobs::SuggestJob {
            session: self.edit.session.clone(),
            role: self.role,
            clip: self.clip_name(),
            labels,
            landmark,
        }
    }

    /// The quality cross-validation over this session's sentences for a job's thread (it
    /// may fit what the cache lacks): replies `QualityReady` or `QualityFailed`.
    pub fn quality_job(&self) -> impl FnOnce() -> Action + Send + 'static {
        let (mut session, path) = (self.edit.session.clone(), self.edit.path.clone());
        move || super::jobs::quality_for_tui(&mut session, &path)
    }

    /// The set-up of the session's transferred head number `index` for a job's thread:
    /// replies `HeadPrepared`. `None` when the session has no such head.
    pub fn head_setup_job(&self, index: usize) -> Option<impl FnOnce() -> Action + Send + 'static> {
        let entry = self.edit.session.transferred_heads.get(index)?.clone();
        let session = self.edit.session.clone();
        Some(move || {
            let head = super::jobs::prepare_head_for_tui(&session, &entry);
            Action::HeadPrepared { index, head: head.map(Arc::new) }
        })
    }

    /// The side view's frames, when the clip has a side view that opens.
    pub fn side_frames(&self) -> Option<Arc<dyn FrameProvider>> {
        let src = self.edit.session.open_side_frames(self.clip, FRAME_CACHE_MB / 4).ok()??;
        Some(Arc::new(SessionFrames(src)))
    }

    /// Reads the session's map file (the eos TOML it refers to), ignoring the labels stored
    /// in the session.
    ///
    /// # Errors
    /// No map file in the session; an unreadable or malformed file.
    pub fn load_map_file(&self) -> anyhow::Result<(PathBuf, LandmarkMap)> {
        let path = self
            .edit
            .session
            .map_of(self.role)
            .file
            .clone()
            .context("the session has no map file (lipmap import SESSION --mapping FILE)")?;
        let map = crate::io::landmark_map_toml::read_landmark_map(&path)?;
        Ok((path, map))
    }

    /// Name of the clip being edited.
    pub fn clip_name(&self) -> String {
        self.edit.session.clips.get(self.clip).map_or_else(String::new, |c| c.name.clone())
    }

    /// `write_back` then an atomic save to the session file.
    ///
    /// # Errors
    /// As `write_back` and `Session::save`.
    pub fn save(&mut self, app: &App) -> anyhow::Result<()> {
        self.write_back(app)?;
        Ok(self.edit.save()?)
    }

    /// Starts the saver thread: `save_in_background` then replies `Saved`/`SaveFailed` on
    /// `tx`, so the UI never waits for the disk.
    pub fn start_saver(&mut self, tx: Sender<Action>) {
        let queue: Arc<(Mutex<SaveQueue>, Condvar)> = Arc::default();
        let q = queue.clone();
        let thread = std::thread::spawn(move || {
            loop {
                let job = {
                    let (lock, wake) = &*q;
                    let Ok(mut g) = lock.lock() else { return };
                    loop {
                        if let Some(job) = g.next.take() {
                            break job;
                        }
                        if g.closed {
                            return;
                        }
                        let Ok(ng) = wake.wait(g) else { return };
                        g = ng;
                    }
                };
                let (session, path, generation) = job;
                let reply = match session.save(&path) {
                    Ok(()) => Action::Saved { generation },
                    Err(e) => Action::SaveFailed { error: e.to_string() },
                };
                let _ = tx.send(reply);
            }
        });
        self.saver = Some(Saver { queue, thread: Some(thread) });
    }

    /// `write_back`, then hands a snapshot of the session to the saver thread (a newer
    /// snapshot replaces one not yet started); without a saver, saves here.
    ///
    /// # Errors
    /// As `write_back`; as `Session::save` without a saver.
    pub fn save_in_background(&mut self, app: &App, generation: u64) -> anyhow::Result<()> {
        self.write_back(app)?;
        match &self.saver {
            Some(s) => {
                let (lock, wake) = &*s.queue;
                let mut g = lock.lock().map_err(|_| anyhow::anyhow!("the saver thread died"))?;
                g.next = Some((self.edit.session.clone(), self.edit.path.clone(), generation));
                wake.notify_one();
                Ok(())
            }
            None => Ok(self.edit.session.save(&self.edit.path)?),
        }
    }

    /// Waits for the saver to write what it was given, and stops it.
    pub fn finish_saving(&mut self) {
        if let Some(mut s) = self.saver.take() {
            if let Ok(mut g) = s.queue.0.lock() {
                g.closed = true;
                s.queue.1.notify_all();
            }
            if let Some(t) = s.thread.take() {
                let _ = t.join();
            }
        }
    }

    /// Caches fits in the session (call after `write_back`, so the cache keys match the
    /// landmarks the fits were made from).
    ///
    /// # Errors
    /// When a fit names a frame without landmarks.
    pub fn store_fits(&mut self, app: &App, fits: Vec<FrameFit>) -> anyhow::Result<()> {
        self.edit.session.store_fits(self.clip, &app.fit_settings, fits)?;
        Ok(())
    }

    /// Writes the landmark map in eos's TOML format to a file of the session's own beside
    /// the session file (`NAME.ibug_map.txt`, numbered if that name is taken by a file the
    /// session did not write) and records it in the session. The map file the session was
    /// created from is an input and is never overwritten. Returns the path written.
    ///
    /// # Errors
    /// When there is no map or the file cannot be written.
    pub fn save_map(&mut self, app: &App) -> anyhow::Result<PathBuf> {
        let map = app.map.as_ref().filter(|m| !m.is_empty()).context("no landmarks mapped yet")?;
        let dir = crate::session::absolute(self.edit.path.parent().unwrap_or(Path::new(".")));
        let ours = self.written_map.clone();
        let target = (1..1000)
            .map(|k| {
                let n = if k == 1 { String::new() } else { format!(".{k}") };
                let kind = match self.role {
                    MapRole::Model => "ibug_map",
                    MapRole::Head => "head_map",
                };
                dir.join(format!("{}.{kind}{n}.txt", self.edit.session.name))
            })
            .find(|p| Some(p) == ours.as_ref() || !p.exists())
            .context("no free file name for the landmark map")?;
        if std::fs::metadata(&target).is_ok_and(|m| m.permissions().readonly()) {
            anyhow::bail!("{} is read-only", target.display());
        }
        let names = &crate::reference::current().names;
        crate::io::landmark_map_toml::write_landmark_map(&target, map, names)?;
        self.edit.session.map_of_mut(self.role).file = Some(target.clone());
        self.edit.session.map_of_mut(self.role).set_inline(map);
        self.loaded_map = Some(map.clone());
        self.written_map = Some(target.clone());
        Ok(target)
    }
}

/// The session's head and its own map, for the facial indices while the model map is being
/// labelled (`None` while the head has no map yet). A head or map that cannot be read is
/// said in `problems`.
fn other_head(session: &Session, problems: &mut Vec<String>) -> Option<(Arc<Mesh>, LandmarkMap)> {
    let map = match session.head_map.as_ref()?.resolve() {
        Ok(map) => map.filter(|m| !m.is_empty())?,
        Err(e) => {
            problems.push(format!("head map: {e}"));
            return None;
        }
    };
    match crate::io::obj::read_obj(session.head_mesh.as_deref()?) {
        Ok(mesh) => Some((Arc::new(mesh), map)),
        Err(e) => {
            problems.push(format!("head: {e}"));
            None
        }
    }
}
