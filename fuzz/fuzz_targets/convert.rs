//! Fuzzes conversion: whatever lipmap CSV (the most expressive format) parses must write in
//! every other landmark format and read back with the same number of frames.
#![no_main]
use libfuzzer_sys::fuzz_target;
use lipmap::io::landmark_format::{LandmarkFormat, parse_track};
use lipmap::io::{dlib_xml, openface, pts, track_csv};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let path = Path::new("fuzz.csv");
    let Ok(track) = track_csv::parse_track_csv(text, path) else { return };
    let outputs = [
        (openface::format_openface_csv(&track), LandmarkFormat::OpenFace),
        (dlib_xml::format_dlib_xml(&track), LandmarkFormat::DlibXml),
        (track_csv::format_track_csv(&track), LandmarkFormat::LipmapCsv),
    ];
    for (out, format) in outputs {
        // OpenFace cannot hold frame usize::MAX (1-based): that one may fail, nothing panics.
        if let Ok(back) = parse_track(&out, path, format) {
            assert_eq!(back.len(), track.len(), "{format}");
        }
    }
    for f in &track.frames {
        let out = pts::format_pts(f);
        assert!(pts::parse_pts(&out, path).is_ok(), "pts:\n{out}");
    }
});
