//! Sessions: everything a user does on a set of clips, in one JSON file
//! (`sessions/NAME.lipmap.json`) with the clips' per-frame data (tracked landmarks, cached
//! fits) in files beside it (`NAME.lipmap.d/`), saved atomically, versioned, and locked while
//! edited.
//!
//! Start with `Session::load` / `Session::save` and `SessionLock::acquire`; edits go through
//! `set_correction`/`clear_correction` (the tracker's values are never changed), the landmarks
//! a fit should use come from `effective_frame`, and fits are cached with `store_fits` and
//! checked with `stale_frames`. A clip's per-frame data is read when it is first used and
//! dropped when no caller holds it (`clip_data`), so memory follows the clips being worked
//! on, not the corpus. The file format is described in docs/session-format.md.

pub mod binary;
pub mod bounds;
pub mod cache;
pub mod clip_data;
pub mod corrections;
pub mod data_dir;
pub mod fits_file;
pub mod journal;
pub mod migrate;
pub mod model;
pub mod store;
pub mod track_file;
pub mod transferred;

pub use cache::{CachedFrame, FitCacheEntry};
pub use corrections::Corrections;
pub use migrate::CURRENT_SCHEMA;
pub use model::{Clip, ClipAudio, FramesRef, MapRef, MapRole, ModelRef, Session, View};
pub use store::{LockInfo, SessionLock};
pub use transferred::TransferredHead;

use crate::fit::{FitSettings, FrameFit};
use crate::io::frames::{FrameError, FrameOptions, FrameSource};
use crate::landmarks::{FrameLandmarks, LandmarkPoint, Track};
use clip_data::ClipDataKind;
use migrate::SchemaVersion;
use std::path::{Path, PathBuf};

/// How many bytes of new per-frame data (imports, fits) a session that writes its data early
/// ([`Session::write_data_early`]) keeps in memory before putting it in files.
pub const SPILL_BUDGET_BYTES: usize = 64 << 20;

/// Where a session's new per-frame data goes before the save, and how much of it waits in
/// memory. Not part of the session's value: two sessions equal in content are equal.
#[derive(Clone, Debug, Default)]
pub(crate) struct Spill {
    dir: Option<PathBuf>,
    pending: usize,
}

impl PartialEq for Spill {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

/// A value derived from a session's clips, made on first use and kept until
/// [`DerivedOnce::forget`]. Not part of the session's value: two sessions equal in content
/// are equal.
#[derive(Debug)]
pub(crate) struct DerivedOnce<T>(std::sync::OnceLock<T>);

impl<T> Default for DerivedOnce<T> {
    fn default() -> Self {
        Self(std::sync::OnceLock::new())
    }
}

impl<T: Clone> Clone for DerivedOnce<T> {
    fn clone(&self) -> Self {
        let cell = std::sync::OnceLock::new();
        if let Some(v) = self.0.get() {
            let _ = cell.set(v.clone());
        }
        Self(cell)
    }
}

impl<T> PartialEq for DerivedOnce<T> {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

impl<T> DerivedOnce<T> {
    fn get_or_init(&self, make: impl FnOnce() -> T) -> &T {
        self.0.get_or_init(make)
    }

    fn forget(&mut self) {
        self.0 = std::sync::OnceLock::new();
    }
}

/// The default folder of session files, relative to the working directory.
pub const SESSIONS_DIR: &str = "sessions";

/// The default file of a session named `name`: `sessions/NAME.lipmap.json`.
pub fn default_path(name: &str) -> PathBuf {
    Path::new(SESSIONS_DIR).join(format!("{name}.lipmap.json"))
}

/// Why a session could not be read, written, locked or edited.
#[derive(Debug, thiserror::Error)]
pub enum SessionError {
    #[error("{}: {source}", path.display())]
    Io { path: PathBuf, source: std::io::Error },
    /// Bad JSON or a bad field, at serde_json's 1-based line and column.
    #[error("{}:{line}:{column}: {message}", path.display())]
    Parse { path: PathBuf, line: usize, column: usize, message: String },
    #[error(
        "{}: this session was written by a newer lipmap (session schema {found}; this build reads up to {supported}); update lipmap to open it",
        path.display()
    )]
    NewerSchema { path: PathBuf, found: u32, supported: u32 },
    /// A missing or malformed `schema_version`, or a failed migration.
    #[error("{}: {message}", path.display())]
    Schema { path: PathBuf, message: String },
    #[error(
        "{} is open in another editor: {holder}; close it there first (if that editor crashed on another machine, delete {})",
        session.display(),
        lock.display()
    )]
    Locked { session: PathBuf, lock: PathBuf, holder: LockInfo },
    /// Content that parses but breaks a rule (duplicate clip names, non-finite numbers).
    #[error("{}: {message}", path.display())]
    Invalid { path: PathBuf, message: String },
    #[error("no clip {index} (the session has {count})")]
    NoClip { index: usize, count: usize },
    #[error("clip {clip:?}: {message}")]
    Edit { clip: String, message: String },
}

/// Refuses a folder, FIFO, socket or device at `path` before a byte is read (a FIFO would
/// block forever, a device never end), as every file a user names is (`io::input`); a
/// missing or unreadable file is left to the read, which names its I/O error.
pub(crate) fn refuse_special_file(path: &Path) -> Result<(), SessionError> {
    match crate::io::input::check_regular_file(path) {
        Err(e) if std::fs::metadata(path).is_ok() => {
            Err(SessionError::Invalid { path: path.to_path_buf(), message: e.message })
        }
        _ => Ok(()),
    }
}

/// `path` made absolute against the working directory, `.`/`..` folded.
pub fn absolute(path: &Path) -> PathBuf {
    let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    store::normalize_lexically(&abs)
}

/// The file a save of `abs` must replace: `abs` itself, or the file a symbolic link there
/// points to (followed to its end), so saving through a link keeps the link. Paths in the
/// session stay relative to `abs`'s folder, where it is loaded from.
fn link_target(abs: &Path) -> PathBuf {
    let mut target = abs.to_path_buf();
    // A bounded walk: a cycle of links is left to the write to report.
    for _ in 0..40 {
        match std::fs::read_link(&target) {
            Ok(next) => target = absolute(&parent_dir(&target).join(next)),
            Err(_) => break,
        }
    }
    target
}

fn parent_dir(abs_file: &Path) -> PathBuf {
    abs_file.parent().map(PathBuf::from).unwrap_or_else(|| PathBuf::from("/"))
}

fn parse_error(path: &Path, e: &serde_json::Error) -> SessionError {
    // serde_json's Display appends " at line L column C"; the position is in the prefix.
    let full = e.to_string();
    let suffix = format!(" at line {} column {}", e.line(), e.column());
    let message = full.strip_suffix(&suffix).unwrap_or(&full).to_string();
    SessionError::Parse { path: path.to_path_buf(), line: e.line(), column: e.column(), message }
}

impl Session {
    /// Reads the session at `path`, migrating an older schema; paths become absolute.
    ///
    /// # Errors
    /// `Io`; `Parse` with serde_json's line and column; `NewerSchema` for a file from a newer
    /// lipmap; `Schema` when the version is missing or a migration fails; `Invalid` when
    /// the content breaks a rule (e.g. two clips with one name).
    pub fn load(path: &Path) -> Result<Session, SessionError> {
        let abs = absolute(path);
        refuse_special_file(&abs)?;
        let text = std::fs::read_to_string(&abs)
            .map_err(|source| SessionError::Io { path: abs.clone(), source })?;
        let base = parent_dir(&abs);
        let version =
            match migrate::peek_schema_version(&text).map_err(|e| parse_error(&abs, &e))? {
                SchemaVersion::Version(v) => v,
                SchemaVersion::Missing => {
                    return Err(SessionError::Schema {
                        path: abs,
                        message: "no `schema_version`: not a lipmap session file".into(),
                    });
                }
                SchemaVersion::NotANumber(v) => {
                    return Err(SessionError::Schema {
                        path: abs,
                        message: format!("`schema_version` must be a whole number, found {v}"),
                    });
                }
            };
        if version > CURRENT_SCHEMA {
            return Err(SessionError::NewerSchema {
                path: abs,
                found: version,
                supported: CURRENT_SCHEMA,
            });
        }
        let mut session: Session = if version >= migrate::TYPED_FROM {
            store::with_base_dir(&base, || serde_json::from_str(&text))
                .map_err(|e| parse_error(&abs, &e))?
        } else {
            let tree: serde_json::Value =
                serde_json::from_str(&text).map_err(|e| parse_error(&abs, &e))?;
            let tree = migrate::migrate(tree, version, migrate::STEPS, migrate::TYPED_FROM)
                .map_err(|message| SessionError::Schema { path: abs.clone(), message })?;
            match store::with_base_dir(&base, || serde_json::from_value(tree)) {
                Ok(session) => session,
                // A problem the upgrade did not make is in the file as written: parsing the
                // text itself names its line and column, which the upgraded tree has lost.
                Err(e) => {
                    return Err(
                        match store::with_base_dir(&base, || serde_json::from_str::<Session>(&text))
                        {
                            Err(at) => parse_error(&abs, &at),
                            Ok(_) => SessionError::Schema {
                                path: abs,
                                message: format!("after upgrade: {e}"),
                            },
                        },
                    );
                }
            }
        };
        session.base_dir = base;
        session.schema_version = CURRENT_SCHEMA;
        if session.name.is_empty() {
            session.name = model::session_name_of(&abs);
        }
        session.adopt_legacy_fit_cache();
        session
            .validate()
            .map_err(|message| SessionError::Invalid { path: abs.clone(), message })?;
        session
            .check_data_files()
            .map_err(|message| SessionError::Invalid { path: abs, message })?;
        Ok(session)
    }

    /// Moves a schema-2 file's session-wide fit cache into its clips (entries of clips the
    /// session does not have are dropped: nothing could use them).
    fn adopt_legacy_fit_cache(&mut self) {
        let legacy = std::mem::take(&mut self.legacy_fit_cache);
        if legacy.is_empty() {
            return;
        }
        let mut per_clip: Vec<Vec<FitCacheEntry>> = vec![Vec::new(); self.clips.len()];
        for e in legacy {
            if let Some(i) = self.clip_index(&e.clip) {
                per_clip[i].push(e.entry);
            }
        }
        for (clip, mut entries) in self.clips.iter_mut().zip(per_clip) {
            if entries.is_empty() {
                continue;
            }
            let excess = entries.len().saturating_sub(cache::MAX_CACHED_SETTINGS_PER_CLIP);
            entries.drain(..excess);
            clip.fit_cache = clip_data::ClipData::new(entries);
        }
    }

    /// Every track file the session refers to exists (a missing one is named at once rather
    /// than when its clip is reached). A missing fit cache file loses nothing that cannot be
    /// made again: the clip's cache starts empty and the file is listed in
    /// `lost_fit_caches`, so that the session stays usable.
    fn check_data_files(&mut self) -> Result<(), String> {
        for c in &mut self.clips {
            if let Some(f) = c.tracked_data().file()
                && let Err(e) = std::fs::metadata(&f)
            {
                return Err(format!("clip {:?}: tracked: {}: {e}", c.name, f.display()));
            }
            if let Some(f) = c.fit_cache.file()
                && std::fs::metadata(&f).is_err()
            {
                c.fit_cache = clip_data::ClipData::default();
                self.lost_fit_caches.push((c.name.clone(), f));
            }
        }
        Ok(())
    }

    /// Writes the session to `path` atomically (temp file, fsync, rename, fsync folder),
    /// keeping the previous versions as `NAME.bak`, `NAME.bak.2`, `NAME.bak.3`. Paths are
    /// written relative to `path`'s folder. Take a `SessionLock` first when editing.
    ///
    /// # Errors
    /// `Invalid` when the session breaks a rule (nothing is written), `Io` when the file
    /// cannot be written; the file on disk is unchanged in both cases.
    pub fn save(&self, path: &Path) -> Result<(), SessionError> {
        let abs = absolute(path);
        let target = link_target(&abs);
        self.validate().map_err(|message| SessionError::Invalid { path: abs.clone(), message })?;
        // The data first: the session file that refers to it is written only once it is all
        // on disk.
        self.store_data(&data_dir::data_dir_of(&target))?;
        // The old file's text is read and let go before the new one is made, so a corpus's
        // save holds one session text at a time.
        let before = data_dir::names_referenced_by_file(&target);
        store::write_atomically_with(&target, |file| self.write_json(&abs, file))?;
        data_dir::tidy(&target, &self.data_file_names(), &before);
        Ok(())
    }

    /// Puts every clip's per-frame data in a file of `dir` (what is there already is kept).
    ///
    /// # Errors
    /// `Invalid` for data breaking a rule, `Io` for a file that cannot be written.
    fn store_data(&self, dir: &Path) -> Result<(), SessionError> {
        for c in &self.clips {
            let stem = data_dir::file_stem(&c.name);
            c.tracked_data().put_in(dir, &stem)?;
            c.fit_cache.put_in(dir, &stem)?;
        }
        Ok(())
    }

    /// The names of the data files the session refers to.
    fn data_file_names(&self) -> std::collections::BTreeSet<std::ffi::OsString> {
        self.clips
            .iter()
            .flat_map(|c| [c.tracked_data().file(), c.fit_cache.file()])
            .flatten()
            .filter_map(|f| f.file_name().map(std::ffi::OsString::from))
            .collect()
    }

    /// Lets the per-frame data this session makes (imports, fits) go to the data folder of
    /// the session file `file` whenever more than [`SPILL_BUDGET_BYTES`] of it waits in
    /// memory, rather than all at the save: for a session this process holds the lock of
    /// and will save at `file`. Until that save the files are referred to by nothing on
    /// disk; a crash leaves them to be tidied away.
    pub fn write_data_early(&mut self, file: &Path) {
        let dir = data_dir::data_dir_of(&link_target(&absolute(file)));
        self.spill = Spill { dir: Some(dir), pending: 0 };
    }

    /// Counts `bytes` of new data in memory, putting the session's unsaved data in files
    /// when it passes the budget.
    ///
    /// # Errors
    /// As [`Session::save`]'s writing of data.
    fn note_new_data(&mut self, bytes: usize) -> Result<(), SessionError> {
        let Some(dir) = self.spill.dir.clone() else { return Ok(()) };
        self.spill.pending = self.spill.pending.saturating_add(bytes);
        if self.spill.pending >= SPILL_BUDGET_BYTES {
            self.store_data(&dir)?;
            self.spill.pending = 0;
        }
        Ok(())
    }

    /// The exact bytes `save` writes for a file at `path`.
    ///
    /// # Errors
    /// `Invalid` when the session breaks a rule or holds a path that is not UTF-8.
    pub fn to_json(&self, path: &Path) -> Result<Vec<u8>, SessionError> {
        let abs = absolute(path);
        self.validate().map_err(|message| SessionError::Invalid { path: abs.clone(), message })?;
        let mut out = Vec::with_capacity(1 << 16);
        self.write_json(&abs, &mut out)?;
        Ok(out)
    }

    /// Writes the session file's text for `path` to `out` as it is made (what
    /// [`Session::to_json`] returns).
    ///
    /// # Errors
    /// `Invalid` when the session breaks a rule; `Io` naming `path` when `out` fails.
    fn write_json(&self, path: &Path, out: &mut dyn std::io::Write) -> Result<(), SessionError> {
        let abs = absolute(path);
        let base = parent_dir(&abs);
        let mut ser =
            serde_json::Serializer::with_formatter(&mut *out, store::ShallowPretty::new(5));
        store::with_base_dir(&base, || serde::Serialize::serialize(self, &mut ser)).map_err(
            |e| {
                if e.is_io() {
                    SessionError::Io { path: abs.clone(), source: e.into() }
                } else {
                    SessionError::Invalid { path: abs.clone(), message: e.to_string() }
                }
            },
        )?;
        out.write_all(b"\n").map_err(|source| SessionError::Io { path: abs, source })
    }

    /// Checks the rules serde cannot: unique clip names, values within what the data can
    /// mean (`bounds`), and finite numbers everywhere (JSON has no NaN; serde_json would
    /// write `null` and the file would not load again). Per-frame data is checked while it
    /// is in memory only; a data file is checked when it is read.
    ///
    /// # Errors
    /// A message naming the clip, frame and point at fault.
    pub fn validate(&self) -> Result<(), String> {
        if self.schema_version != CURRENT_SCHEMA {
            return Err(format!(
                "schema_version is {}, this build writes {CURRENT_SCHEMA}",
                self.schema_version
            ));
        }
        let mut names = std::collections::BTreeSet::new();
        for clip in &self.clips {
            let c = &clip.name;
            if !names.insert(c.as_str()) {
                return Err(format!("two clips are named {c:?}"));
            }
            let bad_point = |p: &LandmarkPoint| {
                !(p.x.is_finite() && p.y.is_finite())
                    || p.confidence.is_some_and(|v| !v.is_finite())
            };
            if let Some(track) = clip.tracked_data().unsaved() {
                for f in &track.frames {
                    bounds::check_tracked_frame(f)
                        .map_err(|m| format!("clip {c:?}: tracked frame {}: {m}", f.frame))?;
                }
            }
            if let Some(entries) = clip.fit_cache.unsaved() {
                bounds::check_cache_entries(&entries).map_err(|m| format!("clip {c:?}: {m}"))?;
            }
            for (frame, pts) in &clip.corrections.points {
                if let Some((i, _)) =
                    pts.iter().find(|(i, p)| **i >= crate::landmarks::N_LANDMARKS || bad_point(p))
                {
                    return Err(format!(
                        "clip {c:?}: correction of frame {frame} point index {i} is out of range or not finite"
                    ));
                }
            }
        }
        bounds::check_values(self)
    }

    // -- clips ------------------------------------------------------------------------

    /// Adds a clip, returning its index.
    ///
    /// # Errors
    /// `Edit` when a clip of that name exists.
    pub fn add_clip(&mut self, clip: Clip) -> Result<usize, SessionError> {
        if self.clip_index(&clip.name).is_some() {
            return Err(SessionError::Edit {
                clip: clip.name,
                message: "a clip of this name exists".into(),
            });
        }
        let bytes = clip.tracked_data().unsaved().map_or(0, |t| t.approx_bytes());
        self.forget_derived();
        self.clips.push(clip);
        self.note_new_data(bytes)?;
        Ok(self.clips.len() - 1)
    }

    /// Replaces clip `clip`'s tracked landmarks (the tracker, an import).
    ///
    /// # Errors
    /// `NoClip`; as [`Session::write_data_early`]'s writing of data.
    pub fn set_tracked(&mut self, clip: usize, track: Track) -> Result<(), SessionError> {
        let bytes = track.approx_bytes();
        self.clip_mut(clip)?.set_tracked(track);
        self.note_new_data(bytes)
    }

    /// Index of the clip named `name`.
    pub fn clip_index(&self, name: &str) -> Option<usize> {
        self.clips.iter().position(|c| c.name == name)
    }

    /// Clip `index`.
    ///
    /// # Errors
    /// `NoClip` when out of range.
    pub fn clip(&self, index: usize) -> Result<&Clip, SessionError> {
        self.clips.get(index).ok_or(SessionError::NoClip { index, count: self.clips.len() })
    }

    /// Clip `index` to change: what is derived from the clips is made again on next use.
    ///
    /// # Errors
    /// `NoClip` when out of range.
    pub(crate) fn clip_mut(&mut self, index: usize) -> Result<&mut Clip, SessionError> {
        self.forget_derived();
        let count = self.clips.len();
        self.clips.get_mut(index).ok_or(SessionError::NoClip { index, count })
    }

    /// Forgets what was derived from the clips (a clip's landmarks or corrections changed).
    pub(crate) fn forget_derived(&mut self) {
        self.contact_precision.forget();
    }

    /// How precisely the tracker places the inner-lip gap where the lips touch (px per
    /// coordinate), over the meeting frames of every clip (`landmarks::closure::
    /// contact_precision`); `None` when they show none. Clips whose track cannot be read are
    /// left out (their own fits report it). Made once and kept until a clip changes.
    pub fn lip_contact_precision(&self) -> Option<f64> {
        // One track in memory at a time: a corpus is read clip by clip.
        *self.contact_precision.get_or_init(|| {
            crate::landmarks::closure::contact_precision(
                (0..self.clips.len()).filter_map(|c| self.effective_track(c).ok()),
            )
        })
    }

    /// Opens the front view's frames of clip `index` (fps and size from the session).
    ///
    /// # Errors
    /// `FrameError` from `FrameSource::open`; an unknown clip is reported as `Invalid`.
    pub fn open_frames(&self, index: usize, cache_mb: usize) -> Result<FrameSource, FrameError> {
        let clip = self.clips.get(index).ok_or_else(|| FrameError::Invalid {
            path: self.base_dir.clone(),
            message: format!("no clip {index}"),
        })?;
        open_view(&clip.front, cache_mb)
    }

    /// Opens the side view of clip `index`, if it has one.
    ///
    /// # Errors
    /// As `open_frames`.
    pub fn open_side_frames(
        &self,
        index: usize,
        cache_mb: usize,
    ) -> Result<Option<FrameSource>, FrameError> {
        match self.clips.get(index).and_then(|c| c.side.as_ref()) {
            Some(v) => open_view(v, cache_mb).map(Some),
            None => Ok(None),
        }
    }

    // -- landmarks and corrections ---------------------------------------------------------

    /// The landmarks a fit should use for `frame` of clip `clip`: the tracked ones with the
    /// corrections applied. `None` for a frame with no landmarks.
    ///
    /// # Errors
    /// `NoClip`; the clip's track file cannot be read.
    pub fn effective_frame(
        &self,
        clip: usize,
        frame: usize,
    ) -> Result<Option<FrameLandmarks>, SessionError> {
        let c = self.clip(clip)?;
        Ok(c.corrections.effective_frame(&*c.tracked()?, frame))
    }

    /// The whole clip's effective landmarks.
    ///
    /// # Errors
    /// `NoClip`; the clip's track file cannot be read.
    pub fn effective_track(&self, clip: usize) -> Result<Track, SessionError> {
        let c = self.clip(clip)?;
        Ok(c.corrections.effective_track(&*c.tracked()?))
    }

    /// The landmarks a fit under `settings` is made from: the effective track with the inner
    /// lips closed on sealed frames when `settings.closure` asks for it (`landmarks::closure`).
    /// A clip whose sealed mode cannot be estimated is fitted as tracked; the measures report
    /// why (`workflow::utterance_of_clip`).
    ///
    /// # Errors
    /// `NoClip`; the clip's track file cannot be read.
    pub fn fit_input_track(
        &self,
        clip: usize,
        settings: &FitSettings,
    ) -> Result<Track, SessionError> {
        let c = self.clip(clip)?;
        Ok(self.fit_input_of(c.corrections.effective_track(&*c.tracked()?), settings))
    }

    /// `track`, a clip's effective landmarks, as a fit under `settings` takes it (see
    /// [`Session::fit_input_track`]): sealed lips carry the session's contact precision
    /// ([`Session::lip_contact_precision`]).
    fn fit_input_of(&self, track: Track, settings: &FitSettings) -> Track {
        let pooled = match settings.closure {
            crate::landmarks::closure::Closure::Seal => self.lip_contact_precision(),
            crate::landmarks::closure::Closure::Off => None,
        };
        crate::landmarks::closure::with_sealed_lips(track, settings.closure, pooled)
    }

    /// Records a corrected (or interpolated) point; the tracked value stays as it was.
    ///
    /// # Errors
    /// `NoClip`; `Edit` for a point index ≥ 68 or non-finite coordinates.
    pub fn set_correction(
        &mut self,
        clip: usize,
        frame: usize,
        point: usize,
        p: LandmarkPoint,
    ) -> Result<(), SessionError> {
        let c = self.clip_mut(clip)?;
        c.corrections
            .set(frame, point, p)
            .map_err(|message| SessionError::Edit { clip: c.name.clone(), message })
    }

    /// Removes a correction, returning it; the tracked point shows again.
    ///
    /// # Errors
    /// `NoClip`.
    pub fn clear_correction(
        &mut self,
        clip: usize,
        frame: usize,
        point: usize,
    ) -> Result<Option<LandmarkPoint>, SessionError> {
        Ok(self.clip_mut(clip)?.corrections.clear(frame, point))
    }

    /// The corrections layer of a clip.
    ///
    /// # Errors
    /// `NoClip`.
    pub fn corrections_of(&self, clip: usize) -> Result<&Corrections, SessionError> {
        Ok(&self.clip(clip)?.corrections)
    }

    /// Marks `frame` reviewed or not.
    ///
    /// # Errors
    /// `NoClip`.
    pub fn set_reviewed(
        &mut self,
        clip: usize,
        frame: usize,
        reviewed: bool,
    ) -> Result<(), SessionError> {
        self.clip_mut(clip)?.corrections.set_reviewed(frame, reviewed);
        Ok(())
    }

    /// Sets the user's upper-lip point of side-view frame `frame` (image px).
    ///
    /// # Errors
    /// `NoClip`; `Edit` for a clip without a side view or non-finite coordinates.
    pub fn set_profile_correction(
        &mut self,
        clip: usize,
        frame: usize,
        point: crate::math::Point2,
    ) -> Result<(), SessionError> {
        let c = self.clip_mut(clip)?;
        let fail =
            |message: &str| SessionError::Edit { clip: c.name.clone(), message: message.into() };
        if c.side.is_none() {
            return Err(fail("no side view to correct"));
        }
        if !(point.x.is_finite() && point.y.is_finite()) {
            return Err(fail("side-view point is not finite"));
        }
        // Pixel centres are at integers: the image spans -0.5 .. size - 0.5.
        if let Some([w, h]) = c.side.as_ref().and_then(|s| s.size) {
            let inside = |v: f64, n: u32| v >= -0.5 && v <= f64::from(n) - 0.5;
            if !(inside(point.x, w) && inside(point.y, h)) {
                return Err(fail(&format!(
                    "side-view point ({}, {}) is outside the {w}×{h} side frame",
                    point.x, point.y
                )));
            }
        }
        c.profile_corrections.insert(frame, point);
        Ok(())
    }

    /// Drops the user's upper-lip point of side-view frame `frame`, returning it.
    ///
    /// # Errors
    /// `NoClip`.
    pub fn clear_profile_correction(
        &mut self,
        clip: usize,
        frame: usize,
    ) -> Result<Option<crate::math::Point2>, SessionError> {
        Ok(self.clip_mut(clip)?.profile_corrections.remove(&frame))
    }

    // -- fit cache ------------------------------------------------------------------------

    /// Hash of what every frame's fit shares: the head mesh, model, blendshapes and
    /// landmark map references (paths relative to the session folder, so moving the project
    /// keeps the cache valid). Editing a model file in place is not detected.
    pub fn context_hash(&self) -> String {
        let mut h = cache::Fnv64::default();
        let mut path = |tag: &str, p: Option<&Path>| {
            h.str(tag);
            if let Some(p) = p {
                h.str(&store::relativize(p, &self.base_dir).to_string_lossy());
            }
        };
        path("mesh", self.head_mesh.as_deref());
        path("model", self.model.as_ref().map(|m| m.path.as_path()));
        path("blendshapes", self.model.as_ref().and_then(|m| m.blendshapes.as_deref()));
        path("map", self.landmark_map.file.as_deref());
        h.str("inline");
        if let Some(m) = &self.landmark_map.inline {
            for (k, v) in m {
                h.u64(*k as u64).u64(*v as u64);
            }
        }
        h.hex()
    }

    /// Caches `fits` of clip `clip` made with `settings` from the current effective
    /// landmarks, merging with fresh fits already cached for those settings. Non-finite
    /// numbers are zeroed and the frame marked failed (JSON cannot hold them).
    ///
    /// # Errors
    /// `NoClip`; `Edit` when a fit names a frame without landmarks; the clip's data files
    /// cannot be read.
    pub fn store_fits(
        &mut self,
        clip: usize,
        settings: &FitSettings,
        fits: Vec<FrameFit>,
    ) -> Result<(), SessionError> {
        let c = self.clip(clip)?;
        let context = self.context_hash();
        let input = self.fit_input_of(c.corrections.effective_track(&*c.tracked()?), settings);
        let mut new = Vec::with_capacity(fits.len());
        for fit in fits {
            let Some(frame) = input.get(fit.frame) else {
                return Err(SessionError::Edit {
                    clip: c.name.clone(),
                    message: format!("fit of frame {} which has no landmarks", fit.frame),
                });
            };
            new.push(CachedFrame {
                input: cache::frame_input_hash(frame, settings.set),
                fit: cache::storable_fit(fit),
            });
        }
        let clip_input = settings.clip.then(|| cache::clip_input_hash(&input.frames, settings.set));
        let mut entries: Vec<FitCacheEntry> = c.fit_cache.get()?.as_ref().clone();
        let mut entry = match entries.iter().position(|e| &e.settings == settings) {
            Some(i) => entries.remove(i),
            None => FitCacheEntry {
                settings: settings.clone(),
                context: context.clone(),
                clip_input: None,
                frames: Vec::new(),
            },
        };
        if entry.context != context || entry.clip_input != clip_input {
            // Made from other inputs: none of the old frames can be reused.
            entry.frames.clear();
        }
        entry.context = context;
        entry.clip_input = clip_input;
        entry.merge(new);
        entries.push(entry); // most recently stored last
        let excess = entries.len().saturating_sub(cache::MAX_CACHED_SETTINGS_PER_CLIP);
        entries.drain(..excess);
        let bytes = clip_data::ClipDataKind::approx_bytes(&entries);
        self.clip_mut(clip)?.fit_cache = clip_data::ClipData::new(entries);
        self.note_new_data(bytes)
    }

    /// Whether any clip has cached fits.
    pub fn has_cached_fits(&self) -> bool {
        self.clips.iter().any(|c| !c.fit_cache.is_empty())
    }

    /// Drops every clip's cached fits (their model or map changed).
    pub fn clear_fit_cache(&mut self) {
        for c in &mut self.clips {
            c.fit_cache = clip_data::ClipData::default();
        }
    }

    /// Which cached fits of clip `clip` under `settings` are still valid for the current
    /// landmarks, model and map, and which frames with landmarks lack one.
    fn cache_state(&self, clip: usize, settings: &FitSettings) -> Result<CacheState, SessionError> {
        let c = self.clip(clip)?;
        let tracked = c.tracked()?;
        let frames = c.corrections.frames_with_landmarks(&tracked);
        let entries = c.fit_cache.get()?;
        let Some(index) = entries.iter().position(|e| &e.settings == settings) else {
            return Ok(CacheState {
                entries,
                index: None,
                fresh: Default::default(),
                stale: frames,
            });
        };
        let entry = &entries[index];
        let input = self.fit_input_of(c.corrections.effective_track(&tracked), settings);
        let valid = entry.context == self.context_hash()
            && (!settings.clip
                || entry.clip_input.as_deref()
                    == Some(cache::clip_input_hash(&input.frames, settings.set).as_str()));
        let (fresh, stale): (Vec<usize>, Vec<usize>) = frames.into_iter().partition(|&f| {
            valid
                && entry.frame(f).zip(input.get(f)).is_some_and(|(cached, now)| {
                    cached.input == cache::frame_input_hash(now, settings.set)
                })
        });
        Ok(CacheState { entries, index: Some(index), fresh: fresh.into_iter().collect(), stale })
    }

    /// The cached fit of `frame`, if it is still valid for the current landmarks, model and
    /// map.
    ///
    /// # Errors
    /// `NoClip`; the clip's data files cannot be read.
    pub fn cached_fit(
        &self,
        clip: usize,
        settings: &FitSettings,
        frame: usize,
    ) -> Result<Option<FrameFit>, SessionError> {
        let state = self.cache_state(clip, settings)?;
        Ok(state
            .index
            .filter(|_| state.fresh.contains(&frame))
            .and_then(|i| state.entries[i].frame(frame))
            .map(|c| c.fit.clone()))
    }

    /// Every still-valid cached fit of the clip, ascending by frame.
    ///
    /// # Errors
    /// `NoClip`; the clip's data files cannot be read.
    pub fn cached_fits(
        &self,
        clip: usize,
        settings: &FitSettings,
    ) -> Result<Vec<FrameFit>, SessionError> {
        let state = self.cache_state(clip, settings)?;
        let Some(i) = state.index else { return Ok(Vec::new()) };
        Ok(state.entries[i]
            .frames
            .iter()
            .filter(|c| state.fresh.contains(&c.fit.frame))
            .map(|c| c.fit.clone())
            .collect())
    }

    /// Frames of clip `clip` that need fitting under the session's `fit_settings`: frames
    /// with landmarks and no valid cached fit.
    ///
    /// # Errors
    /// `NoClip`; the clip's data files cannot be read.
    pub fn stale_frames(&self, clip: usize) -> Result<Vec<usize>, SessionError> {
        self.stale_frames_with(clip, &self.fit_settings)
    }

    /// As `stale_frames`, for any settings.
    ///
    /// # Errors
    /// As [`Session::stale_frames`].
    pub fn stale_frames_with(
        &self,
        clip: usize,
        settings: &FitSettings,
    ) -> Result<Vec<usize>, SessionError> {
        Ok(self.cache_state(clip, settings)?.stale)
    }
}

/// A clip's cache under some settings: its entries, the one for the settings, the frames
/// whose cached fit is still valid and the frames with landmarks that lack one.
struct CacheState {
    entries: std::sync::Arc<Vec<FitCacheEntry>>,
    index: Option<usize>,
    fresh: std::collections::BTreeSet<usize>,
    stale: Vec<usize>,
}

/// Opens one view's frames with the fps and size the session knows.
///
/// # Errors
/// `FrameError` from `FrameSource::open`.
pub fn open_view(view: &View, cache_mb: usize) -> Result<FrameSource, FrameError> {
    let opts =
        FrameOptions { fps: Some(view.fps), size: view.size, cache_mb, ..FrameOptions::default() };
    match &view.source {
        FramesRef::Images { dir } => FrameSource::open_folder(dir, &opts),
        FramesRef::Video { file } => FrameSource::open_video(file, &opts),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn saving_through_a_symlink_writes_its_target_and_keeps_the_link() {
        let dir = tempfile::tempdir().unwrap();
        let real_dir = dir.path().join("real");
        std::fs::create_dir(&real_dir).unwrap();
        let real = real_dir.join("s.lipmap.json");
        let mut s = Session::new(&real);
        s.save(&real).unwrap();
        let link = dir.path().join("link.lipmap.json");
        std::os::unix::fs::symlink("real/s.lipmap.json", &link).unwrap();
        s.name = "renamed".into();
        s.save(&link).unwrap();
        assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
        assert_eq!(Session::load(&real).unwrap().name, "renamed");
    }

    /// A frame whose reference length is 10 px and whose inner lips are `gap` px apart
    /// (vertically at the midline, `tilt` px sideways at the other two pairs).
    fn lips(f: usize, gap: f64, tilt: f64) -> FrameLandmarks {
        let mut pts = vec![LandmarkPoint::tracked(0.0, 0.0); 68];
        pts[39] = LandmarkPoint::tracked(-5.0, 0.0);
        pts[42] = LandmarkPoint::tracked(5.0, 0.0);
        pts[30] = LandmarkPoint::tracked(0.0, 10.0);
        for (k, (u, l)) in crate::landmarks::closure::INNER_LIP_PAIRS.into_iter().enumerate() {
            let x = k as f64 - 1.0;
            pts[u] = LandmarkPoint::tracked(x, 20.0);
            pts[l] = LandmarkPoint::tracked(x + tilt, 20.0 + gap);
        }
        FrameLandmarks::new(f, pts)
    }

    #[test]
    fn the_contact_precision_is_pooled_over_the_clips_and_made_again_after_an_edit() {
        use crate::landmarks::closure::contact_precision;
        let dir = tempfile::tempdir().unwrap();
        let mut s = Session::new(&dir.path().join("s.lipmap.json"));
        // Three clips, three meeting frames each (gaps 0.2–1.2 px under a 1.7 px limit) and
        // open frames spread evenly up to 34 px: alone each shows little.
        let mut tracks = Vec::new();
        for c in 0..3 {
            let meet = [0.2 + 0.1 * c as f64, 0.7, 1.2 - 0.1 * c as f64];
            let open = (0..31).map(|k| 3.0 + k as f64 * 31.0 / 30.0);
            let gaps: Vec<f64> = meet.into_iter().chain(open).collect();
            let track =
                Track::new(gaps.iter().enumerate().map(|(f, g)| lips(f, *g, 0.0)).collect());
            tracks.push(track.clone());
            let mut clip = Clip::new(
                format!("c{c}"),
                View::new(FramesRef::Images { dir: dir.path().into() }, 25.0),
            );
            clip.set_tracked(track);
            s.add_clip(clip).unwrap();
        }
        let pooled = s.lip_contact_precision().unwrap();
        assert_eq!(Some(pooled), contact_precision(&tracks));
        let settings = FitSettings::default();
        let input = s.fit_input_track(1, &settings).unwrap();
        let carried: Vec<usize> = input
            .frames
            .iter()
            .filter(|f| f.lip_contact_px == Some(pooled))
            .map(|f| f.frame)
            .collect();
        assert_eq!(carried, vec![0, 1, 2]);
        let off = FitSettings { closure: crate::landmarks::closure::Closure::Off, ..settings };
        assert!(
            s.fit_input_track(1, &off).unwrap().frames.iter().all(|f| f.lip_contact_px.is_none())
        );
        // A correction moving a meeting frame's lower lip 1.5 px sideways changes what the
        // clips show; the session says so without being reloaded.
        let moved = lips(0, 0.2, 1.5);
        for (_, l) in crate::landmarks::closure::INNER_LIP_PAIRS {
            s.set_correction(0, 0, l, moved.points[l]).unwrap();
        }
        tracks[0] = s.effective_track(0).unwrap();
        let again = s.lip_contact_precision();
        assert_eq!(again, contact_precision(&tracks));
        assert_ne!(again, Some(pooled));
    }
}
