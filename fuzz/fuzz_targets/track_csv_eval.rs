//! Fuzzes landmark CSV text through the reader `lipmap new` uses and the first steps of
//! `eval` (`workflow::untrusted::track_csv_through_eval`): a one-line error or a result,
//! never a panic, an abort or an allocation sized by a frame number in the text.
#![no_main]
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    if let Err(e) = lipmap::workflow::untrusted::track_csv_through_eval(text) {
        assert!(!e.contains('\n'), "a multi-line error: {e}");
    }
});
