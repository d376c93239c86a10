//! Fuzzes the dlib shape predictor reader: any bytes give a predictor or an error, never a
//! panic or an allocation sized by an untrusted count; what parses runs its cascade on a
//! small image without panicking (every index it follows was checked by the reader).
#![no_main]
use libfuzzer_sys::fuzz_target;
use lipmap::track::{CascadeStart, FaceBox, GrayView, parse_shape_predictor, run_cascade};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    if let Ok(p) = parse_shape_predictor(data, Path::new("fuzz.dat")) {
        let pixels: Vec<u8> = (0..32 * 24).map(|i| (i * 37 % 251) as u8).collect();
        let img = GrayView { width: 32, height: 24, pixels: &pixels };
        let face = FaceBox { left: 4.0, top: 3.0, width: 20.0, height: 18.0 };
        let shape = run_cascade(&p, img, &face, &CascadeStart::default());
        assert_eq!(shape.len(), p.num_parts());
    }
});
