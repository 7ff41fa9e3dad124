//! A control stream from the network, in pieces: the frame decoder never
//! panics, never holds more than its bound, and everything it yields has
//! passed validation (so it encodes again).
#![no_main]

use inertia_fuzz::drive_frames;
use inertia_protocol::control::{ClientControl, ServerControl};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // The first byte picks the size of the pieces the stream arrives in.
    let Some((&first, stream)) = data.split_first() else {
        return;
    };
    let chunk = usize::from(first) + 1;
    drive_frames::<ServerControl>(stream, chunk);
    drive_frames::<ClientControl>(stream, chunk);
});
