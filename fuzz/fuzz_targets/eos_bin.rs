//! Fuzzes eos's cereal binary readers (shape model and blendshapes): any bytes give a model
//! or an error, never a panic or an allocation sized by an untrusted count.
#![no_main]
use libfuzzer_sys::fuzz_target;
use lipmap::io::eos_bin::{parse_eos_blendshapes, parse_eos_model};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    // The first byte picks the reader so one corpus exercises both.
    let Some((&which, bytes)) = data.split_first() else { return };
    if which & 1 == 0 {
        if let Ok(model) = parse_eos_model(bytes, Path::new("fuzz.bin")) {
            let n = model.shape.mean.len();
            assert_eq!(model.shape.basis.nrows(), n);
        }
    } else if let Ok(e) = parse_eos_blendshapes(bytes, Path::new("fuzz.bin")) {
        let _ = e;
    }
});
