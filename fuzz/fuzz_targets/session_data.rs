//! Fuzzes the readers of a session's data files (`NAME.lipmap.d/*.track`, `*.fits`), through
//! a temp file since both take a path: errors naming the file, never panics, and what reads
//! back keeps the rules the readers promise.
#![no_main]
use libfuzzer_sys::fuzz_target;
use lipmap::landmarks::N_LANDMARKS;
use lipmap::session::{fits_file::read_fits, track_file::read_track};
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
        dir.join(format!("lipmap-fuzz-{}.data", std::process::id()))
    })
}

fuzz_target!(|data: &[u8]| {
    let Some((&which, rest)) = data.split_first() else { return };
    let Some((&count, bytes)) = rest.split_first() else { return };
    let count = usize::from(count);
    std::fs::write(scratch(), bytes).expect("write scratch file");
    if which & 1 == 0 {
        if let Ok(track) = read_track(scratch(), count) {
            assert_eq!(track.frames.len(), count);
            assert!(track.frames.windows(2).all(|w| w[0].frame < w[1].frame));
            assert!(track.frames.iter().all(|f| f.points.len() == N_LANDMARKS));
        }
    } else if let Ok(entries) = read_fits(scratch(), count) {
        assert_eq!(entries.len(), count);
    }
});
