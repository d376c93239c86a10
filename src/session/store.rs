//! Putting a session on disk safely: atomic replace with rotating backups, the lock file that
//! keeps a second editor out, the JSON layout, and relative <-> absolute path conversion.
//!
//! Save = write `.NAME.tmp.PID.N` beside the target through [`crate::io::atomic`] (fsynced),
//! rotate the backups (hard links, so the target never disappears), rename the temp file over
//! the target, fsync the folder.
//! A crash at any point leaves either the old or the new file whole, never a mix.

use super::SessionError;
use crate::io::atomic::{self, AtomicFile};
use serde::{Deserialize, Serialize};
use std::cell::RefCell;
use std::fs::{self, OpenOptions};
use std::io::{self, Write};
use std::path::{Component, Path, PathBuf};

/// How many backups (`NAME.bak`, `NAME.bak.2`, `NAME.bak.3`) a save keeps.
pub const BACKUPS_KEPT: usize = 3;

/// The least age of the newest backup before a save pushes the backups along. Autosaves
/// come every few seconds while someone edits; without spacing all three backups would
/// hold the last few seconds' states and a mistake older than that could not be undone
/// from them.
pub const BACKUP_SPACING: std::time::Duration = std::time::Duration::from_secs(60);

// ---------------------------------------------------------------------------------------
// Paths: absolute in memory, relative to the session file's folder on disk.

thread_local! {
    /// The folder paths are relative to while a session is (de)serialized on this thread.
    static BASE_DIR: RefCell<Option<PathBuf>> = const { RefCell::new(None) };
}

/// Runs `f` with path fields (de)serialized relative to `base`. Serde offers no context
/// parameter, and (de)serialization is synchronous on one thread, so a scoped thread-local
/// is the least intrusive way to avoid copying the whole session to rewrite its paths.
pub(crate) fn with_base_dir<R>(base: &Path, f: impl FnOnce() -> R) -> R {
    struct Restore(Option<PathBuf>);
    impl Drop for Restore {
        fn drop(&mut self) {
            let old = self.0.take();
            BASE_DIR.with(|b| *b.borrow_mut() = old);
        }
    }
    let old = BASE_DIR.with(|b| b.borrow_mut().replace(base.to_path_buf()));
    let _restore = Restore(old);
    f()
}

fn current_base() -> Option<PathBuf> {
    BASE_DIR.with(|b| b.borrow().clone())
}

/// Removes `.` and folds `dir/..` without touching the file system (files may not exist).
pub fn normalize_lexically(path: &Path) -> PathBuf {
    let mut out: Vec<Component> = Vec::new();
    for c in path.components() {
        match c {
            Component::CurDir => {}
            Component::ParentDir => match out.last() {
                Some(Component::Normal(_)) => {
                    out.pop();
                }
                Some(Component::RootDir | Component::Prefix(_)) => {}
                _ => out.push(c),
            },
            _ => out.push(c),
        }
    }
    if out.is_empty() { PathBuf::from(".") } else { out.iter().collect() }
}

/// `path` relative to `base` (both absolute), written with `/`. Paths that share only the
/// file-system root with `base` (a model in `/usr/share`) stay absolute, so moving the
/// project folder does not break them.
pub fn relativize(path: &Path, base: &Path) -> PathBuf {
    if !path.is_absolute() || !base.is_absolute() {
        return path.to_path_buf();
    }
    let p = normalize_lexically(path);
    let b = normalize_lexically(base);
    let pc: Vec<Component> = p.components().collect();
    let bc: Vec<Component> = b.components().collect();
    let common = pc.iter().zip(&bc).take_while(|(x, y)| x == y).count();
    let shares_a_folder = pc[..common].iter().any(|c| matches!(c, Component::Normal(_)));
    if !shares_a_folder {
        return p;
    }
    let mut parts: Vec<String> = vec!["..".to_string(); bc.len() - common];
    parts.extend(pc[common..].iter().map(|c| c.as_os_str().to_string_lossy().into_owned()));
    if parts.is_empty() { PathBuf::from(".") } else { PathBuf::from(parts.join("/")) }
}

/// `path` (from the file) made absolute against `base`.
pub fn resolve(path: &Path, base: &Path) -> PathBuf {
    if path.is_absolute() {
        normalize_lexically(path)
    } else {
        normalize_lexically(&base.join(path))
    }
}

/// Serde adapter for a `PathBuf` field: relative on disk, absolute in memory.
pub(crate) mod rel_path {
    use super::*;
    use serde::{Deserializer, Serializer};

    pub fn serialize<S: Serializer>(path: &Path, s: S) -> Result<S::Ok, S::Error> {
        let shown = match current_base() {
            Some(base) => relativize(path, &base),
            None => path.to_path_buf(),
        };
        match shown.to_str() {
            Some(text) => s.serialize_str(text),
            None => {
                Err(serde::ser::Error::custom(format!("path {} is not UTF-8", shown.display())))
            }
        }
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<PathBuf, D::Error> {
        let text = String::deserialize(d)?;
        if text.is_empty() {
            return Err(serde::de::Error::custom("empty path"));
        }
        let p = PathBuf::from(text);
        Ok(match current_base() {
            Some(base) => resolve(&p, &base),
            None => p,
        })
    }
}

/// Serde adapter for an `Option<PathBuf>` field (use with `#[serde(default)]`).
pub(crate) mod rel_path_opt {
    use super::*;
    use serde::{Deserializer, Serializer};

    pub fn serialize<S: Serializer>(path: &Option<PathBuf>, s: S) -> Result<S::Ok, S::Error> {
        match path {
            Some(p) => rel_path::serialize(p, s),
            None => s.serialize_none(),
        }
    }

    pub fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<Option<PathBuf>, D::Error> {
        #[derive(Deserialize)]
        struct Wrap(#[serde(with = "rel_path")] PathBuf);
        Ok(Option::<Wrap>::deserialize(d)?.map(|w| w.0))
    }
}

// ---------------------------------------------------------------------------------------
// JSON layout.

/// Pretty-prints containers down to `max_depth` and writes anything deeper on one line, so
/// the session's structure reads like ordinary pretty JSON while each frame's 136
/// coordinates stay on one line (fully pretty output would put every number on a line).
pub(crate) struct ShallowPretty {
    depth: usize,
    max_depth: usize,
    has_value: bool,
}

impl ShallowPretty {
    pub(crate) fn new(max_depth: usize) -> Self {
        Self { depth: 0, max_depth, has_value: false }
    }

    fn newline_indent<W: ?Sized + Write>(&self, w: &mut W, depth: usize) -> io::Result<()> {
        w.write_all(b"\n")?;
        for _ in 0..depth {
            w.write_all(b"  ")?;
        }
        Ok(())
    }

    fn pretty(&self) -> bool {
        self.depth <= self.max_depth
    }

    fn open<W: ?Sized + Write>(&mut self, w: &mut W, bracket: &[u8]) -> io::Result<()> {
        self.depth += 1;
        self.has_value = false;
        w.write_all(bracket)
    }

    fn close<W: ?Sized + Write>(&mut self, w: &mut W, bracket: &[u8]) -> io::Result<()> {
        let was_pretty = self.pretty();
        self.depth -= 1;
        if self.has_value && was_pretty {
            self.newline_indent(w, self.depth)?;
        }
        w.write_all(bracket)
    }

    fn item<W: ?Sized + Write>(&mut self, w: &mut W, first: bool) -> io::Result<()> {
        if !first {
            w.write_all(b",")?;
        }
        if self.pretty() { self.newline_indent(w, self.depth) } else { Ok(()) }
    }
}

impl serde_json::ser::Formatter for ShallowPretty {
    fn begin_array<W: ?Sized + Write>(&mut self, w: &mut W) -> io::Result<()> {
        self.open(w, b"[")
    }
    fn end_array<W: ?Sized + Write>(&mut self, w: &mut W) -> io::Result<()> {
        self.close(w, b"]")
    }
    fn begin_array_value<W: ?Sized + Write>(&mut self, w: &mut W, first: bool) -> io::Result<()> {
        self.item(w, first)
    }
    fn end_array_value<W: ?Sized + Write>(&mut self, _w: &mut W) -> io::Result<()> {
        self.has_value = true;
        Ok(())
    }
    fn begin_object<W: ?Sized + Write>(&mut self, w: &mut W) -> io::Result<()> {
        self.open(w, b"{")
    }
    fn end_object<W: ?Sized + Write>(&mut self, w: &mut W) -> io::Result<()> {
        self.close(w, b"}")
    }
    fn begin_object_key<W: ?Sized + Write>(&mut self, w: &mut W, first: bool) -> io::Result<()> {
        self.item(w, first)
    }
    fn begin_object_value<W: ?Sized + Write>(&mut self, w: &mut W) -> io::Result<()> {
        w.write_all(if self.pretty() { b": " } else { b":" })
    }
    fn end_object_value<W: ?Sized + Write>(&mut self, _w: &mut W) -> io::Result<()> {
        self.has_value = true;
        Ok(())
    }
}

// ---------------------------------------------------------------------------------------
// Atomic replace with backups.

/// The `k`-th backup of `target` (1 = newest): `NAME.bak`, `NAME.bak.2`, ...
pub fn backup_path(target: &Path, k: usize) -> PathBuf {
    let mut name = target.file_name().unwrap_or_default().to_os_string();
    name.push(if k <= 1 { ".bak".to_string() } else { format!(".bak.{k}") });
    target.with_file_name(name)
}

/// Replaces `target` with `bytes` atomically through [`crate::io::atomic`], keeping
/// `BACKUPS_KEPT` older versions (rotated once the new contents are on disk, so a failed
/// write never shifts them).
///
/// # Errors
/// `SessionError::Io` naming the file that could not be written, linked or renamed; the
/// target is untouched in every error case.
pub fn write_atomically(target: &Path, bytes: &[u8]) -> Result<(), SessionError> {
    write_atomically_with(target, |file| {
        file.write_all(bytes)
            .map_err(|source| SessionError::Io { path: target.to_path_buf(), source })
    })
}

/// As [`write_atomically`], the contents written by `write` as they are made (a corpus's
/// session text is never held whole in memory); when `write` fails nothing is replaced.
///
/// # Errors
/// `write`'s error; as [`write_atomically`].
pub fn write_atomically_with(
    target: &Path,
    write: impl FnOnce(&mut dyn Write) -> Result<(), SessionError>,
) -> Result<(), SessionError> {
    let io_err = |path: &Path| {
        let path = path.to_path_buf();
        move |source| SessionError::Io { path, source }
    };
    if let Some(dir) = target.parent().filter(|d| !d.as_os_str().is_empty()) {
        fs::create_dir_all(dir).map_err(io_err(dir))?;
    }
    let mut file = AtomicFile::create(target).map_err(io_err(target))?;
    write(&mut file)?;
    file.commit_after(|t| if t.exists() { rotate_backups(t) } else { Ok(()) })
        .map_err(io_err(target))?;
    // Saves are few and the folder small: every save clears what crashed saves left.
    if let Some(dir) = target.parent() {
        atomic::remove_dead_temp_files(dir);
    }
    Ok(())
}

fn rotate_backups(target: &Path) -> io::Result<()> {
    let newest = backup_path(target, 1);
    // A hard-linked backup keeps the mtime of the save that wrote it.
    let recent = fs::metadata(&newest)
        .and_then(|m| m.modified())
        .ok()
        .and_then(|t| t.elapsed().ok())
        .is_some_and(|age| age < BACKUP_SPACING);
    if recent {
        return Ok(());
    }
    for k in (1..BACKUPS_KEPT).rev() {
        let from = backup_path(target, k);
        if from.exists() {
            fs::rename(&from, backup_path(target, k + 1))?;
        }
    }
    // A hard link keeps the current file in place until the rename replaces it; copy where
    // the file system has no hard links.
    if fs::hard_link(target, &newest).is_err() {
        fs::copy(target, &newest)?;
    }
    Ok(())
}

// ---------------------------------------------------------------------------------------
// The editor lock.

/// Who holds a session open for editing; the content of `NAME.lipmap.json.lock`.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct LockInfo {
    pub user: String,
    pub host: String,
    pub pid: u32,
    /// Seconds since the Unix epoch when the lock was taken.
    pub since_unix: u64,
}

impl LockInfo {
    /// This process, now.
    pub fn current() -> Self {
        let since_unix = std::time::SystemTime::now()
            .duration_since(std::time::UNIX_EPOCH)
            .map_or(0, |d| d.as_secs());
        Self { user: current_user(), host: current_host(), pid: std::process::id(), since_unix }
    }

    /// Whether the holder is a process on this machine that no longer exists.
    pub fn is_stale(&self) -> bool {
        self.host == current_host() && !process_alive(self.pid)
    }
}

impl std::fmt::Display for LockInfo {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(
            f,
            "{}@{} (pid {}) since {}",
            self.user,
            self.host,
            self.pid,
            format_utc(self.since_unix)
        )
    }
}

fn current_user() -> String {
    ["USER", "LOGNAME", "USERNAME"]
        .iter()
        .find_map(|k| std::env::var(k).ok().filter(|v| !v.is_empty()))
        .unwrap_or_else(|| "unknown".into())
}

fn current_host() -> String {
    let from_file = |p: &str| {
        fs::read_to_string(p).ok().map(|s| s.trim().to_string()).filter(|s| !s.is_empty())
    };
    from_file("/proc/sys/kernel/hostname")
        .or_else(|| from_file("/etc/hostname"))
        .or_else(|| std::env::var("HOSTNAME").ok().filter(|s| !s.is_empty()))
        .or_else(|| std::env::var("COMPUTERNAME").ok().filter(|s| !s.is_empty()))
        .unwrap_or_else(|| "localhost".into())
}

/// Whether process `pid` is alive on this machine (see [`atomic::process_alive`]: without
/// `/proc` a lock is never stolen from a live editor, at the price of deleting truly stale
/// locks by hand).
pub(crate) fn process_alive(pid: u32) -> bool {
    atomic::process_alive(pid)
}

/// `YYYY-MM-DD HH:MM:SS UTC` from Unix seconds (Howard Hinnant's civil-from-days algorithm).
pub fn format_utc(secs: u64) -> String {
    let days = (secs / 86_400) as i64;
    let rem = secs % 86_400;
    let z = days + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!("{y:04}-{m:02}-{d:02} {:02}:{:02}:{:02} UTC", rem / 3600, rem / 60 % 60, rem % 60)
}

/// The lock file of a session file: `NAME.lipmap.json.lock`.
pub fn lock_path(session: &Path) -> PathBuf {
    let mut name = session.file_name().unwrap_or_default().to_os_string();
    name.push(".lock");
    session.with_file_name(name)
}

/// Deletes `session`'s lock file when this process holds it: for a process about to exit
/// without unwinding (a signal its event loop did not answer), where [`SessionLock`]'s drop
/// would not run. Another process's lock is left alone.
pub fn release_lock_if_ours(session: &Path) {
    let lock = lock_path(session);
    let ours = std::fs::read_to_string(&lock)
        .ok()
        .and_then(|t| serde_json::from_str::<LockInfo>(&t).ok())
        .is_some_and(|info| info.pid == std::process::id());
    if ours {
        let _ = std::fs::remove_file(&lock);
    }
}

/// An editor's claim on a session file; released (the lock file deleted) on drop.
#[derive(Debug)]
pub struct SessionLock {
    path: PathBuf,
    info: LockInfo,
}

impl SessionLock {
    /// Takes the lock of the session at `session`, or takes over a stale one (its holder was
    /// a process on this host that has died).
    ///
    /// # Errors
    /// `SessionError::Locked` naming the holder when another live editor has it;
    /// `Io` when the lock file cannot be created.
    pub fn acquire(session: &Path) -> Result<SessionLock, SessionError> {
        let path = lock_path(session);
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            fs::create_dir_all(dir)
                .map_err(|source| SessionError::Io { path: dir.to_path_buf(), source })?;
        }
        let info = LockInfo::current();
        let text = serde_json::to_string(&info).unwrap_or_default();
        for attempt in 0..2 {
            match create_whole_exclusive(&path, text.as_bytes()) {
                Ok(()) => return Ok(SessionLock { path, info }),
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists && attempt == 0 => {
                    let holder = read_lock(&path);
                    match holder {
                        Some(h) if !h.is_stale() => {
                            return Err(SessionError::Locked {
                                session: session.to_path_buf(),
                                lock: path,
                                holder: h,
                            });
                        }
                        // Stale, or unreadable (a crash while writing it): take it over.
                        _ => {
                            fs::remove_file(&path).map_err(|source| SessionError::Io {
                                path: path.clone(),
                                source,
                            })?;
                        }
                    }
                }
                Err(e) if e.kind() == io::ErrorKind::AlreadyExists => {
                    // Someone else took it between our removal and our creation.
                    let holder = read_lock(&path).unwrap_or_else(|| LockInfo {
                        user: "unknown".into(),
                        host: "unknown".into(),
                        pid: 0,
                        since_unix: 0,
                    });
                    return Err(SessionError::Locked {
                        session: session.to_path_buf(),
                        lock: path,
                        holder,
                    });
                }
                Err(source) => return Err(SessionError::Io { path, source }),
            }
        }
        unreachable!("the loop returns on its second attempt")
    }

    /// Who holds the lock (this process).
    pub fn info(&self) -> &LockInfo {
        &self.info
    }

    /// The lock file.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// The current holder of `session`'s lock, if any.
    pub fn holder(session: &Path) -> Option<LockInfo> {
        read_lock(&lock_path(session))
    }
}

/// Creates `path` holding `bytes`, failing with `AlreadyExists` when it exists, and never
/// leaving it partly written: the bytes go to a temp file (fsynced), which is then hard-linked
/// to `path` (a link, unlike a rename, refuses an existing name, so two editors cannot both
/// win). A full disk fails the temp file's write, and no lock file appears at all. Where the
/// file system has no hard links, `path` is created in place and removed again if its write
/// fails.
fn create_whole_exclusive(path: &Path, bytes: &[u8]) -> io::Result<()> {
    let mut temp = AtomicFile::create(path)?;
    temp.write_all(bytes)?;
    let staged = temp.stage()?;
    match fs::hard_link(staged.path(), path) {
        Ok(()) => Ok(()),
        Err(e) if e.kind() == io::ErrorKind::AlreadyExists => Err(e),
        Err(_) => {
            let mut f = OpenOptions::new().write(true).create_new(true).open(path)?;
            f.write_all(bytes).and_then(|()| f.sync_all()).inspect_err(|_| {
                let _ = fs::remove_file(path);
            })
        }
    }
}

fn read_lock(path: &Path) -> Option<LockInfo> {
    serde_json::from_str(&fs::read_to_string(path).ok()?).ok()
}

impl Drop for SessionLock {
    fn drop(&mut self) {
        // Only delete the file if it is still ours (it may have been taken over as stale).
        if read_lock(&self.path).as_ref() == Some(&self.info) {
            let _ = fs::remove_file(&self.path);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[cfg(target_os = "linux")]
    #[test]
    fn a_killed_unreaped_editor_is_not_alive() {
        let mut child = std::process::Command::new("sleep").arg("30").spawn().unwrap();
        let pid = child.id();
        assert!(process_alive(pid));
        child.kill().unwrap();
        // Not waited for yet: a zombie, whose /proc entry stays until it is reaped.
        let gone = (0..200).any(|_| {
            std::thread::sleep(std::time::Duration::from_millis(5));
            !process_alive(pid)
        });
        assert!(proc_entry_exists(pid), "still unreaped, so /proc keeps it");
        child.wait().unwrap();
        assert!(gone, "a zombie holds no lock");
    }

    #[cfg(target_os = "linux")]
    fn proc_entry_exists(pid: u32) -> bool {
        Path::new("/proc").join(pid.to_string()).exists()
    }

    #[test]
    fn relativize_and_resolve_are_inverse() {
        let base = Path::new("/data/proj/sessions");
        for p in ["/data/proj/frames/clip1", "/data/proj/sessions/x.json", "/data/other/v.mp4"] {
            let rel = relativize(Path::new(p), base);
            assert!(rel.is_relative(), "{p} -> {}", rel.display());
            assert_eq!(resolve(&rel, base), PathBuf::from(p));
        }
        assert_eq!(
            relativize(Path::new("/data/proj/frames/a"), base),
            PathBuf::from("../frames/a")
        );
        // Only the root in common: kept absolute.
        assert_eq!(
            relativize(Path::new("/usr/share/m.bin"), base),
            PathBuf::from("/usr/share/m.bin")
        );
        assert_eq!(normalize_lexically(Path::new("/a/./b/../c")), PathBuf::from("/a/c"));
    }

    #[test]
    fn utc_formatting_matches_known_dates() {
        assert_eq!(format_utc(0), "1970-01-01 00:00:00 UTC");
        assert_eq!(format_utc(951_782_400), "2000-02-29 00:00:00 UTC");
        assert_eq!(format_utc(1_700_000_000), "2023-11-14 22:13:20 UTC");
    }

    #[test]
    fn shallow_pretty_keeps_deep_arrays_on_one_line() {
        let v = serde_json::json!({"a": {"b": [1, 2, 3]}, "c": []});
        let mut out = Vec::new();
        let mut ser = serde_json::Serializer::with_formatter(&mut out, ShallowPretty::new(1));
        v.serialize(&mut ser).unwrap();
        let text = String::from_utf8(out).unwrap();
        assert_eq!(text, "{\n  \"a\": {\"b\":[1,2,3]},\n  \"c\": []\n}");
        let back: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(back, v);
    }
}
