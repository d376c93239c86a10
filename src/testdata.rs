//! Locating the shared real-data folder (`../shared` beside the repository) for tests and
//! benchmarks; absent on a user's fresh clone, where callers skip with a printed notice.

use std::path::PathBuf;

/// `../shared/<rel>` relative to the crate root, if it exists; otherwise prints a skip
/// notice naming `rel` and returns `None`.
pub fn shared(rel: &str) -> Option<PathBuf> {
    let root = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("..").join("shared");
    let p = root.join(rel);
    if p.exists() {
        Some(p)
    } else {
        eprintln!("skipping: {} not found (shared test data is absent)", p.display());
        None
    }
}
