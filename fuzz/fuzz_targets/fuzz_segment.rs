//! A recording segment from disk (a file the server did not write, or one
//! damaged): the scan never panics, never reads past the bytes, and what
//! it reports is consistent. The first byte picks whether the frames'
//! checksums are made right first (to reach the record decoders) or left
//! as they come (to reach the damage and torn-tail handling).
#![no_main]

use inertia_server::record::scan_segment_bytes;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&mode, segment)) = data.split_first() else {
        return;
    };
    let mut segment = segment.to_vec();
    if mode & 1 == 1 {
        inertia_fuzz::reseal_frames(&mut segment);
    }
    let scan = scan_segment_bytes(&segment);
    assert_eq!(scan.file_len, segment.len() as u64);
    assert!(scan.good_len <= scan.file_len);
    match scan.damage {
        None => assert_eq!(scan.good_len, scan.file_len),
        Some((offset, _)) => assert_eq!(offset, scan.good_len),
    }
    assert!(!scan.torn_tail || scan.damage.is_some());
    assert_eq!(scan.records == 0, scan.first_tick.is_none());
});
