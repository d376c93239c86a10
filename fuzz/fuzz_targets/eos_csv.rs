//! Fuzzes the eos landmark CSV parser (`frame,ibug_id,u,v`): errors, never panics; what
//! parses formats and parses back to the same track.
#![no_main]
use libfuzzer_sys::fuzz_target;
use lipmap::io::eos_csv::{format_eos_csv, parse_eos_csv};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    if let Ok(track) = parse_eos_csv(text, Path::new("fuzz.csv")) {
        let out = format_eos_csv(&track);
        assert_eq!(parse_eos_csv(&out, Path::new("out.csv")).expect("re-parse"), track);
    }
});
