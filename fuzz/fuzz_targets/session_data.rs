//! Fuzzes the readers of a session's data files (`NAME.lipmap.d/*.track`, `*.fits`), through
//! a temp file since both take a path: errors naming the file, never panics, and what reads
//! back keeps the rules the readers promise.
#![no_main]
use libfuzzer_sys::fuzz_target;
use lipmap::landmarks::N_LANDMARKS;
use lipmap::session::{fits_file::read_fits, track_file::read_track};
use scratch::scratch_dir;

#[path = "common/scratch.rs"]
mod scratch;

fuzz_target!(|data: &[u8]| {
    let Some((&which, rest)) = data.split_first() else { return };
    let Some((&count, bytes)) = rest.split_first() else { return };
    let count = usize::from(count);
    let file = scratch_dir("session_data").join("fuzz.data");
    std::fs::write(&file, bytes).expect("write scratch file");
    if which & 1 == 0 {
        if let Ok(track) = read_track(&file, count) {
            assert_eq!(track.frames.len(), count);
            assert!(track.frames.windows(2).all(|w| w[0].frame < w[1].frame));
            assert!(track.frames.iter().all(|f| f.points.len() == N_LANDMARKS));
        }
    } else if let Ok(entries) = read_fits(&file, count) {
        assert_eq!(entries.len(), count);
    }
});
