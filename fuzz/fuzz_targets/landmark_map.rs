//! Fuzzes the eos TOML landmark-map reader: errors, never panics; what parses formats and
//! parses back to the same map.
#![no_main]
use libfuzzer_sys::fuzz_target;
use lipmap::io::landmark_map_toml::{format_landmark_map, parse_landmark_map};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    if let Ok(map) = parse_landmark_map(text, Path::new("fuzz.toml")) {
        let out = format_landmark_map(&map, &lipmap::landmarks::LandmarkNames::builtin());
        assert_eq!(parse_landmark_map(&out, Path::new("out.toml")).expect("re-parse"), map);
    }
});
