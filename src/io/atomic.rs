//! Atomic file output: every file lipmap writes goes through here, so a crash, a full disk or a
//! failing encoder never leaves a truncated file where a good one (or none) was.
//!
//! Start with [`write_atomic`] (a closure writes the contents) or [`write_atomic_bytes`]. For
//! callers that must act between writing and replacing (the session store rotates its backups
//! there), [`AtomicFile`] exposes the two steps.
//!
//! The contents go to `.NAME.tmp.PID.N` in the target's folder (same file system, so the rename
//! is atomic), are fsynced, and the temp file is renamed over the target; then the folder is
//! fsynced so the rename itself survives a power cut. Renaming replaces a symlink at the target,
//! never the file it points to, so an output can never be redirected through a planted link.

use std::ffi::OsString;
use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Distinguishes temp files of one process (threads writing the same target at once).
static TEMP_COUNTER: AtomicU64 = AtomicU64::new(0);

/// A file being written to a temp name beside its target; [`AtomicFile::commit`] puts it in
/// place. Dropped without a commit, it removes the temp file and leaves the target untouched.
pub struct AtomicFile {
    target: PathBuf,
    temp: PathBuf,
    writer: Option<BufWriter<File>>,
}

impl AtomicFile {
    /// Opens a fresh temp file beside `target` (the target's folder must exist).
    ///
    /// # Errors
    /// The I/O error creating the temp file (folder missing, read-only, no space).
    pub fn create(target: &Path) -> io::Result<Self> {
        let dir = parent_dir(target);
        let name = target
            .file_name()
            .ok_or_else(|| io::Error::new(io::ErrorKind::InvalidInput, "not a file name"))?;
        let mut temp_name = OsString::from(".");
        temp_name.push(name);
        temp_name.push(format!(
            ".tmp.{}.{}",
            std::process::id(),
            TEMP_COUNTER.fetch_add(1, Ordering::Relaxed)
        ));
        let temp = dir.join(temp_name);
        let file = OpenOptions::new().write(true).create_new(true).open(&temp)?;
        // Replacing a file keeps its permissions (a user who made an output read-only for the
        // group does not see it widened by the next run).
        if let Ok(meta) = fs::symlink_metadata(target)
            && meta.is_file()
        {
            let _ = file.set_permissions(meta.permissions());
        }
        Ok(Self { target: target.to_path_buf(), temp, writer: Some(BufWriter::new(file)) })
    }

    /// The path the file will have once committed.
    pub fn target(&self) -> &Path {
        &self.target
    }

    /// Flushes and fsyncs the contents, renames the temp file over the target and fsyncs the
    /// folder.
    ///
    /// # Errors
    /// The I/O error of any step; the temp file is removed and the target is untouched
    /// unless the rename itself succeeded.
    pub fn commit(mut self) -> io::Result<()> {
        let writer = self.writer.take().expect("writer present until commit");
        let file = writer.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        drop(file);
        fs::rename(&self.temp, &self.target)?;
        sync_dir(&parent_dir(&self.target))
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.writer.as_mut().expect("writer present until commit").write(buf)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.writer.as_mut().expect("writer present until commit").flush()
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        // After a successful commit the temp name no longer exists; otherwise this is cleanup.
        drop(self.writer.take());
        let _ = fs::remove_file(&self.temp);
    }
}

/// Writes `target` atomically with whatever `write` puts into the buffered writer.
///
/// # Errors
/// The first error of `write`, or the I/O error creating, syncing or renaming the temp file.
/// In every error case the temp file is gone and the old `target` (if any) is intact.
///
/// ```
/// use std::io::Write;
/// let dir = tempfile::tempdir().unwrap();
/// let p = dir.path().join("out.csv");
/// lipmap::io::atomic::write_atomic(&p, |w| writeln!(w, "frame,width_mm")).unwrap();
/// assert_eq!(std::fs::read_to_string(&p).unwrap(), "frame,width_mm\n");
/// ```
pub fn write_atomic<F>(target: &Path, write: F) -> io::Result<()>
where
    F: FnOnce(&mut dyn Write) -> io::Result<()>,
{
    let mut file = AtomicFile::create(target)?;
    write(&mut file)?;
    file.commit()
}

/// Writes `bytes` to `target` atomically; see [`write_atomic`].
///
/// # Errors
/// As [`write_atomic`].
pub fn write_atomic_bytes(target: &Path, bytes: &[u8]) -> io::Result<()> {
    write_atomic(target, |w| w.write_all(bytes))
}

fn parent_dir(target: &Path) -> PathBuf {
    match target.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Makes a rename in `dir` durable; a no-op where folders cannot be opened (Windows).
pub fn sync_dir(dir: &Path) -> io::Result<()> {
    #[cfg(unix)]
    {
        File::open(dir)?.sync_all()
    }
    #[cfg(not(unix))]
    {
        let _ = dir;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn entries(dir: &Path) -> Vec<String> {
        let mut v: Vec<String> = fs::read_dir(dir)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        v.sort();
        v
    }

    #[test]
    fn a_failing_writer_leaves_the_old_file_and_no_temp() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("fit.csv");
        fs::write(&p, "old contents\n").unwrap();
        let err = write_atomic(&p, |w| {
            w.write_all(b"half of the new ")?;
            Err(io::Error::other("encoder failed"))
        })
        .unwrap_err();
        assert_eq!(err.to_string(), "encoder failed");
        assert_eq!(fs::read_to_string(&p).unwrap(), "old contents\n");
        assert_eq!(entries(dir.path()), vec!["fit.csv".to_string()]);
    }

    #[test]
    fn a_failing_writer_with_no_old_file_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("shapes.npy");
        assert!(write_atomic(&p, |_| Err(io::Error::other("disk full"))).is_err());
        assert!(entries(dir.path()).is_empty());
    }

    #[test]
    fn a_dropped_uncommitted_file_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.txt");
        let mut f = AtomicFile::create(&p).unwrap();
        f.write_all(b"x").unwrap();
        drop(f);
        assert!(entries(dir.path()).is_empty());
    }

    #[test]
    fn replaces_contents_and_keeps_permissions() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.txt");
        fs::write(&p, "long old contents\n").unwrap();
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            fs::set_permissions(&p, fs::Permissions::from_mode(0o640)).unwrap();
        }
        write_atomic_bytes(&p, b"new").unwrap();
        assert_eq!(fs::read_to_string(&p).unwrap(), "new");
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt;
            assert_eq!(fs::metadata(&p).unwrap().permissions().mode() & 0o777, 0o640);
        }
        assert_eq!(entries(dir.path()), vec!["a.txt".to_string()]);
    }

    #[cfg(unix)]
    #[test]
    fn a_symlink_at_the_target_is_replaced_not_followed() {
        let dir = tempfile::tempdir().unwrap();
        let outside = dir.path().join("outside.txt");
        fs::write(&outside, "precious").unwrap();
        let out = dir.path().join("out");
        fs::create_dir(&out).unwrap();
        let link = out.join("clip.csv");
        std::os::unix::fs::symlink(&outside, &link).unwrap();
        write_atomic_bytes(&link, b"export").unwrap();
        assert_eq!(fs::read_to_string(&outside).unwrap(), "precious");
        assert!(!fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
        assert_eq!(fs::read_to_string(&link).unwrap(), "export");
    }

    #[test]
    fn a_missing_folder_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        assert!(write_atomic_bytes(&dir.path().join("no/such/x"), b"x").is_err());
    }
}
