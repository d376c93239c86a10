//! Fuzzes a session file through loading and the first steps of `eval`
//! (`workflow::untrusted::session_through_eval`): a one-line error or a result, never a
//! panic, an abort or an allocation sized by a number in the file.
#![no_main]
use libfuzzer_sys::fuzz_target;
use scratch::scratch_dir;

#[path = "common/scratch.rs"]
mod scratch;

fuzz_target!(|data: &[u8]| {
    let file = scratch_dir("eval").join("fuzz.lipmap.json");
    std::fs::write(&file, data).expect("write scratch file");
    if let Err(e) = lipmap::workflow::untrusted::session_through_eval(&file) {
        assert!(!e.contains('\n'), "a multi-line error: {e}");
    }
});
