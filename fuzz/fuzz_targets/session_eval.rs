//! Fuzzes a session file through loading and the first steps of `eval`
//! (`workflow::untrusted::session_through_eval`): a one-line error or a result, never a
//! panic, an abort or an allocation sized by a number in the file.
#![no_main]
use libfuzzer_sys::fuzz_target;
use std::path::PathBuf;
use std::sync::OnceLock;

fn scratch_file() -> &'static PathBuf {
    static P: OnceLock<PathBuf> = OnceLock::new();
    P.get_or_init(|| {
        let dir = std::env::temp_dir().join(format!("lipmap-fuzz-eval-{}", std::process::id()));
        std::fs::create_dir_all(&dir).expect("scratch dir");
        dir.join("fuzz.lipmap.json")
    })
}

fuzz_target!(|data: &[u8]| {
    std::fs::write(scratch_file(), data).expect("write scratch file");
    if let Err(e) = lipmap::workflow::untrusted::session_through_eval(scratch_file()) {
        assert!(!e.contains('\n'), "a multi-line error: {e}");
    }
});
