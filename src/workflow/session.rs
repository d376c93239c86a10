//! Opening a session: for editing (locked), for reading beside another editor (unlocked,
//! nothing saved), saving only what this process holds; and finding its clips by name.

use super::error::{Context, Error, Result, Warning};
use crate::session::{LockInfo, Session, SessionError, SessionLock};
use std::path::{Path, PathBuf};

/// `NAME` -> sessions/NAME.lipmap.json; anything with a slash or a .json ending is a path.
pub fn session_path(s: &str) -> PathBuf {
    if s.contains('/') || s.ends_with(".json") {
        PathBuf::from(s)
    } else {
        crate::session::default_path(s)
    }
}

/// Loads the session at `path`, the error naming it.
///
/// # Errors
/// An unreadable or invalid session file.
pub fn load_session(path: &Path) -> Result<Session> {
    Session::load(path).with_context(|| path.display().to_string())
}

/// A session opened for a use case that changes it: locked first, then loaded.
pub struct EditSession {
    pub path: PathBuf,
    pub lock: SessionLock,
    pub session: Session,
}

/// Opens the session `s` names for editing: lock first, then load.
///
/// # Errors
/// The lock is held ([`SessionError::Locked`]); unreadable session or lock file.
pub fn open_for_edit(s: &str) -> Result<EditSession> {
    let path = session_path(s);
    let lock = SessionLock::acquire(&path)?;
    let session = load_session(&path)?;
    Ok(EditSession { path, lock, session })
}

/// A session opened for a use case that only reads it but would cache new fits.
pub struct ReadSession {
    pub path: PathBuf,
    /// `None` when another editor holds the lock: fits are then made in memory only.
    pub lock: Option<SessionLock>,
    pub session: Session,
    /// Why the session is read without saving, when it is.
    pub notice: Option<Warning>,
}

impl ReadSession {
    /// Saves the session when this process holds its lock; a read-only run saves nothing.
    ///
    /// # Errors
    /// The save's error.
    pub fn save_if_locked(&self) -> Result<()> {
        if self.lock.is_some() {
            self.session.save(&self.path)?;
        }
        Ok(())
    }
}

/// Opens the session `s` names for a use case that reads it but would cache new fits
/// (`eval`, `export`): locked like [`open_for_edit`] when it can be; when another editor
/// (the TUI) holds the lock, loaded without it, with a notice saying so. The caller then fits
/// what the cache lacks in memory and saves through [`ReadSession::save_if_locked`].
///
/// # Errors
/// Unreadable session or lock file.
pub fn open_for_read(s: &str) -> Result<ReadSession> {
    let path = session_path(s);
    let read_only = |why: &str| {
        Warning(format!(
            "lipmap: note: {} {why}; reading it without saving (fits missing from its cache \
             are computed now and not stored)",
            path.display()
        ))
    };
    if is_read_only(&path) {
        // No lock file is created where nothing will be written.
        let session = load_session(&path)?;
        let notice = Some(read_only("is read-only"));
        return Ok(ReadSession { path, lock: None, session, notice });
    }
    let (lock, notice) = match SessionLock::acquire(&path) {
        Ok(lock) => (Some(lock), None),
        Err(SessionError::Locked { holder, .. }) => {
            (None, Some(Warning(read_only_notice(&path, &holder))))
        }
        Err(SessionError::Io { source, .. })
            if matches!(
                source.kind(),
                std::io::ErrorKind::PermissionDenied | std::io::ErrorKind::ReadOnlyFilesystem
            ) =>
        {
            (None, Some(read_only("cannot be locked (its folder is not writable)")))
        }
        Err(e) => return Err(e.into()),
    };
    let session = load_session(&path)?;
    Ok(ReadSession { path, lock, session, notice })
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
    Ok(c.tracked.frames.last().map_or(0, |f| f.frame + 1))
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
        let opened = opened.unwrap();
        assert!(opened.lock.is_none());
        assert!(opened.notice.as_ref().is_some_and(|w| w.0.contains("read-only")));
        assert!(!crate::session::store::lock_path(&path).exists(), "a lock file was created");
        opened.save_if_locked().unwrap();
    }
}
