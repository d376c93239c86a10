//! Fuzzes lipmap's binary model reader: any bytes give a model or an error (never a panic or
//! a header-sized allocation); a decoded model encodes (f64) and decodes to itself.
#![no_main]
use libfuzzer_sys::fuzz_target;
use lipmap::io::model_file::{Precision, decode_model, encode_model};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    if let Ok(model) = decode_model(data, Path::new("fuzz.lmm")) {
        let bytes = encode_model(&model, Precision::F64);
        let back = decode_model(&bytes, Path::new("out.lmm")).expect("re-decode");
        assert_eq!(back, model);
    }
});
