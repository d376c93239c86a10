//! The edit journal: an append-only file beside a session being edited
//! (`NAME.lipmap.json.journal`), one JSON line per edit, each flushed to disk before the
//! next, so a crash (`kill -9`, power loss) loses at most the edit being written. Opening
//! the session again replays it; a successful save of everything removes it.
//!
//! Each line holds a clip's whole edit layer (corrections, reviewed frames, side-view
//! corrections, the labelled map) rather than the one change: replaying is then "take the
//! last whole line per clip", needs no knowledge of the editor's operations, and a torn last
//! line only costs that edit. The lines are small: the layer holds edits, not the tracker's
//! landmarks.

use super::{Corrections, MapRole, Session, SessionError};
use crate::math::Point2;
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::fs::{File, OpenOptions};
use std::io::Write;
use std::path::{Path, PathBuf};

/// One clip's edit layer at one moment.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct JournalEntry {
    pub clip: String,
    pub corrections: Corrections,
    #[serde(default)]
    pub profile_corrections: BTreeMap<usize, Point2>,
    /// The inline landmark map, when the editor changed it.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub landmark_map: Option<BTreeMap<usize, usize>>,
    /// The mesh `landmark_map` labels (the model's, or a head with its own map).
    #[serde(default, skip_serializing_if = "is_model")]
    pub map_role: MapRole,
}

fn is_model(role: &MapRole) -> bool {
    *role == MapRole::Model
}

/// The journal of the session at `session`: `NAME.lipmap.json.journal` beside it.
pub fn journal_path(session: &Path) -> PathBuf {
    let mut name = session.file_name().unwrap_or_default().to_os_string();
    name.push(".journal");
    session.with_file_name(name)
}

/// Renames the journal of `session` to `….journal.bad` (after a failed [`replay`]), so the
/// user keeps it and new edits start a new one. Returns the new name.
pub fn set_aside(session: &Path) -> PathBuf {
    let path = journal_path(&super::absolute(session));
    let mut name = path.file_name().unwrap_or_default().to_os_string();
    name.push(".bad");
    let aside = path.with_file_name(name);
    let _ = std::fs::rename(&path, &aside);
    aside
}

/// An open journal, appended to by one editor (who holds the session's lock).
pub struct Journal {
    path: PathBuf,
    file: Option<File>,
    /// The file may exist (found at open, or recorded to since the last clear).
    present: bool,
}

impl Journal {
    /// The journal of `session`; nothing is created until the first [`record`](Self::record).
    pub fn new(session: &Path) -> Self {
        let path = journal_path(&super::absolute(session));
        let present = path.exists();
        Self { path, file: None, present }
    }

    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Appends `entry` as one line and waits until it is on disk.
    ///
    /// # Errors
    /// `Io` naming the journal.
    pub fn record(&mut self, entry: &JournalEntry) -> Result<(), SessionError> {
        let io = |source| SessionError::Io { path: self.path.clone(), source };
        let mut line = serde_json::to_vec(entry).map_err(|e| SessionError::Invalid {
            path: self.path.clone(),
            message: e.to_string(),
        })?;
        line.push(b'\n');
        if self.file.is_none() {
            // Appended in place, not through `io::atomic`: each line is fsynced on its own and
            // replay stops at a torn last line, so rewriting the whole journal per edit would
            // only cost time.
            let f = OpenOptions::new().create(true).append(true).open(&self.path).map_err(io)?;
            // The new name must survive a crash too: sync the folder once.
            if let Some(dir) = self.path.parent() {
                let _ = crate::io::atomic::sync_dir(dir);
            }
            self.file = Some(f);
            self.present = true;
        }
        let f = self.file.as_mut().expect("opened above");
        // One write of the whole line: a crash leaves a prefix of it at worst, which replay
        // ignores.
        f.write_all(&line).map_err(io)?;
        f.sync_data().map_err(io)
    }

    /// Whether the journal file may exist (left by a crash, or recorded to since the last
    /// clear).
    pub fn is_present(&self) -> bool {
        self.present
    }

    /// Removes the journal once the session file holds everything it recorded.
    ///
    /// # Errors
    /// `Io` when the file exists and cannot be removed.
    pub fn clear(&mut self) -> Result<(), SessionError> {
        self.file = None;
        self.present = false;
        match std::fs::remove_file(&self.path) {
            Err(e) if e.kind() != std::io::ErrorKind::NotFound => {
                Err(SessionError::Io { path: self.path.clone(), source: e })
            }
            _ => Ok(()),
        }
    }
}

/// What [`replay`] applied.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Replayed {
    /// Edits the journal holds that the session file lacks: corrected points, reviewed
    /// frames, side-view corrections and map labels that differ between the two.
    pub edits: usize,
    /// Clips whose edit layer differs.
    pub clips: usize,
}

impl Replayed {
    /// Whether the journal held nothing the session file lacks.
    pub fn is_empty(&self) -> bool {
        self.edits == 0
    }
}

/// How many entries differ between two maps: added, removed or changed.
fn differing<K: Ord, V: PartialEq>(a: &BTreeMap<K, V>, b: &BTreeMap<K, V>) -> usize {
    let changed = a.iter().filter(|(k, v)| b.get(k) != Some(v)).count();
    changed + b.keys().filter(|k| !a.contains_key(k)).count()
}

/// The edits `next` holds that `old` does not, counted per corrected point, reviewed frame,
/// side-view correction and map label.
fn edits_between(old: &JournalEntry, next: &JournalEntry) -> usize {
    let points = |c: &Corrections| -> BTreeMap<(usize, usize), crate::landmarks::LandmarkPoint> {
        c.points.iter().flat_map(|(&f, ps)| ps.iter().map(move |(&i, p)| ((f, i), *p))).collect()
    };
    let reviewed = old.corrections.reviewed.symmetric_difference(&next.corrections.reviewed);
    let map = match (&old.landmark_map, &next.landmark_map) {
        (_, None) => 0,
        (None, Some(m)) => m.len(),
        (Some(a), Some(b)) => differing(a, b),
    };
    differing(&points(&old.corrections), &points(&next.corrections))
        + reviewed.count()
        + differing(&old.profile_corrections, &next.profile_corrections)
        + map
}

/// Applies the journal left beside `session_path` (by an editor that crashed, or one still
/// editing) to `session`: the last whole line of each clip replaces that clip's edit layer.
/// Returns how many edits the journal holds and how many clips they touched (nothing when
/// there is no journal). A torn last line is skipped; the journal stays until a save clears
/// it.
///
/// # Errors
/// `Io` for an unreadable journal; `Invalid` naming the journal and line when a whole line
/// is not an entry, or when the restored session breaks a rule (the journal is as untrusted
/// as the session file).
pub fn replay(session: &mut Session, session_path: &Path) -> Result<Replayed, SessionError> {
    let path = journal_path(&super::absolute(session_path));
    super::refuse_special_file(&path)?;
    let bytes = match std::fs::read(&path) {
        Ok(b) => b,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Replayed::default()),
        Err(source) => return Err(SessionError::Io { path, source }),
    };
    let invalid = |line: usize, message: String| SessionError::Invalid {
        path: path.clone(),
        message: format!("line {line}: {message}"),
    };
    let mut last: BTreeMap<String, JournalEntry> = BTreeMap::new();
    let mut lines = bytes.split(|&b| b == b'\n').enumerate().peekable();
    while let Some((i, line)) = lines.next() {
        let whole = lines.peek().is_some();
        if line.is_empty() {
            continue;
        }
        match serde_json::from_slice::<JournalEntry>(line) {
            Ok(e) => {
                last.insert(e.clip.clone(), e);
            }
            // The line being written when the editor died: that edit is the one lost.
            Err(_) if !whole => break,
            Err(e) => return Err(invalid(i + 1, e.to_string())),
        }
    }
    // Applied to a copy: a refused journal leaves the session as loaded.
    let mut next = session.clone();
    let mut replayed = Replayed::default();
    for (name, e) in last {
        let Some(i) = next.clip_index(&name) else {
            return Err(invalid(0, format!("no clip {name:?} in the session")));
        };
        let saved_map = next.map_of(e.map_role).inline.clone();
        let clip = &mut next.clips[i];
        let saved = JournalEntry {
            clip: name,
            corrections: clip.corrections.clone(),
            profile_corrections: clip.profile_corrections.clone(),
            landmark_map: saved_map,
            map_role: e.map_role,
        };
        let edits = edits_between(&saved, &e);
        replayed.edits += edits;
        replayed.clips += usize::from(edits > 0);
        clip.corrections = e.corrections;
        clip.profile_corrections = e.profile_corrections;
        if let Some(map) = e.landmark_map {
            next.map_of_mut(e.map_role).inline = Some(map);
        }
    }
    next.validate().map_err(|message| SessionError::Invalid { path: path.clone(), message })?;
    // The corrections were set on the clips themselves.
    next.forget_derived();
    *session = next;
    Ok(replayed)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::landmarks::LandmarkPoint;
    use crate::session::{Clip, FramesRef, View};

    fn session(dir: &Path) -> (Session, PathBuf) {
        let path = dir.join("s.lipmap.json");
        let mut s = Session::new(&path);
        let view = View::new(FramesRef::Images { dir: dir.join("frames") }, 25.0);
        s.clips.push(Clip::new("a", view));
        s.save(&path).unwrap();
        (s, path)
    }

    fn entry(n: usize) -> JournalEntry {
        let mut corrections = Corrections::default();
        for f in 0..n {
            corrections.set(f, 3, LandmarkPoint::tracked(1.0, f as f64)).unwrap();
        }
        JournalEntry {
            clip: "a".into(),
            corrections,
            profile_corrections: BTreeMap::new(),
            landmark_map: None,
            map_role: MapRole::Model,
        }
    }

    #[test]
    fn replay_takes_the_last_whole_line_and_skips_a_torn_one() {
        let dir = tempfile::tempdir().unwrap();
        let (mut s, path) = session(dir.path());
        let mut j = Journal::new(&path);
        for n in 1..=3 {
            j.record(&entry(n)).unwrap();
        }
        // A crash in the middle of the fourth line.
        let torn = serde_json::to_string(&entry(4)).unwrap();
        let mut f = OpenOptions::new().append(true).open(j.path()).unwrap();
        f.write_all(&torn.as_bytes()[..torn.len() / 2]).unwrap();
        // Three points corrected (the last whole line), each an edit.
        assert_eq!(replay(&mut s, &path).unwrap(), Replayed { edits: 3, clips: 1 });
        let mut again = s.clone();
        assert!(replay(&mut again, &path).unwrap().is_empty(), "nothing new the second time");
        assert_eq!(s.clips[0].corrections.points.len(), 3);
        j.clear().unwrap();
        assert!(!j.path().exists());
        let (mut fresh, _) = session(dir.path());
        assert!(replay(&mut fresh, &path).unwrap().is_empty());
    }

    #[test]
    fn a_hostile_journal_is_refused_with_its_name() {
        let dir = tempfile::tempdir().unwrap();
        let (mut s, path) = session(dir.path());
        let mut bad = entry(1);
        bad.corrections.reviewed.insert(1 << 40);
        Journal::new(&path).record(&bad).unwrap();
        let err = replay(&mut s, &path).unwrap_err().to_string();
        assert!(err.contains(".journal") && err.contains("reviewed frame"), "{err}");
        std::fs::write(journal_path(&path), "not json\n{}\n").unwrap();
        let err = replay(&mut s, &path).unwrap_err().to_string();
        assert!(err.contains(".journal") && err.contains("line 1"), "{err}");
    }
}
