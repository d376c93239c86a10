//! Fuzzes the NumPy model readers: one `.npy` from bytes, and a whole `.npz` archive (through
//! a temp file, since `read_npz` takes a path): errors, never panics.
#![no_main]
use libfuzzer_sys::fuzz_target;
use lipmap::io::npy_model::{parse_npy, read_npz};
use scratch::scratch_dir;
use std::path::Path;

#[path = "common/scratch.rs"]
mod scratch;

fuzz_target!(|data: &[u8]| {
    let Some((&which, bytes)) = data.split_first() else { return };
    if which & 1 == 0 {
        if let Ok(a) = parse_npy(bytes, Path::new("fuzz.npy")) {
            assert_eq!(a.shape.iter().product::<usize>(), a.data.len());
        }
    } else {
        let file = scratch_dir("npy").join("fuzz.npz");
        std::fs::write(&file, bytes).expect("write scratch file");
        if let Ok(model) = read_npz(&file) {
            assert_eq!(model.shape.basis.nrows(), model.shape.mean.len());
        }
    }
});
