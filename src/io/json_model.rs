//! The header of the JSON model files lipmap writes (a speech model, a quality model): a
//! `format` naming what the file is and a `version` of its layout, checked before anything
//! else is read, so a file of another kind or from another lipmap is refused with one line
//! that says what it is not and how to make one.
//!
//! Start with [`read_json_model`]; [`SPEECH_MODEL`] and [`QUALITY_MODEL`] are the two kinds.

use super::error::{FormatError, Result};
use super::input::read_input;
use std::path::Path;

/// One kind of JSON model file.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct JsonModelKind {
    /// The `format` value that names the kind.
    pub format: &'static str,
    /// The layout version this lipmap reads and writes.
    pub version: u32,
    /// What users call it, e.g. `speech model`.
    pub what: &'static str,
    /// The command that makes one, for the hint.
    pub made_by: &'static str,
}

/// A `speech train` model.
pub const SPEECH_MODEL: JsonModelKind = JsonModelKind {
    format: "lipmap speech model",
    // 2: per-recording normalised audio features, speech activity, the reference face and
    // the held-out estimate. 3: the training clips' visual covariance (speaker adaptation).
    version: 3,
    what: "speech model",
    made_by: "lipmap speech train",
};

/// A `saqp train` quality model.
pub const QUALITY_MODEL: JsonModelKind = JsonModelKind {
    format: "lipmap saqp model",
    // 2: the predictor sees E and the context coverage, keeps a GP or a line, and records
    // its held-out skill.
    version: 2,
    what: "quality model",
    made_by: "lipmap saqp train",
};

/// Reads the JSON model file at `path` (through [`read_input`], so with its size cap and
/// refusals) and checks its header against `kind`; returns the whole document for the
/// caller to deserialise and validate.
///
/// # Errors
/// One line naming the file: unreadable, not JSON, not a file of this kind (no matching
/// `format`), another version.
pub fn read_json_model(path: &Path, kind: &JsonModelKind) -> Result<serde_json::Value> {
    let what = kind.what;
    let bytes = read_input(path)?;
    let doc: serde_json::Value = serde_json::from_slice(&bytes)
        .map_err(|e| FormatError::whole(path, format!("not a {what} file: {e}")))?;
    if doc.get("format").and_then(|f| f.as_str()) != Some(kind.format) {
        return Err(FormatError::whole(
            path,
            format!(
                "not a {what} file (no `format: \"{}\"`); make one with `{}`",
                kind.format, kind.made_by
            ),
        ));
    }
    let version = doc.get("version").and_then(serde_json::Value::as_u64);
    if version != Some(u64::from(kind.version)) {
        return Err(FormatError::whole(
            path,
            format!(
                "{what} version {} is not the version {} this lipmap reads{}",
                version.map_or_else(|| "(missing)".to_string(), |v| v.to_string()),
                kind.version,
                // An older model holds less than this lipmap needs: only retraining makes it.
                if version.is_some_and(|v| v < u64::from(kind.version)) {
                    format!("; make a new one with `{}`", kind.made_by)
                } else {
                    String::new()
                }
            ),
        ));
    }
    Ok(doc)
}

/// Whether `head` (the start of a JSON file) names `kind`'s format: how a file is told to be
/// a model of that kind without reading it whole.
pub fn names_format(head: &str, kind: &JsonModelKind) -> bool {
    head.contains(&format!("\"{}\"", kind.format))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_header_is_checked_before_the_rest() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("m.json");
        let v = SPEECH_MODEL.version;
        std::fs::write(&p, format!(r#"{{"format":"lipmap speech model","version":{v},"x":2}}"#))
            .unwrap();
        assert_eq!(read_json_model(&p, &SPEECH_MODEL).unwrap()["x"], 2);
        let e = read_json_model(&p, &QUALITY_MODEL).unwrap_err().to_string();
        assert!(e.ends_with("not a quality model file (no `format: \"lipmap saqp model\"`); make one with `lipmap saqp train`"), "{e}");
        std::fs::write(&p, r#"{"format":"lipmap speech model"}"#).unwrap();
        let e = read_json_model(&p, &SPEECH_MODEL).unwrap_err().to_string();
        assert!(
            e.ends_with(&format!(
                "speech model version (missing) is not the version {v} this lipmap reads"
            )),
            "{e}"
        );
        std::fs::write(&p, r#"{"format":"lipmap saqp model","version":1}"#).unwrap();
        let e = read_json_model(&p, &QUALITY_MODEL).unwrap_err().to_string();
        assert!(
            e.ends_with(
                "is not the version 2 this lipmap reads; make a new one with `lipmap saqp train`"
            ),
            "{e}"
        );
        std::fs::write(&p, "[").unwrap();
        let e = read_json_model(&p, &SPEECH_MODEL).unwrap_err().to_string();
        assert!(e.starts_with(&format!("{}: not a speech model file: ", p.display())), "{e}");
        assert!(names_format(r#"{"format": "lipmap saqp model""#, &QUALITY_MODEL));
    }
}
