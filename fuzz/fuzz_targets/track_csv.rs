//! Fuzzes the lipmap CSV parser: errors, never panics; what parses round-trips exactly.
#![no_main]
use libfuzzer_sys::fuzz_target;
use lipmap::io::track_csv::{format_track_csv, parse_track_csv};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    if let Ok(track) = parse_track_csv(text, Path::new("fuzz.csv")) {
        let out = format_track_csv(&track);
        assert_eq!(parse_track_csv(&out, Path::new("out.csv")).expect("re-parse"), track);
    }
});
