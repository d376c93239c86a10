//! Atomic file output: every file lipmap writes goes through here, so a crash, a full disk or a
//! failing encoder never leaves a truncated file where a good one (or none) was.
//!
//! Start with [`write_atomic`] (a closure writes the contents) or [`write_atomic_bytes`]. For
//! writers that need a file handle (`Seek` for zip archives) or must act between writing and
//! replacing (the session store rotates its backups there, [`AtomicFile::commit_after`]),
//! [`AtomicFile`] exposes the two steps.
//!
//! The contents go to `.NAME.tmp.PID.N` ([`temp_path`]) in the target's folder (same file system, so the rename
//! is atomic), are fsynced, and the temp file is renamed over the target; then the folder is
//! fsynced so the rename itself survives a power cut. Renaming replaces a symlink at the target,
//! never the file it points to, so an output can never be redirected through a planted link.
//!
//! A writer killed between creating its temp file and the rename (kill -9, a power cut)
//! leaves the temp file behind: the first atomic write of a later process into that folder
//! removes the temp files of processes that are gone ([`remove_dead_temp_files`]).

use std::collections::BTreeSet;
use std::ffi::OsString;
use std::fs::{self, File, OpenOptions};
use std::io::{self, BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicU64, Ordering};

/// Bytes gathered before a `write`: a mesh file of tens of MB written frame by frame (41 KB
/// a frame for the SFM model) cost the kernel more per call than the copy into this buffer
/// costs (`docs/performance.md`); a small file never touches most of it.
const WRITE_BUFFER: usize = 1 << 20;

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
        if target.file_name().is_none() {
            return Err(io::Error::new(io::ErrorKind::InvalidInput, "not a file name"));
        }
        sweep_once(&parent_dir(target));
        // A crashed process whose pid has been reused may have left our next name behind; a
        // fresh counter value is as good a name.
        let (temp, file) = loop {
            let n = TEMP_COUNTER.fetch_add(1, Ordering::Relaxed);
            let temp = temp_path(target, std::process::id(), n);
            match OpenOptions::new().write(true).create_new(true).open(&temp) {
                Ok(file) => break (temp, file),
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists && n < 1 << 20 => {}
                Err(e) => return Err(e),
            }
        };
        // Replacing a file keeps its permissions (a user who made an output read-only for the
        // group does not see it widened by the next run).
        if let Ok(meta) = fs::symlink_metadata(target)
            && meta.is_file()
        {
            let _ = file.set_permissions(meta.permissions());
        }
        Ok(Self {
            target: target.to_path_buf(),
            temp,
            writer: Some(BufWriter::with_capacity(WRITE_BUFFER, file)),
        })
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
    pub fn commit(self) -> io::Result<()> {
        self.commit_after(|_| Ok(()))
    }

    /// As [`AtomicFile::commit`], calling `before_rename` with the target once the new
    /// contents are safely on disk and before they replace it (the session store rotates
    /// its backups there, so a failed write never shifts them).
    ///
    /// # Errors
    /// As [`AtomicFile::commit`], or `before_rename`'s error (the target is then untouched).
    pub fn commit_after(
        mut self,
        before_rename: impl FnOnce(&Path) -> io::Result<()>,
    ) -> io::Result<()> {
        let writer = self.writer.take().expect("writer present until commit");
        let file = writer.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        drop(file);
        before_rename(&self.target)?;
        fs::rename(&self.temp, &self.target)?;
        sync_dir(&parent_dir(&self.target))
    }
}

impl AtomicFile {
    /// Flushes and fsyncs the contents and hands back the temp file, for a writer that puts
    /// it in place itself (the session lock hard-links it, which refuses an existing name
    /// where a rename would replace it). The temp file is removed when the result is dropped.
    ///
    /// # Errors
    /// The I/O error of the flush or sync; the temp file is removed.
    pub fn stage(mut self) -> io::Result<Staged> {
        let writer = self.writer.take().expect("writer present until commit");
        let file = writer.into_inner().map_err(|e| e.into_error())?;
        file.sync_all()?;
        Ok(Staged { temp: std::mem::take(&mut self.temp) })
    }
}

/// A written and synced temp file ([`AtomicFile::stage`]); removed on drop.
pub struct Staged {
    temp: PathBuf,
}

impl Staged {
    /// The temp file.
    pub fn path(&self) -> &Path {
        &self.temp
    }
}

impl Drop for Staged {
    fn drop(&mut self) {
        let _ = fs::remove_file(&self.temp);
    }
}

impl Write for AtomicFile {
    fn write(&mut self, buf: &[u8]) -> io::Result<usize> {
        self.writer.as_mut().expect("writer present until commit").write(buf)
    }

    fn write_vectored(&mut self, bufs: &[io::IoSlice<'_>]) -> io::Result<usize> {
        self.writer.as_mut().expect("writer present until commit").write_vectored(bufs)
    }

    fn flush(&mut self) -> io::Result<()> {
        self.writer.as_mut().expect("writer present until commit").flush()
    }
}

/// Zip archives (`.npz`) seek back to patch their headers.
impl Seek for AtomicFile {
    fn seek(&mut self, pos: SeekFrom) -> io::Result<u64> {
        self.writer.as_mut().expect("writer present until commit").seek(pos)
    }
}

impl Drop for AtomicFile {
    fn drop(&mut self) {
        // After a successful commit the temp name no longer exists (after `stage` it is the
        // `Staged`'s to remove); otherwise this is cleanup.
        drop(self.writer.take());
        if !self.temp.as_os_str().is_empty() {
            let _ = fs::remove_file(&self.temp);
        }
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

/// The temp name process `pid` writes `target` under for its `n`-th atomic file:
/// `.NAME.tmp.PID.N` beside it (hidden, and recognisable by [`temp_owner`]).
pub fn temp_path(target: &Path, pid: u32, n: u64) -> PathBuf {
    let mut name = OsString::from(".");
    name.push(target.file_name().unwrap_or_default());
    name.push(format!(".tmp.{pid}.{n}"));
    parent_dir(target).join(name)
}

/// The pid of the process that wrote `file_name` as a temp file for `target` (see
/// [`temp_path`]), or `None` when the name is not one of `target`'s temp files.
pub fn temp_owner(target: &Path, file_name: &str) -> Option<u32> {
    let name = target.file_name()?.to_str()?;
    let rest = file_name.strip_prefix('.')?.strip_prefix(name)?.strip_prefix(".tmp.")?;
    let (pid, n) = rest.split_once('.')?;
    n.parse::<u64>().ok()?;
    pid.parse().ok()
}

/// Folders this process has swept of dead writers' temp files.
static SWEPT: Mutex<BTreeSet<PathBuf>> = Mutex::new(BTreeSet::new());

/// [`remove_dead_temp_files`] of `dir`, the first time this process writes there.
fn sweep_once(dir: &Path) {
    let first = SWEPT.lock().map(|mut swept| swept.insert(dir.to_path_buf())).unwrap_or(false);
    if first {
        remove_dead_temp_files(dir);
    }
}

/// Removes the temp files in `dir` ([`temp_path`] names) whose writer is a process that no
/// longer exists on this machine; a live writer's temp file is never touched. Failures are
/// ignored (a file another process removed first, a read-only folder).
pub fn remove_dead_temp_files(dir: &Path) {
    let Ok(entries) = fs::read_dir(dir) else { return };
    for entry in entries.flatten() {
        let Some(pid) = entry.file_name().to_str().and_then(temp_file_owner) else { continue };
        if pid != std::process::id() && !process_alive(pid) {
            let _ = fs::remove_file(entry.path());
        }
    }
}

/// Whether process `pid` exists on this machine and is not a zombie. Without `/proc` (not
/// Linux) a process cannot be checked, so it is assumed alive: nothing of a live process is
/// ever removed or taken over, at the price of cleaning up by hand.
pub fn process_alive(pid: u32) -> bool {
    let proc_root = Path::new("/proc");
    if !proc_root.join("self").exists() {
        return true;
    }
    // A killed process stays a zombie until its parent (a shell, tmux) reaps it: its /proc
    // entry is still there, but it holds nothing. The state is the field after the `(comm)`.
    match fs::read_to_string(proc_root.join(pid.to_string()).join("stat")) {
        Ok(stat) => stat
            .rsplit_once(')')
            .and_then(|(_, rest)| rest.split_whitespace().next())
            .is_none_or(|state| !matches!(state, "Z" | "X")),
        Err(_) => proc_root.join(pid.to_string()).exists(),
    }
}

/// The pid of the process that wrote `file_name` as a temp file for any target (a name
/// `.NAME.tmp.PID.N`, see [`temp_path`]), or `None` when it is not one.
pub fn temp_file_owner(file_name: &str) -> Option<u32> {
    let rest = file_name.strip_prefix('.')?;
    let (_, tail) = rest.rsplit_once(".tmp.")?;
    let (pid, n) = tail.split_once('.')?;
    n.parse::<u64>().ok()?;
    pid.parse().ok()
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
    fn temp_names_are_recognised_only_for_their_target() {
        let t = Path::new("/s/a.lipmap.json");
        let tmp = temp_path(t, 4242, 7);
        assert_eq!(tmp, Path::new("/s/.a.lipmap.json.tmp.4242.7"));
        let name = tmp.file_name().unwrap().to_str().unwrap();
        assert_eq!(temp_owner(t, name), Some(4242));
        assert_eq!(temp_owner(Path::new("/s/a.lipmap"), name), None);
        assert_eq!(temp_owner(t, ".a.lipmap.json.tmp.4242"), None);
        assert_eq!(temp_owner(t, "a.lipmap.json.bak"), None);
    }

    #[test]
    fn a_leftover_temp_with_our_next_name_is_stepped_over() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.txt");
        let next = TEMP_COUNTER.load(Ordering::Relaxed);
        // Leave the next few names taken, as a crashed process with our pid would.
        for n in next..next + 3 {
            fs::write(temp_path(&p, std::process::id(), n), "stale").unwrap();
        }
        write_atomic_bytes(&p, b"new").unwrap();
        assert_eq!(fs::read_to_string(&p).unwrap(), "new");
    }

    #[test]
    fn a_seeking_writer_patches_earlier_bytes() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.bin");
        let mut f = AtomicFile::create(&p).unwrap();
        f.write_all(b"xxxxtail").unwrap();
        f.seek(SeekFrom::Start(0)).unwrap();
        f.write_all(b"head").unwrap();
        f.seek(SeekFrom::End(0)).unwrap();
        f.commit().unwrap();
        assert_eq!(fs::read(&p).unwrap(), b"headtail");
    }

    #[test]
    fn a_failing_hook_before_the_rename_leaves_the_target() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("s.json");
        fs::write(&p, "old").unwrap();
        let mut f = AtomicFile::create(&p).unwrap();
        f.write_all(b"new").unwrap();
        let seen = std::cell::Cell::new(false);
        let err = f
            .commit_after(|t| {
                seen.set(fs::read_to_string(t).unwrap() == "old");
                Err(io::Error::other("backup failed"))
            })
            .unwrap_err();
        assert_eq!(err.to_string(), "backup failed");
        assert!(seen.get());
        assert_eq!(fs::read_to_string(&p).unwrap(), "old");
        assert_eq!(entries(dir.path()), vec!["s.json".to_string()]);
    }

    #[test]
    fn a_missing_folder_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        assert!(write_atomic_bytes(&dir.path().join("no/such/x"), b"x").is_err());
    }
}
