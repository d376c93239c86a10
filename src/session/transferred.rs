//! Heads the session's motion has been transferred onto (`lipmap transfer`): the mesh, its
//! landmark map and the interpolation, so `eval` and the TUI can redo the transfer. The
//! transfer itself is recomputed from these (setup takes well under a second), never stored.

use super::store::rel_path;
use serde::{Deserialize, Serialize};
use std::path::PathBuf;

/// One transferred head.
#[derive(Clone, Debug, PartialEq, Eq, Serialize, Deserialize)]
pub struct TransferredHead {
    /// Display name (the mesh's file stem, made unique within the session).
    pub name: String,
    /// The head's OBJ.
    #[serde(with = "rel_path")]
    pub mesh: PathBuf,
    /// Its landmark map (TOML or eos `.txt`).
    #[serde(with = "rel_path")]
    pub mapping: PathBuf,
    /// `biharmonic` or `barycentric`.
    pub mode: String,
}
