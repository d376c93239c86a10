//! Fuzzes the OpenCV Haar cascade reader: any text gives a cascade or a one-line error,
//! never a panic; what parses scans a small image without panicking or looping.
#![no_main]
use libfuzzer_sys::fuzz_target;
use lipmap::track::{DetectOptions, GrayView, detect_faces, parse_haar_cascade};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    match parse_haar_cascade(text, Path::new("fuzz.xml")) {
        Ok(c) => {
            let pixels: Vec<u8> = (0..48 * 40).map(|i| (i * 37 % 251) as u8).collect();
            let img = GrayView { width: 48, height: 40, pixels: &pixels };
            let _ = detect_faces(&c, img, &DetectOptions { min_neighbors: 0, ..Default::default() });
        }
        Err(e) => assert!(!e.to_string().contains('\n')),
    }
});
