//! A control stream from the network, in pieces: the frame decoder never
//! panics, never holds more than its bound, and everything it yields has
//! passed validation (so it encodes again).
#![no_main]

use inertia_protocol::control::{
    encode_frame, ClientControl, ControlError, ControlMessage, FrameDecoder, ServerControl,
    MAX_DECODER_BUFFER,
};
use libfuzzer_sys::fuzz_target;

fn drive<T: ControlMessage>(data: &[u8], chunk: usize) {
    let mut decoder = FrameDecoder::new();
    for piece in data.chunks(chunk) {
        if decoder.push(piece).is_err() {
            return;
        }
        assert!(decoder.buffered() <= MAX_DECODER_BUFFER);
        loop {
            match decoder.next::<T>() {
                None => break,
                Some(Ok(msg)) => {
                    encode_frame(&msg).expect("a decoded message encodes");
                }
                Some(Err(ControlError::FrameTooLarge { .. })) => return,
                Some(Err(_)) => {}
            }
        }
    }
}

fuzz_target!(|data: &[u8]| {
    // The first byte picks the size of the pieces the stream arrives in.
    let Some((&first, stream)) = data.split_first() else {
        return;
    };
    let chunk = usize::from(first) + 1;
    drive::<ServerControl>(stream, chunk);
    drive::<ClientControl>(stream, chunk);
});
