//! The folder beside a session file that holds its clips' per-frame data:
//! `NAME.lipmap.json` → `NAME.lipmap.d/`, one `CLIP.HASH.track` and one `CLIP.HASH.fits` per
//! clip ([`super::clip_data`]). Which files a session file refers to, and tidying the folder
//! after a save.
//!
//! A save writes new data files first, then the session file that refers to them, so a crash
//! leaves the old session file with its old files or the new one with its new files. Files
//! no session version refers to any more are deleted by a later save, but not at once:
//! - files the session's backups (`.bak`, `.bak.2`, `.bak.3`) refer to are kept, so a backup
//!   stays whole;
//! - a file the replaced session file referred to is kept [`UNREFERENCED_GRACE`] longer
//!   (its time is set to now when it is let go): a command reading the session beside its
//!   editor (`eval` beside the TUI) reads a clip's files when it comes to that clip, from the
//!   version it loaded;
//! - a file written less than [`UNREFERENCED_GRACE`] ago is kept (a process that holds the
//!   session's lock writes data before the save that refers to it).

use serde::Deserialize;
use serde::de::IgnoredAny;
use std::collections::BTreeSet;
use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::time::{Duration, SystemTime};

/// How long a data file no session version refers to is kept after it was let go (or
/// written).
pub const UNREFERENCED_GRACE: Duration = Duration::from_secs(10 * 60);

/// The data folder of the session file `session` (absolute): `NAME.lipmap.d` beside
/// `NAME.lipmap.json` (`NAME.d` beside any other `NAME.json`).
pub fn data_dir_of(session: &Path) -> PathBuf {
    let name = session.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    let stem = name.strip_suffix(".json").unwrap_or(&name);
    session.with_file_name(format!("{stem}.d"))
}

/// The start of a clip's data file names: its name with anything but ASCII letters, digits,
/// `-` and `_` made `_`, at most 48 characters (the checksum after it keeps names apart).
pub fn file_stem(clip: &str) -> String {
    let stem: String = clip
        .chars()
        .take(48)
        .map(|c| if c.is_ascii_alphanumeric() || c == '-' || c == '_' { c } else { '_' })
        .collect();
    if stem.is_empty() { "clip".into() } else { stem }
}

/// Whether `name` is a data file's name (`STEM.HASH.track` or `STEM.HASH.fits`).
fn is_data_file(name: &str) -> bool {
    let Some((rest, ext)) = name.rsplit_once('.') else { return false };
    matches!(ext, "track" | "fits")
        && rest
            .rsplit_once('.')
            .is_some_and(|(_, h)| h.len() == 16 && h.bytes().all(|b| b.is_ascii_hexdigit()))
}

/// The data file names a session file's text refers to (by file name: names carry their
/// contents' checksum). Inline data (older sessions) refers to none. Only what is needed is
/// built: clips' `tracked` and `fit_cache` references.
///
/// # Errors
/// The text is not a session's JSON.
pub fn referenced_names(text: &str) -> Result<BTreeSet<OsString>, serde_json::Error> {
    #[derive(Deserialize)]
    struct Doc {
        #[serde(default)]
        clips: Vec<ClipRefs>,
    }
    #[derive(Deserialize)]
    struct ClipRefs {
        #[serde(default)]
        tracked: FileRef,
        #[serde(default)]
        fit_cache: FileRef,
    }
    let doc: Doc = serde_json::from_str(text)?;
    Ok(doc
        .clips
        .into_iter()
        .flat_map(|c| [c.tracked.0, c.fit_cache.0])
        .flatten()
        .filter_map(|f| Path::new(&f).file_name().map(OsString::from))
        .collect())
}

/// A `{"file": …}` reference, or nothing for anything else (inline data is skipped unbuilt).
#[derive(Default)]
struct FileRef(Option<String>);

impl<'de> Deserialize<'de> for FileRef {
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        struct V;
        impl<'de> serde::de::Visitor<'de> for V {
            type Value = FileRef;
            fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
                f.write_str("a data file reference or inline data")
            }
            fn visit_map<A: serde::de::MapAccess<'de>>(
                self,
                mut m: A,
            ) -> Result<FileRef, A::Error> {
                let mut file = None;
                while let Some(k) = m.next_key::<String>()? {
                    if k == "file" {
                        file = Some(m.next_value::<String>()?);
                    } else {
                        m.next_value::<IgnoredAny>()?;
                    }
                }
                Ok(FileRef(file))
            }
            fn visit_seq<A: serde::de::SeqAccess<'de>>(
                self,
                mut s: A,
            ) -> Result<FileRef, A::Error> {
                while s.next_element::<IgnoredAny>()?.is_some() {}
                Ok(FileRef(None))
            }
            fn visit_unit<E: serde::de::Error>(self) -> Result<FileRef, E> {
                Ok(FileRef(None))
            }
        }
        d.deserialize_any(V)
    }
}

/// The data file names session file `path` refers to now (none when it is missing, is of
/// an older schema or cannot be read: such a file keeps no data file).
pub fn names_referenced_by_file(path: &Path) -> BTreeSet<OsString> {
    let Ok(text) = std::fs::read_to_string(path) else { return BTreeSet::new() };
    match super::migrate::peek_schema_version(&text) {
        Ok(super::migrate::SchemaVersion::Version(v)) if v >= super::migrate::DATA_FILES_FROM => {
            referenced_names(&text).unwrap_or_default()
        }
        _ => BTreeSet::new(),
    }
}

/// After a save of `session` that refers to `kept`: lets go of the files `before` (what
/// the replaced file referred to) no longer needed, and deletes data files no version
/// refers to that were let go or written more than [`UNREFERENCED_GRACE`] ago, and temp
/// files of writers that are gone. Failures are left for the next save (tidying is never
/// worth failing a save).
pub fn tidy(session: &Path, kept: &BTreeSet<OsString>, before: &BTreeSet<OsString>) {
    let dir = data_dir_of(session);
    let Ok(entries) = std::fs::read_dir(&dir) else { return };
    let mut keep = kept.clone();
    for k in 1..=super::store::BACKUPS_KEPT {
        keep.extend(names_referenced_by_file(&super::store::backup_path(session, k)));
    }
    let now = SystemTime::now();
    for entry in entries.flatten() {
        let name = entry.file_name();
        let Some(text) = name.to_str() else { continue };
        let path = entry.path();
        if let Some(pid) = crate::io::atomic::temp_file_owner(text) {
            if pid != std::process::id() && !crate::io::atomic::process_alive(pid) {
                let _ = std::fs::remove_file(&path);
            }
            continue;
        }
        if !is_data_file(text) || keep.contains(&name) {
            continue;
        }
        if before.contains(&name) {
            // Let go now: readers of the replaced version get the grace from here.
            let _ =
                std::fs::File::options().write(true).open(&path).and_then(|f| f.set_modified(now));
            continue;
        }
        let old = entry
            .metadata()
            .and_then(|m| m.modified())
            .ok()
            .and_then(|t| now.duration_since(t).ok())
            .is_some_and(|age| age > UNREFERENCED_GRACE);
        if old {
            let _ = std::fs::remove_file(&path);
        }
    }
}

/// Checks a data file reference read from a session: a plain file of the session's data
/// folder or any other, named `STEM.HASH.EXT`.
///
/// # Errors
/// A message for a name that is not a data file's.
pub fn check_reference(file: &Path, ext: &str) -> Result<(), String> {
    let name = file.file_name().and_then(|n| n.to_str()).unwrap_or_default();
    if !is_data_file(name) || !name.ends_with(&format!(".{ext}")) {
        return Err(format!(
            "file {:?} is not a lipmap data file name (CLIP.CHECKSUM.{ext})",
            file.display().to_string()
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_and_references() {
        assert_eq!(
            data_dir_of(Path::new("/s/demo.lipmap.json")),
            PathBuf::from("/s/demo.lipmap.d")
        );
        assert_eq!(data_dir_of(Path::new("/s/x.json")), PathBuf::from("/s/x.d"));
        assert_eq!(file_stem("s1/bbaf2n ü"), "s1_bbaf2n__");
        assert_eq!(file_stem(""), "clip");
        assert!(is_data_file("a.0123456789abcdef.track"));
        assert!(!is_data_file("a.0123456789abcdeg.track"));
        assert!(!is_data_file("a.json"));
        let text = r#"{"schema_version": 3, "clips": [
            {"name": "a", "tracked": {"file": "x.lipmap.d/a.0123456789abcdef.track", "frames": 1},
             "fit_cache": {"file": "x.lipmap.d/a.00000000000000ff.fits", "entries": 1}},
            {"name": "b", "tracked": [{"frame": 0, "xy": []}]}]}"#;
        let names: Vec<_> = referenced_names(text).unwrap().into_iter().collect();
        assert_eq!(names, ["a.00000000000000ff.fits", "a.0123456789abcdef.track"]);
    }

    #[test]
    fn tidying_keeps_what_any_version_needs_and_deletes_the_rest_after_the_grace() {
        let dir = tempfile::tempdir().unwrap();
        let session = dir.path().join("s.lipmap.json");
        let data = data_dir_of(&session);
        std::fs::create_dir(&data).unwrap();
        let old = SystemTime::now() - UNREFERENCED_GRACE - Duration::from_secs(5);
        let file = |name: &str, age: SystemTime| {
            let p = data.join(name);
            std::fs::write(&p, b"x").unwrap();
            std::fs::File::options().write(true).open(&p).unwrap().set_modified(age).unwrap();
            p
        };
        let kept = file("a.0000000000000001.track", old);
        let in_backup = file("a.0000000000000002.track", old);
        let let_go = file("a.0000000000000003.fits", old);
        let stale = file("a.0000000000000004.fits", old);
        let fresh = file("a.0000000000000005.fits", SystemTime::now());
        let other = file("notes.txt", old);
        let dead_temp = file(".a.0000000000000006.fits.tmp.999999999.0", old);
        let backup = r#"{"schema_version": 3, "clips": [{"tracked": {"file": "s.lipmap.d/a.0000000000000002.track"}}]}"#;
        std::fs::write(super::super::store::backup_path(&session, 2), backup).unwrap();
        let name = |p: &Path| p.file_name().unwrap().to_os_string();
        tidy(&session, &[name(&kept)].into(), &[name(&let_go)].into());
        for (p, present) in [
            (&kept, true),
            (&in_backup, true),
            (&let_go, true),
            (&stale, false),
            (&fresh, true),
            (&other, true),
            (&dead_temp, false),
        ] {
            assert_eq!(p.exists(), present, "{}", p.display());
        }
        // Let go a save ago: deleted once its grace has passed.
        std::fs::File::options().write(true).open(&let_go).unwrap().set_modified(old).unwrap();
        tidy(&session, &[name(&kept)].into(), &BTreeSet::new());
        assert!(!let_go.exists());
    }
}
