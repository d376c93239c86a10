//! Fuzzes the TextGrid reader (raw bytes: every encoding path) and tier choice; a chosen
//! tier must write and read back to the same phones.
#![no_main]
use libfuzzer_sys::fuzz_target;
use lipmap::io::textgrid::{TierChoice, format_textgrid, parse_textgrid};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let path = Path::new("fuzz.TextGrid");
    if let Ok(grid) = parse_textgrid(data, path) {
        for choice in [None, Some(TierChoice::Index(1)), Some(TierChoice::Name("phones".into()))] {
            if let Ok(a) = grid.alignment(choice.as_ref(), path) {
                let out = format_textgrid(&a, "phones");
                let back = parse_textgrid(out.as_bytes(), path).expect("re-parse");
                assert_eq!(back.alignment(None, path).expect("tier"), a);
            }
        }
    }
});
