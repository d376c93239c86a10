//! Fuzzes the iBUG `.pts` parser: any text must give points or an error, never a panic;
//! what parses must format and parse again.
#![no_main]
use libfuzzer_sys::fuzz_target;
use lipmap::io::pts::{format_pts, parse_pts};
use lipmap::landmarks::track::FrameLandmarks;
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    if let Ok(points) = parse_pts(text, Path::new("fuzz.pts")) {
        let out = format_pts(&FrameLandmarks::new(0, points));
        assert!(parse_pts(&out, Path::new("out.pts")).is_ok(), "re-parse failed:\n{out}");
    }
});
