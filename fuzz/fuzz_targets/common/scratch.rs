//! A scratch folder for fuzz targets whose parser takes a path: one per target and process,
//! in /dev/shm where there is one (each run writes a file per input: memory, not disk).

use std::path::{Path, PathBuf};
use std::sync::OnceLock;

/// `lipmap-fuzz-TARGET-PID/` in /dev/shm (or the temp folder), made on first use.
pub fn scratch_dir(target: &str) -> &'static Path {
    static P: OnceLock<PathBuf> = OnceLock::new();
    P.get_or_init(|| {
        let base = if Path::new("/dev/shm").is_dir() {
            PathBuf::from("/dev/shm")
        } else {
            std::env::temp_dir()
        };
        let dir = base.join(format!("lipmap-fuzz-{target}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("scratch dir");
        dir
    })
}
