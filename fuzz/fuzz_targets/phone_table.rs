//! Fuzzes the phone inventory: a table (`phone,ipa,labels` CSV) parses or errors, never
//! panics; every label, looked up in the parsed table and in the built-in one, gets a key
//! without panicking, and a label the table names keeps that phone's key.
#![no_main]
use libfuzzer_sys::fuzz_target;
use lipmap::alignment::PhoneInventory;

fuzz_target!(|data: &[u8]| {
    let Ok(text) = std::str::from_utf8(data) else { return };
    // Before the first NUL: a table; after it: labels, one a line.
    let (table, labels) = text.split_once('\0').unwrap_or((text, text));
    let builtin = PhoneInventory::default();
    let parsed = PhoneInventory::from_csv_str(table).ok();
    for label in labels.lines() {
        let _ = builtin.key_of(label);
        let _ = builtin.is_silence(label);
        if let Some(inv) = &parsed {
            let key = inv.key_of(label);
            if let Some(p) = inv.phone_of(label) {
                assert_eq!(p.key, key);
            }
        }
    }
    if let Some(inv) = &parsed {
        for p in inv.phones() {
            assert_eq!(inv.key_of(&p.key), p.key, "a key is its own key");
        }
    }
});
