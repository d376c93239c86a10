//! Fuzzes the eos landmark-map readers, TOML and JSON (`landmarks_and_contours.json`):
//! errors, never panics; what parses formats (as TOML) and parses back to the same map.
#![no_main]
use libfuzzer_sys::fuzz_target;
use lipmap::io::landmark_map_toml::{
    format_landmark_map, parse_landmark_map, parse_landmark_map_json,
};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let toml = parse_landmark_map(text, Path::new("fuzz.toml"));
    let json = parse_landmark_map_json(text, Path::new("fuzz.json"));
    for map in [toml, json].into_iter().flatten() {
        let out = format_landmark_map(&map, &lipmap::landmarks::LandmarkNames::builtin());
        assert_eq!(parse_landmark_map(&out, Path::new("out.toml")).expect("re-parse"), map);
    }
});
