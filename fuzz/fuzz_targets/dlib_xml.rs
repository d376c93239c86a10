//! Fuzzes the dlib imglab XML parser: errors, never panics; what parses writes and re-reads.
#![no_main]
use libfuzzer_sys::fuzz_target;
use lipmap::io::dlib_xml::{format_dlib_xml, parse_dlib_xml};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    if let Ok(track) = parse_dlib_xml(text, Path::new("fuzz.xml")) {
        let out = format_dlib_xml(&track);
        let back = parse_dlib_xml(&out, Path::new("out.xml")).expect("re-parse");
        assert_eq!(back.len(), track.len());
    }
});
