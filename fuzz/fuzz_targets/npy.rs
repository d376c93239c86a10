//! Fuzzes the NumPy model readers: one `.npy` from bytes, and a whole `.npz` archive (through
//! a temp file, since `read_npz` takes a path): errors, never panics.
#![no_main]
use libfuzzer_sys::fuzz_target;
use lipmap::io::npy_model::{parse_npy, read_npz};
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

fn scratch() -> &'static PathBuf {
    static P: OnceLock<PathBuf> = OnceLock::new();
    P.get_or_init(|| {
        let dir = if Path::new("/dev/shm").is_dir() {
            PathBuf::from("/dev/shm")
        } else {
            std::env::temp_dir()
        };
        dir.join(format!("lipmap-fuzz-{}.npz", std::process::id()))
    })
}

fuzz_target!(|data: &[u8]| {
    let Some((&which, bytes)) = data.split_first() else { return };
    if which & 1 == 0 {
        if let Ok(a) = parse_npy(bytes, Path::new("fuzz.npy")) {
            assert_eq!(a.shape.iter().product::<usize>(), a.data.len());
        }
    } else {
        std::fs::write(scratch(), bytes).expect("write scratch file");
        if let Ok(model) = read_npz(scratch()) {
            assert_eq!(model.shape.basis.nrows(), model.shape.mean.len());
        }
    }
});
