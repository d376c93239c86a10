//! Fuzzes the `start,end,phone` CSV parser: errors, never panics; what parses round-trips.
#![no_main]
use libfuzzer_sys::fuzz_target;
use lipmap::io::phones_csv::{format_phones_csv, parse_phones_csv};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    if let Ok(a) = parse_phones_csv(text, Path::new("fuzz.csv")) {
        let out = format_phones_csv(&a);
        assert_eq!(parse_phones_csv(&out, Path::new("out.csv")).expect("re-parse"), a);
    }
});
