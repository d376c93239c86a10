//! Session schema versions: reading a file's `schema_version` cheaply, refusing newer ones,
//! and upgrading older ones step by step on the JSON tree before typed parsing.
//!
//! To change the format: bump `CURRENT_SCHEMA`, add a step `(old, fn)` to `STEPS` that turns
//! a version-`old` tree into a version-`old + 1` tree, add a test with a real old file, and
//! describe the change in docs/session-format.md. Files from [`TYPED_FROM`] on skip the JSON
//! tree entirely: the types read them as they are (a schema-2 session holds its tracks inline,
//! hundreds of MB for a corpus; a `Value` of it would be several times that).
//!
//! Schema 3 moved tracks and cached fits into per-clip files (`clip_data`). It needs no tree
//! step: the types read a schema-2 file's inline tracks and its session-wide `fit_cache`
//! (`Session::load` moves the entries into their clips), and the next save writes them to
//! files. The version bump is what keeps an older build from misreading a file reference.

use serde::Deserialize;
use serde_json::Value;

/// The schema this build reads and writes.
pub const CURRENT_SCHEMA: u32 = 3;

/// The oldest schema the session types read directly; older files are upgraded on the JSON
/// tree by [`STEPS`] up to it first.
pub const TYPED_FROM: u32 = 2;

/// The first schema whose clips refer to data files (`NAME.lipmap.d/`).
pub const DATA_FILES_FROM: u32 = 3;

/// One upgrade step: a tree at version `from` to a tree at `from + 1`.
pub type MigrationStep = fn(Value) -> Result<Value, String>;

/// Upgrade steps by the version they start from, ascending.
pub const STEPS: &[(u32, MigrationStep)] = &[(1, separate_head_map)];

/// Schema 2 gives a head that is another mesh than the model a map of its own
/// (`head_map`). A schema-1 file has one map, which its fits used as the model's: it stays
/// the model's map, and the head keeps sharing it, so the file means what it meant. The
/// version bump is what matters: a schema-1 build would drop a head map it does not know.
fn separate_head_map(tree: Value) -> Result<Value, String> {
    match tree {
        Value::Object(_) => Ok(tree),
        _ => Err("the session is not a JSON object".into()),
    }
}

/// What the top of a file says about its version.
#[derive(Clone, Debug, PartialEq)]
pub enum SchemaVersion {
    Missing,
    NotANumber(String),
    Version(u32),
}

/// Reads only `schema_version`; everything else is skipped without being built, so this
/// also finds JSON syntax errors (with serde_json's line and column) cheaply.
///
/// # Errors
/// The serde_json syntax error, when the text is not JSON.
pub fn peek_schema_version(text: &str) -> Result<SchemaVersion, serde_json::Error> {
    // Unknown keys are skipped by serde_json without building anything, so this costs a
    // fraction of the real parse; the version key may sit anywhere in a hand-edited file.
    #[derive(Deserialize)]
    struct Peek {
        #[serde(default)]
        schema_version: Option<Value>,
    }
    let peek: Peek = serde_json::from_str(text)?;
    Ok(match peek.schema_version {
        None => SchemaVersion::Missing,
        Some(v) => match v.as_u64().and_then(|n| u32::try_from(n).ok()) {
            Some(n) => SchemaVersion::Version(n),
            None => SchemaVersion::NotANumber(v.to_string()),
        },
    })
}

/// Upgrades `tree` from version `from` to `CURRENT_SCHEMA` with `steps`.
///
/// # Errors
/// A message naming the version that has no upgrade step, or the step's own error.
pub fn migrate(
    tree: Value,
    from: u32,
    steps: &[(u32, MigrationStep)],
    to: u32,
) -> Result<Value, String> {
    let mut tree = tree;
    let mut version = from;
    while version < to {
        let step = steps.iter().find(|(v, _)| *v == version).ok_or_else(|| {
            format!("no upgrade from schema version {version} (this build reads {to})")
        })?;
        tree = (step.1)(tree)
            .map_err(|e| format!("upgrading schema {version} to {}: {e}", version + 1))?;
        version += 1;
        if let Value::Object(map) = &mut tree {
            map.insert("schema_version".into(), Value::from(version));
        }
    }
    Ok(tree)
}

#[cfg(test)]
mod tests {
    use super::*;
    use serde_json::json;

    #[test]
    fn peeks_version_without_building_the_rest() {
        let v =
            peek_schema_version(r#"{"clips": [1, 2, {"a": null}], "schema_version": 7}"#).unwrap();
        assert_eq!(v, SchemaVersion::Version(7));
        assert_eq!(peek_schema_version(r#"{"clips": []}"#).unwrap(), SchemaVersion::Missing);
        assert!(matches!(
            peek_schema_version(r#"{"schema_version": "x"}"#).unwrap(),
            SchemaVersion::NotANumber(_)
        ));
        let err = peek_schema_version("{\n  \"schema_version\": 1,\n  oops\n}").unwrap_err();
        assert_eq!(err.line(), 3);
    }

    #[test]
    fn migration_chain_applies_each_step_in_order() {
        fn rename_frames(mut v: Value) -> Result<Value, String> {
            let m = v.as_object_mut().ok_or("not an object")?;
            let x = m.remove("images").ok_or("no `images`")?;
            m.insert("frames".into(), x);
            Ok(v)
        }
        fn add_clips(mut v: Value) -> Result<Value, String> {
            v.as_object_mut().ok_or("not an object")?.insert("clips".into(), json!([]));
            Ok(v)
        }
        let steps: &[(u32, MigrationStep)] = &[(0, rename_frames), (1, add_clips)];
        let out = migrate(json!({"schema_version": 0, "images": "a"}), 0, steps, 2).unwrap();
        assert_eq!(out, json!({"schema_version": 2, "frames": "a", "clips": []}));
        let err = migrate(json!({"schema_version": 0}), 0, steps, 2).unwrap_err();
        assert!(err.contains("upgrading schema 0 to 1") && err.contains("images"), "{err}");
        assert!(
            migrate(json!({}), 5, steps, 6)
                .unwrap_err()
                .contains("no upgrade from schema version 5")
        );
    }

    #[test]
    fn a_schema_1_session_loads_with_its_one_map_as_the_model_and_head_map() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("old.lipmap.json");
        // As a schema-1 build wrote it: a head, a model and one (labelled) map.
        let old = r#"{
  "schema_version": 1,
  "name": "old",
  "clips": [],
  "head_mesh": "head.obj",
  "model": {"path": "model.bin"},
  "landmark_map": {"file": "map.toml", "inline": {"30": 12, "36": 40}}
}"#;
        std::fs::write(&path, old).unwrap();
        let s = crate::session::Session::load(&path).unwrap();
        assert_eq!(s.schema_version, CURRENT_SCHEMA);
        assert_eq!(s.head_map, None);
        let inline = s.landmark_map.inline.clone().unwrap();
        assert_eq!(inline.into_iter().collect::<Vec<_>>(), vec![(30, 12), (36, 40)]);
        assert_eq!(s.landmark_map.file.as_deref(), Some(dir.path().join("map.toml").as_path()));
        use crate::session::MapRole;
        assert_eq!(s.map_of(MapRole::Head), s.map_of(MapRole::Model));
        s.save(&path).unwrap();
        let again = crate::session::Session::load(&path).unwrap();
        assert_eq!(again, s);
        assert!(std::fs::read_to_string(&path).unwrap().contains("\"schema_version\": 3"));
    }
}
