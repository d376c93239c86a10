//! Fuzzes the MakeHuman `.target` reader and the dense delta it builds: errors, never panics.
#![no_main]
use libfuzzer_sys::fuzz_target;
use lipmap::io::makehuman_target::{offsets_to_delta, parse_target};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let path = Path::new("fuzz.target");
    if let Ok(offsets) = parse_target(text, path) {
        assert!(offsets.iter().all(|o| o.delta.iter().all(|v| v.is_finite())));
        // A small base: most offsets fall outside it, which must be an error, not a panic.
        if let Ok(delta) = offsets_to_delta(&offsets, 16, path) {
            assert_eq!(delta.len(), 48);
        }
    }
});
