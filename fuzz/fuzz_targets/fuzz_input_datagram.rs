//! Client input datagrams from the network: decoding never panics, the
//! format is canonical (what decodes encodes to the same bytes), the
//! sandbox game's input decoder is too (what it reads of a payload encodes
//! to the same bytes), and the server's input buffer hands sequences on
//! strictly in order.
#![no_main]

use inertia_protocol::input::{GameInput, InputBuffer, InputDatagram};
use inertia_sandbox::SandboxInput;
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    // Several datagrams, each prefixed by its length in one byte.
    let mut buffer = InputBuffer::new(32);
    let mut last: Option<u32> = None;
    let mut rest = data;
    while let Some((&len, tail)) = rest.split_first() {
        let len = usize::from(len).min(tail.len());
        let (datagram, tail) = tail.split_at(len);
        rest = tail;
        if let Ok(d) = InputDatagram::decode(datagram) {
            assert_eq!(d.encode().as_deref(), Ok(datagram), "not canonical");
            for input in &d.inputs {
                if let Ok(game) = SandboxInput::from_payload(&input.payload) {
                    assert_eq!(game.to_payload(), input.payload, "sandbox input not canonical");
                }
            }
            buffer.push_datagram(&d);
        }
        if let Some(input) = buffer.pop() {
            if let Some(prev) = last {
                let ahead = input.sequence.wrapping_sub(prev) as i32;
                assert!(ahead > 0, "sequence {} after {}", input.sequence, prev);
            }
            last = Some(input.sequence);
        }
        assert!(buffer.len() <= 32);
    }
});
