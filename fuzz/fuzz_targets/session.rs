//! Fuzzes session loading (`Session::load` on a temp file: JSON, schema peek, migrations,
//! validation): errors, never panics; a session that loads saves and loads again.
#![no_main]
use libfuzzer_sys::fuzz_target;
use lipmap::session::Session;
use scratch::scratch_dir;

#[path = "common/scratch.rs"]
mod scratch;

fuzz_target!(|data: &[u8]| {
    let path = scratch_dir("session").join("fuzz.lipmap.json");
    std::fs::write(&path, data).expect("write scratch file");
    if let Ok(session) = Session::load(&path) {
        let bytes = session.to_json(&path).expect("a loaded session serialises");
        std::fs::write(&path, &bytes).expect("write scratch file");
        let back = Session::load(&path).expect("a saved session loads");
        assert_eq!(back.to_json(&path).expect("serialises"), bytes);
    }
});
