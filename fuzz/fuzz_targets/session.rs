//! Fuzzes session loading (`Session::load` on a temp file: JSON, schema peek, migrations,
//! validation): errors, never panics; a session that loads saves and loads again.
#![no_main]
use libfuzzer_sys::fuzz_target;
use lipmap::session::Session;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

fn scratch_dir() -> &'static PathBuf {
    static P: OnceLock<PathBuf> = OnceLock::new();
    P.get_or_init(|| {
        let base = if Path::new("/dev/shm").is_dir() {
            PathBuf::from("/dev/shm")
        } else {
            std::env::temp_dir()
        };
        let dir = base.join(format!("lipmap-fuzz-session-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("scratch dir");
        dir
    })
}

fuzz_target!(|data: &[u8]| {
    let path = scratch_dir().join("fuzz.lipmap.json");
    std::fs::write(&path, data).expect("write scratch file");
    if let Ok(session) = Session::load(&path) {
        let bytes = session.to_json(&path).expect("a loaded session serialises");
        std::fs::write(&path, &bytes).expect("write scratch file");
        let back = Session::load(&path).expect("a saved session loads");
        assert_eq!(back.to_json(&path).expect("serialises"), bytes);
    }
});
