//! A journal payload from a recording: decoding never panics, and what
//! decodes encodes to bytes that decode to the same entries.
#![no_main]

use inertia_server::replay::journal;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((tick, bytes)) = data.split_first_chunk::<8>() else {
        return;
    };
    let tick = u64::from_le_bytes(*tick);
    let Ok(entries) = journal::decode(tick, bytes) else {
        return;
    };
    let encoded = journal::encode(tick, &entries);
    let again = journal::decode(tick, &encoded).expect("an encoded journal decodes");
    assert_eq!(journal::encode(tick, &again), encoded);
});
