//! An admin stream from the network, in pieces: the frame decoder never
//! panics on any of the admin messages, never holds more than its bound,
//! and everything it yields has passed validation (so it encodes again).
#![no_main]

use inertia_fuzz::drive_frames;
use inertia_protocol::admin::{AdminCall, AdminHandshake, AdminHello, AdminReply};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // The first byte picks the size of the pieces the stream arrives in.
    let Some((&first, stream)) = data.split_first() else {
        return;
    };
    let chunk = usize::from(first) + 1;
    drive_frames::<AdminHello>(stream, chunk);
    drive_frames::<AdminHandshake>(stream, chunk);
    drive_frames::<AdminCall>(stream, chunk);
    drive_frames::<AdminReply>(stream, chunk);
});
