//! Fuzzes the OpenFace CSV parser: errors, never panics; what parses (up to two frames)
//! writes and re-reads.
#![no_main]
use libfuzzer_sys::fuzz_target;
use lipmap::io::openface::{format_openface_csv, parse_openface_csv};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    // Writing expands every row to all 136 coordinate columns; re-reading long tracks would
    // spend the run on the csv crate, so the round trip is checked on short ones only.
    if let Ok(track) = parse_openface_csv(text, Path::new("fuzz.csv"))
        && track.len() <= 2
    {
        let out = format_openface_csv(&track);
        let back = parse_openface_csv(&out, Path::new("out.csv")).expect("re-parse");
        assert_eq!(back.len(), track.len());
    }
});
