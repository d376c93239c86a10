//! Fuzzes format detection and dispatch for alignments and landmarks: the first byte picks
//! a file name (so every extension path is taken), the rest is the content.
#![no_main]
use libfuzzer_sys::fuzz_target;
use lipmap::io::alignment_format::parse_alignment;
use lipmap::io::landmark_format::{detect_text, parse_track};
use std::path::Path;

const NAMES: [&str; 6] = ["a.TextGrid", "a.lab", "a.csv", "a.txt", "a.seg", "a"];

fuzz_target!(|data: &[u8]| {
    let Some((&pick, body)) = data.split_first() else { return };
    let path = Path::new(NAMES[pick as usize % NAMES.len()]);
    let _ = parse_alignment(body, path, None);
    if let Ok(text) = std::str::from_utf8(body)
        && let Some(format) = detect_text(text)
    {
        let _ = parse_track(text, path, format);
    }
});
