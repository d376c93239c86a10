//! Opening a session, the one way every front and use case does it:
//!
//! - [`open_for_edit`]: locked, loaded, and the edits an editor recorded in the journal but
//!   never saved (it crashed) restored, so a change made now is made on top of them; a save
//!   through [`EditSession::save`] writes them into the file and retires the journal.
//! - [`read_session`]: no lock, nothing saved; the journal beside the session (a crashed
//!   editor's, or the one an editor still open keeps) applied in memory, with a one-line
//!   notice saying how many edits it holds. A reader thus sees what the editor last showed,
//!   less at most the edit it was writing.
//! - [`open_for_read`]: for use cases that read but would cache new fits (`eval`,
//!   `export`, SAQP, speech): [`open_for_edit`] when the lock is free, so the fits are kept;
//!   [`read_session`] beside a live editor or in a read-only folder, saying so.
//!
//! Why a reader applies a live editor's journal rather than refusing to run: `eval` and
//! `export` beside an open TUI are a documented way of working, and the journal is made for
//! being read at any moment (each line is one whole edit layer of a clip, on disk before the
//! next edit; a torn last line is skipped). A save racing the read is caught by reading the
//! session again when its file changed underneath.

use super::error::{Context, Error, Result, Warning, error_chain};
use crate::session::journal::{self, Journal, Replayed};
use crate::session::{LockInfo, Session, SessionError, SessionLock};
use std::path::{Path, PathBuf};

/// One edit layer as an editor records it (what [`EditSession::record`] takes).
pub use crate::session::journal::JournalEntry;
/// For a front about to exit without unwinding: frees the session's lock if it is this
/// process's.
pub use crate::session::store::release_lock_if_ours;

/// `NAME` -> sessions/NAME.lipmap.json; anything with a slash or a .json ending is a path.
pub fn session_path(s: &str) -> PathBuf {
    if s.contains('/') || s.ends_with(".json") {
        PathBuf::from(s)
    } else {
        crate::session::default_path(s)
    }
}

/// A session opened for a use case that changes it: locked, loaded, the journal's edits
/// restored.
pub struct EditSession {
    pub path: PathBuf,
    pub lock: SessionLock,
    pub session: Session,
    /// The session's journal: an editor appends its edits to it; [`EditSession::save`]
    /// removes it once the file holds them.
    pub journal: Journal,
    /// What the journal gave: the edits restored (in memory until saved).
    pub restored: Replayed,
    /// What opening noticed (edits restored, a journal set aside), one line each.
    pub notices: Vec<Warning>,
}

impl EditSession {
    /// Saves the session, then removes the journal: the file now holds its edits.
    ///
    /// # Errors
    /// The save's error; the journal exists and cannot be removed.
    pub fn save(&mut self) -> Result<()> {
        self.session.save(&self.path)?;
        self.retire_journal()
    }

    /// Appends an editor's edit layer to the journal, on disk when this returns.
    ///
    /// # Errors
    /// The journal cannot be written.
    pub fn record(&mut self, entry: &journal::JournalEntry) -> Result<()> {
        Ok(self.journal.record(entry)?)
    }

    /// Removes the journal: call when the session file holds every edit.
    ///
    /// # Errors
    /// The journal exists and cannot be removed.
    pub fn retire_journal(&mut self) -> Result<()> {
        if self.journal.is_present() {
            self.journal.clear()?;
        }
        Ok(())
    }
}

/// Opens the session `s` names for editing ([`session_path`]); see [`open_for_edit_at`].
///
/// # Errors
/// As [`open_for_edit_at`].
pub fn open_for_edit(s: &str) -> Result<EditSession> {
    open_for_edit_at(&session_path(s))
}

/// Opens the session at `path` for editing: lock first, then load, then replay the journal
/// an editor left (it stopped without saving). A journal that cannot be replayed is set
/// aside (`….journal.bad`, kept for the user) with a warning, so editing can go on.
///
/// # Errors
/// The lock is held ([`SessionError::Locked`]); unreadable session or lock file.
pub fn open_for_edit_at(path: &Path) -> Result<EditSession> {
    let lock = SessionLock::acquire(path)?;
    let mut session = Session::load(path)?;
    // This process will save it: data made on the way (fits of a corpus) need not wait in
    // memory for the save.
    session.write_data_early(path);
    let mut notices = lost_fit_cache_notices(&session, path);
    let restored = match journal::replay(&mut session, path) {
        Ok(r) => r,
        Err(e) => {
            let aside = journal::set_aside(path);
            notices.push(Warning(format!(
                "lipmap: warning: journal not replayed: {e} (moved to {})",
                aside.display()
            )));
            Replayed::default()
        }
    };
    let journal = Journal::new(path);
    if !restored.is_empty() {
        notices.push(Warning(format!(
            "lipmap: note: restored the edits of an editor that stopped without saving ({} \
             from {})",
            edits(restored.edits),
            journal.path().display()
        )));
    }
    Ok(EditSession { path: path.to_path_buf(), lock, session, journal, restored, notices })
}

/// One warning per clip whose fit cache file was missing when `session` (read from `path`)
/// was loaded: its fits are gone, nothing else, and `lipmap fit` makes them again.
fn lost_fit_cache_notices(session: &Session, path: &Path) -> Vec<Warning> {
    session
        .lost_fit_caches
        .iter()
        .map(|(clip, file)| {
            Warning(format!(
                "lipmap: warning: clip {clip:?}: its cached fits {} are missing; \
                 `lipmap fit {}` fits the clip again",
                file.display(),
                path.display()
            ))
        })
        .collect()
}

fn edits(n: usize) -> String {
    if n == 1 { "1 edit".into() } else { format!("{n} edits") }
}

/// A session opened for a use case that reads it (and, when it holds the lock, may cache
/// new fits in it).
pub struct ReadSession {
    pub path: PathBuf,
    pub session: Session,
    /// Why the session is read the way it is, one line each: read without saving beside
    /// another editor, journal edits applied.
    pub notices: Vec<Warning>,
    /// The lock and journal when this process could take the lock: fits made now are then
    /// saved, with the journal's edits, by [`ReadSession::save_if_locked`].
    editing: Option<(SessionLock, Journal)>,
}

impl ReadSession {
    /// Whether this process holds the session's lock (and so may save).
    pub fn is_locked(&self) -> bool {
        self.editing.is_some()
    }

    /// Saves the session when this process holds its lock, retiring the journal whose edits
    /// it now holds; a read-only run saves nothing.
    ///
    /// # Errors
    /// The save's error.
    pub fn save_if_locked(&mut self) -> Result<()> {
        if let Some((_, journal)) = &mut self.editing {
            self.session.save(&self.path)?;
            if journal.is_present() {
                journal.clear()?;
            }
        }
        Ok(())
    }
}

impl From<EditSession> for ReadSession {
    fn from(e: EditSession) -> Self {
        Self {
            path: e.path,
            session: e.session,
            notices: e.notices,
            editing: Some((e.lock, e.journal)),
        }
    }
}

/// Reads the session at `path` without locking it: the session file with its journal (a
/// crashed editor's, or a live editor's) applied in memory, and a notice naming how many
/// edits the journal holds. A journal that cannot be applied is left alone with a warning.
/// Nothing is written.
///
/// # Errors
/// An unreadable or invalid session file.
pub fn read_session(path: &Path) -> Result<ReadSession> {
    // An editor saving between the two reads would pair the old file with no journal (it is
    // removed after the save): read again while the file changes underneath.
    let mut attempts = 0;
    let (session, replayed) = loop {
        attempts += 1;
        let before = file_identity(path);
        let mut session = Session::load(path)?;
        let replayed = journal::replay(&mut session, path);
        if attempts == 3 || file_identity(path) == before {
            break (session, replayed);
        }
    };
    let journal = journal::journal_path(&crate::session::absolute(path));
    let mut notices = lost_fit_cache_notices(&session, path);
    match replayed {
        Ok(r) if r.is_empty() => {}
        Ok(r) => notices.push(Warning(format!(
            "lipmap: note: {} holds {} not saved in the session yet; read with them",
            journal.display(),
            edits(r.edits)
        ))),
        Err(e) => notices
            .push(Warning(format!("lipmap: warning: journal not applied: {}", error_chain(&e)))),
    }
    Ok(ReadSession { path: path.to_path_buf(), session, notices, editing: None })
}

/// What tells one version of a file from the next (an atomic save renames a new file in).
fn file_identity(path: &Path) -> Option<(std::time::SystemTime, u64, u64)> {
    let m = std::fs::metadata(path).ok()?;
    #[cfg(unix)]
    let inode = std::os::unix::fs::MetadataExt::ino(&m);
    #[cfg(not(unix))]
    let inode = 0;
    Some((m.modified().ok()?, m.len(), inode))
}

/// Opens the session `s` names for a use case that reads it but would cache new fits; see
/// [`open_for_read_at`].
///
/// # Errors
/// As [`open_for_read_at`].
pub fn open_for_read(s: &str) -> Result<ReadSession> {
    open_for_read_at(&session_path(s))
}

/// Opens the session at `path` for a use case that reads it but would cache new fits
/// (`eval`, `export`): locked like [`open_for_edit_at`] (journal restored) when it can be;
/// when another editor (the TUI) holds the lock or the folder is read-only, read as
/// [`read_session`] does, with a notice saying nothing will be saved. The caller fits what
/// the cache lacks in memory and saves through [`ReadSession::save_if_locked`].
///
/// # Errors
/// Unreadable session or lock file.
pub fn open_for_read_at(path: &Path) -> Result<ReadSession> {
    let read_only = |why: &str| {
        Warning(format!(
            "lipmap: note: {} {why}; reading it without saving (fits missing from its cache \
             are computed now and not stored)",
            path.display()
        ))
    };
    // No lock file is created where nothing will be written.
    let why = if is_read_only(path) {
        read_only("is read-only")
    } else {
        match open_for_edit_at(path) {
            Ok(e) => return Ok(e.into()),
            Err(Error::Session(SessionError::Locked { holder, .. })) => {
                Warning(read_only_notice(path, &holder))
            }
            Err(Error::Session(SessionError::Io { source, .. }))
                if matches!(
                    source.kind(),
                    std::io::ErrorKind::PermissionDenied | std::io::ErrorKind::ReadOnlyFilesystem
                ) =>
            {
                read_only("cannot be locked (its folder is not writable)")
            }
            Err(e) => return Err(e),
        }
    };
    let mut read = read_session(path)?;
    read.notices.insert(0, why);
    Ok(read)
}

/// Whether the session file or its folder is marked read-only (no write bit), so a save
/// could not replace it: reading then takes no lock. Mode bits are looked at rather than
/// trying a write, which would create the very file this avoids.
fn is_read_only(path: &Path) -> bool {
    let abs = crate::session::absolute(path);
    let ro = |p: &Path| std::fs::metadata(p).is_ok_and(|m| m.permissions().readonly());
    ro(&abs) || abs.parent().is_some_and(ro)
}

/// The notice of a read-only run beside another editor.
pub fn read_only_notice(path: &Path, holder: &LockInfo) -> String {
    format!(
        "lipmap: note: {} is open in another editor ({holder}); reading it without saving \
         (fits missing from its cache are computed now and not stored)",
        path.display()
    )
}

/// The index of the clip called `name`: the one clip lookup by name of both fronts.
///
/// # Errors
/// [`Error::UnknownClip`], listing the clips the session has.
pub fn find_clip(session: &Session, name: &str) -> Result<usize> {
    session.clip_index(name).ok_or_else(|| Error::UnknownClip {
        name: name.to_string(),
        known: session.clips.iter().map(|c| c.name.clone()).collect(),
    })
}

/// The clips a use case runs on: the one called `name`, or all of them.
///
/// # Errors
/// As [`find_clip`].
pub fn select_clips(session: &Session, name: Option<&str>) -> Result<Vec<usize>> {
    match name {
        Some(n) => Ok(vec![find_clip(session, n)?]),
        None => Ok((0..session.clips.len()).collect()),
    }
}

/// The clip called `name`, or the first.
///
/// # Errors
/// As [`find_clip`]; [`Error::NoClips`] for a session without clips.
pub fn clip_or_first(session: &Session, name: Option<&str>) -> Result<usize> {
    match name {
        Some(n) => find_clip(session, n),
        None if session.clips.is_empty() => Err(Error::NoClips),
        None => Ok(0),
    }
}

/// Image height (pixels) of a clip's front view: the session's record, else the first frame.
///
/// # Errors
/// Neither the session nor the frames tell the size.
pub fn image_height(session: &Session, clip: usize) -> Result<f64> {
    let c = session.clip(clip)?;
    if let Some([_, h]) = c.front.size {
        return Ok(f64::from(h));
    }
    let frames = session.open_frames(clip, 64).with_context(|| format!("clip `{}`", c.name))?;
    Ok(f64::from(frames.size()[1]))
}

/// Number of frames a clip spans: the last frame with landmarks + 1.
///
/// # Errors
/// Unknown clip.
pub fn clip_length(session: &Session, clip: usize) -> Result<usize> {
    let c = session.clip(clip)?;
    Ok(c.tracked_summary().last_frame.map_or(0, |f| f + 1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::os::unix::fs::PermissionsExt;

    #[test]
    fn a_read_only_session_is_read_without_a_lock_file() {
        let dir = tempfile::tempdir().unwrap();
        let folder = dir.path().join("ro");
        std::fs::create_dir(&folder).unwrap();
        let path = folder.join("s.lipmap.json");
        Session::new(&path).save(&path).unwrap();
        std::fs::set_permissions(&folder, std::fs::Permissions::from_mode(0o555)).unwrap();
        let opened = open_for_read(path.to_str().unwrap());
        // Writable again before asserting, so the temp folder can be removed.
        std::fs::set_permissions(&folder, std::fs::Permissions::from_mode(0o755)).unwrap();
        let mut opened = opened.unwrap();
        assert!(!opened.is_locked());
        assert!(opened.notices.iter().any(|w| w.0.contains("read-only")));
        assert!(!crate::session::store::lock_path(&path).exists(), "a lock file was created");
        opened.save_if_locked().unwrap();
    }

    /// A session of one clip at `dir/s.lipmap.json`, and a journal entry correcting point
    /// 48 of frames `0..n` of it.
    fn session_and_edit(dir: &Path, n: usize) -> (PathBuf, journal::JournalEntry) {
        use crate::landmarks::{FrameLandmarks, LandmarkPoint};
        use crate::session::{Clip, FramesRef, View};
        let path = dir.join("s.lipmap.json");
        let mut s = Session::new(&path);
        let mut clip = Clip::new("a", View::new(FramesRef::Images { dir: dir.join("f") }, 25.0));
        clip.set_tracked(crate::landmarks::Track::new(
            (0..n)
                .map(|f| FrameLandmarks::new(f, vec![LandmarkPoint::tracked(1.0, 1.0); 68]))
                .collect(),
        ));
        s.clips.push(clip);
        s.save(&path).unwrap();
        let mut corrections = crate::session::Corrections::default();
        for f in 0..n {
            corrections.set(f, 48, LandmarkPoint::tracked(5.0, f as f64)).unwrap();
        }
        let entry = journal::JournalEntry {
            clip: "a".into(),
            corrections,
            profile_corrections: Default::default(),
            landmark_map: None,
            map_role: Default::default(),
        };
        (path, entry)
    }

    #[test]
    fn readers_beside_a_live_editor_see_its_journal_and_save_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let (path, entry) = session_and_edit(dir.path(), 3);
        // This process is the live editor: it holds the lock and journals an edit.
        let editor = open_for_edit_at(&path).unwrap();
        let mut j = Journal::new(&path);
        j.record(&entry).unwrap();
        assert!(matches!(
            open_for_edit_at(&path),
            Err(Error::Session(SessionError::Locked { .. }))
        ));
        let mut read = open_for_read_at(&path).unwrap();
        assert!(!read.is_locked());
        assert_eq!(read.session.clips[0].corrections, entry.corrections);
        let notes: Vec<&str> = read.notices.iter().map(|w| w.0.as_str()).collect();
        assert!(notes[0].contains("open in another editor"), "{notes:?}");
        assert!(notes[1].contains("holds 3 edits not saved"), "{notes:?}");
        read.save_if_locked().unwrap();
        assert!(Session::load(&path).unwrap().clips[0].corrections.points.is_empty());
        assert!(j.is_present() && journal::journal_path(&path).exists());
        let read = read_session(&path).unwrap();
        assert_eq!(read.session.clips[0].corrections, entry.corrections);
        drop(editor);
    }

    #[test]
    fn an_editor_after_a_crash_restores_the_journal_and_its_save_retires_it() {
        let dir = tempfile::tempdir().unwrap();
        let (path, entry) = session_and_edit(dir.path(), 2);
        let mut j = Journal::new(&path);
        j.record(&entry).unwrap();
        j.record(&entry).unwrap();
        let mut edit = open_for_edit_at(&path).unwrap();
        assert_eq!(edit.restored, Replayed { edits: 2, clips: 1 });
        assert!(edit.notices[0].0.contains("restored the edits"), "{:?}", edit.notices);
        assert_eq!(edit.session.clips[0].corrections, entry.corrections);
        edit.save().unwrap();
        assert!(!journal::journal_path(&path).exists());
        assert_eq!(Session::load(&path).unwrap().clips[0].corrections, entry.corrections);
    }

    #[test]
    fn a_journal_that_cannot_be_replayed_is_set_aside_by_an_editor_and_left_by_a_reader() {
        let dir = tempfile::tempdir().unwrap();
        let (path, _) = session_and_edit(dir.path(), 1);
        let journal = journal::journal_path(&path);
        std::fs::write(&journal, "not json\n{}\n").unwrap();
        let read = read_session(&path).unwrap();
        assert!(read.notices[0].0.contains("journal not applied"), "{:?}", read.notices);
        assert!(journal.exists());
        let edit = open_for_edit_at(&path).unwrap();
        assert!(edit.notices[0].0.contains("journal not replayed"), "{:?}", edit.notices);
        assert!(!journal.exists() && journal.with_extension("journal.bad").exists());
    }
}
