//! A clip's per-frame data — its tracked landmarks and its cached fits — kept out of the
//! session JSON, in files beside it (`NAME.lipmap.d/`, [`super::data_dir`]), and in memory
//! only while someone uses it.
//!
//! A [`ClipData`] is either in memory only (new or changed since the last save, or read
//! from an older session whose JSON held it inline) or in a file. [`ClipData::get`] reads a
//! file the first time it is asked for and keeps only a weak reference afterwards: the data
//! stays in memory while a caller holds the `Arc`, and is read again after, so a session's
//! memory is bounded by the clips being worked on rather than by the whole corpus.
//!
//! Clones share their slot (a save that puts the data in a file serves every clone, since
//! the contents are the same); replacing the data makes a new slot. Files are named by the
//! checksum of their contents, so equal contents share a file, an unchanged clip is never
//! written again, and a file never changes once written.

use super::SessionError;
use super::binary::{HashOnly, Kind};
use super::cache::FitCacheEntry;
use crate::landmarks::Track;
use std::fmt;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard, Weak};

/// What a per-clip data file can hold.
pub trait ClipDataKind: Default + PartialEq + Send + Sync + 'static {
    /// Which file it is.
    const KIND: Kind;
    /// What the session JSON says of the data, so the session's bounds are checked (and the
    /// file's header compared) without reading the file.
    type Summary: Copy + PartialEq + fmt::Debug + Send + Sync;
    fn summary(&self) -> Self::Summary;
    fn is_empty(&self) -> bool;
    /// About how many bytes the data takes in memory (for the spill budget).
    fn approx_bytes(&self) -> usize;
    /// Writes the file's bytes; returns their checksum.
    ///
    /// # Errors
    /// The writer's I/O error.
    fn write(&self, out: &mut dyn Write) -> std::io::Result<u64>;
    /// Reads a file the session says holds `summary`.
    ///
    /// # Errors
    /// `Invalid` naming the file, record and field at fault.
    fn read(path: &Path, summary: &Self::Summary) -> Result<Self, SessionError>;
}

/// What the session JSON says of a clip's tracked landmarks.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct TrackSummary {
    /// Frames with tracked landmarks.
    pub frames: usize,
    /// The last of them.
    pub last_frame: Option<usize>,
}

impl ClipDataKind for Track {
    const KIND: Kind = Kind::Track;
    type Summary = TrackSummary;

    fn summary(&self) -> TrackSummary {
        TrackSummary { frames: self.len(), last_frame: self.frames.last().map(|f| f.frame) }
    }

    fn is_empty(&self) -> bool {
        self.frames.is_empty()
    }

    fn approx_bytes(&self) -> usize {
        self.frames.iter().map(|f| 64 + f.points.len() * 32).sum()
    }

    fn write(&self, out: &mut dyn Write) -> std::io::Result<u64> {
        super::track_file::write_track(out, self)
    }

    fn read(path: &Path, summary: &TrackSummary) -> Result<Self, SessionError> {
        let track = super::track_file::read_track(path, summary.frames)?;
        let last = track.frames.last().map(|f| f.frame);
        if last != summary.last_frame {
            return Err(SessionError::Invalid {
                path: path.to_path_buf(),
                message: format!(
                    "the last tracked frame is {} where the session says {}",
                    shown(last),
                    shown(summary.last_frame)
                ),
            });
        }
        Ok(track)
    }
}

fn shown(frame: Option<usize>) -> String {
    frame.map_or_else(|| "none".into(), |f| f.to_string())
}

/// What the session JSON says of a clip's cached fits.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct FitsSummary {
    /// Cache entries (fit settings).
    pub entries: usize,
}

impl ClipDataKind for Vec<FitCacheEntry> {
    const KIND: Kind = Kind::Fits;
    type Summary = FitsSummary;

    fn summary(&self) -> FitsSummary {
        FitsSummary { entries: self.len() }
    }

    fn is_empty(&self) -> bool {
        <[FitCacheEntry]>::is_empty(self)
    }

    fn approx_bytes(&self) -> usize {
        let fit = |f: &crate::fit::FrameFit| {
            160 + 8 * (f.identity.len() + f.expression.len()) + 24 * f.residuals.len()
        };
        self.iter().flat_map(|e| &e.frames).map(|c| 40 + fit(&c.fit)).sum()
    }

    fn write(&self, out: &mut dyn Write) -> std::io::Result<u64> {
        super::fits_file::write_fits(out, self)
    }

    fn read(path: &Path, summary: &FitsSummary) -> Result<Self, SessionError> {
        super::fits_file::read_fits(path, summary.entries)
    }
}

/// A clip's tracked landmarks or cached fits, in memory or in a file beside the session.
pub struct ClipData<T: ClipDataKind> {
    slot: Arc<Mutex<Slot<T>>>,
}

struct Slot<T: ClipDataKind> {
    /// The file holding the data, once it is in one (absolute).
    file: Option<PathBuf>,
    summary: T::Summary,
    /// Checksum of the contents, once known.
    hash: Option<u64>,
    held: Held<T>,
}

enum Held<T> {
    /// In memory only, or read and kept on purpose.
    Strong(Arc<T>),
    /// In a file; in memory while a caller holds it.
    Weak(Weak<T>),
}

impl<T: ClipDataKind> ClipData<T> {
    /// Data in memory only (written to a file by the next save).
    pub fn new(value: T) -> Self {
        let summary = value.summary();
        Self::from_slot(Slot {
            file: None,
            summary,
            hash: None,
            held: Held::Strong(Arc::new(value)),
        })
    }

    /// Data in `file` (absolute), which the session says holds `summary`.
    pub(crate) fn in_file(file: PathBuf, summary: T::Summary) -> Self {
        Self::from_slot(Slot {
            file: Some(file),
            summary,
            hash: None,
            held: Held::Weak(Weak::new()),
        })
    }

    fn from_slot(slot: Slot<T>) -> Self {
        Self { slot: Arc::new(Mutex::new(slot)) }
    }

    fn lock(&self) -> MutexGuard<'_, Slot<T>> {
        // The slot holds no invariant a panicking reader could break halfway.
        self.slot.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
    }

    /// The data, read from its file when it is not in memory.
    ///
    /// # Errors
    /// The file cannot be read or is not what the session says (`Invalid` naming the file,
    /// record and field).
    pub fn get(&self) -> Result<Arc<T>, SessionError> {
        let mut slot = self.lock();
        let weak = match &slot.held {
            Held::Strong(v) => return Ok(v.clone()),
            Held::Weak(w) => w.clone(),
        };
        if let Some(v) = weak.upgrade() {
            return Ok(v);
        }
        let Some(file) = slot.file.clone() else {
            unreachable!("data neither in memory nor in a file")
        };
        let v = Arc::new(T::read(&file, &slot.summary)?);
        slot.held = Held::Weak(Arc::downgrade(&v));
        Ok(v)
    }

    /// What the session JSON says of the data (read from neither file nor memory).
    pub fn summary(&self) -> T::Summary {
        self.lock().summary
    }

    /// Whether there is nothing (no frames, no cache entries).
    pub fn is_empty(&self) -> bool {
        let slot = self.lock();
        match (&slot.file, &slot.held) {
            (None, Held::Strong(v)) => v.is_empty(),
            _ => false,
        }
    }

    /// The file holding the data, when it is in one.
    pub fn file(&self) -> Option<PathBuf> {
        self.lock().file.clone()
    }

    /// The data when it is in memory only (not in any file yet).
    pub fn unsaved(&self) -> Option<Arc<T>> {
        let slot = self.lock();
        match (&slot.file, &slot.held) {
            (None, Held::Strong(v)) => Some(v.clone()),
            _ => None,
        }
    }

    /// The checksum of the contents (the name of their file).
    ///
    /// # Errors
    /// As [`ClipData::get`] when the checksum is not known yet.
    fn content_hash(&self) -> Result<u64, SessionError> {
        if let Some(h) = self.lock().hash {
            return Ok(h);
        }
        let h = match self.file().and_then(|f| hash_in_name(&f)) {
            Some(h) => h,
            None => self
                .get()?
                .write(&mut HashOnly)
                .map_err(|source| SessionError::Io { path: PathBuf::from("(memory)"), source })?,
        };
        self.lock().hash = Some(h);
        Ok(h)
    }

    /// Puts the data in a file of folder `dir` named `STEM.HASH.EXT` (kept when it exists:
    /// equal names, equal contents), unless it is in one there already; afterwards the data
    /// is held in memory only while a caller uses it. Data in a file of another folder (a
    /// session saved under a new name) is linked or copied over.
    ///
    /// # Errors
    /// `Io` naming the file that could not be written; the data then stays where it was.
    pub(crate) fn put_in(&self, dir: &Path, stem: &str) -> Result<(), SessionError> {
        if self.is_empty() {
            return Ok(());
        }
        let hash = self.content_hash()?;
        let mut slot = self.lock();
        if slot.file.as_deref().and_then(Path::parent) == Some(dir) {
            return Ok(());
        }
        let name = format!("{stem}.{hash:016x}.{}", T::KIND.extension());
        let target = dir.join(name);
        let io = |source| SessionError::Io { path: target.clone(), source };
        std::fs::create_dir_all(dir)
            .map_err(|source| SessionError::Io { path: dir.to_path_buf(), source })?;
        if !target.exists() {
            match (&slot.held, &slot.file) {
                (Held::Strong(v), _) => {
                    let v = v.clone();
                    crate::io::atomic::write_atomic(&target, |w| v.write(w).map(|_| ()))
                        .map_err(io)?;
                }
                (Held::Weak(_), Some(from)) => {
                    if std::fs::hard_link(from, &target).is_err() {
                        let bytes = std::fs::read(from)
                            .map_err(|source| SessionError::Io { path: from.clone(), source })?;
                        crate::io::atomic::write_atomic_bytes(&target, &bytes).map_err(io)?;
                    }
                }
                (Held::Weak(_), None) => unreachable!("data neither in memory nor in a file"),
            }
        }
        if let Held::Strong(v) = &slot.held {
            slot.held = Held::Weak(Arc::downgrade(v));
        }
        slot.file = Some(target);
        slot.hash = Some(hash);
        Ok(())
    }
}

/// The checksum in a data file's name `STEM.HASH.EXT`.
pub(crate) fn hash_in_name(file: &Path) -> Option<u64> {
    let name = file.file_name()?.to_str()?;
    let (rest, _ext) = name.rsplit_once('.')?;
    let (_, hex) = rest.rsplit_once('.')?;
    (hex.len() == 16).then(|| u64::from_str_radix(hex, 16).ok()).flatten()
}

impl<T: ClipDataKind> Default for ClipData<T> {
    fn default() -> Self {
        Self::new(T::default())
    }
}

impl<T: ClipDataKind> Clone for ClipData<T> {
    fn clone(&self) -> Self {
        Self { slot: self.slot.clone() }
    }
}

/// Equal contents: the same slot, or the same checksum (data that cannot be read equals
/// nothing).
impl<T: ClipDataKind> PartialEq for ClipData<T> {
    fn eq(&self, other: &Self) -> bool {
        if Arc::ptr_eq(&self.slot, &other.slot) {
            return true;
        }
        if self.summary() != other.summary() {
            return false;
        }
        match (self.content_hash(), other.content_hash()) {
            (Ok(a), Ok(b)) => a == b,
            _ => false,
        }
    }
}

impl<T: ClipDataKind> fmt::Debug for ClipData<T> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let slot = self.lock();
        match &slot.file {
            Some(file) => write!(f, "{:?} in {}", slot.summary, file.display()),
            None => write!(f, "{:?} in memory", slot.summary),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::landmarks::{FrameLandmarks, LandmarkPoint};

    fn track(n: usize) -> Track {
        Track::new(
            (0..n)
                .map(|f| FrameLandmarks::new(f, vec![LandmarkPoint::tracked(f as f64, 2.0); 68]))
                .collect(),
        )
    }

    #[test]
    fn data_goes_to_a_file_named_by_its_contents_and_is_read_back_when_used() {
        let dir = tempfile::tempdir().unwrap();
        let d = ClipData::new(track(3));
        assert!(d.unsaved().is_some());
        d.put_in(dir.path(), "clip").unwrap();
        let file = d.file().unwrap();
        assert_eq!(file.parent(), Some(dir.path()));
        assert!(file.file_name().unwrap().to_str().unwrap().starts_with("clip."));
        assert!(d.unsaved().is_none());
        // Nobody holds it: it is read from the file, and kept only while held.
        let held = d.get().unwrap();
        assert_eq!(*held, track(3));
        assert!(Arc::ptr_eq(&held, &d.get().unwrap()));
        drop(held);
        let again = ClipData::<Track>::in_file(file.clone(), d.summary());
        assert_eq!(again, d);
        assert_ne!(again, ClipData::new(track(2)));
        // Equal contents, one file.
        let twin = ClipData::new(track(3));
        twin.put_in(dir.path(), "clip").unwrap();
        assert_eq!(twin.file(), Some(file.clone()));
        // Another folder: copied over, the same name.
        let other = dir.path().join("other");
        again.put_in(&other, "clip").unwrap();
        assert_eq!(again.file().unwrap(), other.join(file.file_name().unwrap()));
        assert_eq!(*again.get().unwrap(), track(3));
    }

    #[test]
    fn a_damaged_file_is_an_error_naming_it_when_used() {
        let dir = tempfile::tempdir().unwrap();
        let d = ClipData::new(track(2));
        d.put_in(dir.path(), "c").unwrap();
        let file = d.file().unwrap();
        let wrong = ClipData::<Track>::in_file(
            file.clone(),
            TrackSummary { frames: 2, last_frame: Some(5) },
        );
        let e = wrong.get().unwrap_err().to_string();
        assert!(e.contains(file.to_str().unwrap()) && e.contains("session says 5"), "{e}");
        std::fs::write(&file, b"not a track").unwrap();
        let e = ClipData::<Track>::in_file(file.clone(), d.summary()).get().unwrap_err();
        assert!(e.to_string().contains("too short"), "{e}");
    }
}
