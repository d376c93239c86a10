//! Fuzzes the HTK `.lab` and Festival xlabel parsers: errors, never panics; writing what
//! parsed never panics either.
#![no_main]
use libfuzzer_sys::fuzz_target;
use lipmap::io::htk_lab::{format_htk_lab, format_xlabel, parse_htk_lab, parse_lab, parse_xlabel};
use std::path::Path;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    let path = Path::new("fuzz.lab");
    for a in [parse_lab(text, path), parse_htk_lab(text, path), parse_xlabel(text, path)]
        .into_iter()
        .flatten()
    {
        let _ = parse_lab(&format_htk_lab(&a), path);
        let x = parse_lab(&format_xlabel(&a), path).expect("xlabel re-parse");
        assert_eq!(x.phones.len(), a.phones.len());
    }
});
