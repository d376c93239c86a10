//! Fuzzes the synthesized-motion CSV parser (`frame,vertex,x,y,z`): errors, never panics;
//! what parses is rectangular and round-trips.
#![no_main]
use libfuzzer_sys::fuzz_target;
use lipmap::io::motion_csv::{format_motion_csv, parse_motion_csv};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    if let Ok(m) = parse_motion_csv(text, Path::new("fuzz.csv")) {
        assert!(!m.frames.is_empty());
        assert!(m.frames.iter().all(|f| f.len() == m.vertices.len()));
        let out = format_motion_csv(&m);
        assert_eq!(parse_motion_csv(&out, Path::new("out.csv")).expect("re-parse"), m);
    }
});
