//! A recording segment from disk (a file the server did not write, or one
//! damaged): the scan never panics, never reads past the bytes, and what
//! it reports is consistent.
#![no_main]

use inertia_server::record::scan_segment_bytes;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let scan = scan_segment_bytes(data);
    assert_eq!(scan.file_len, data.len() as u64);
    assert!(scan.good_len <= scan.file_len);
    match scan.damage {
        None => assert_eq!(scan.good_len, scan.file_len),
        Some((offset, _)) => assert_eq!(offset, scan.good_len),
    }
    assert!(!scan.torn_tail || scan.damage.is_some());
    assert_eq!(scan.records == 0, scan.first_tick.is_none());
});
