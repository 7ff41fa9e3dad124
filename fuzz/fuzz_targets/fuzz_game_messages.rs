//! Game messages and inputs from the network: a message datagram, the
//! sandbox's own message decoders (its players' requests, its rules'
//! events) and football's (its players' asks, its rules' tells, its
//! input) never panic, and what decodes encodes to the same bytes (each
//! decoder is canonical). The first byte picks the decoder; the rest is
//! the input.
#![no_main]

use inertia_football::{Ask, Play, Tell};
use inertia_protocol::input::{GameInput, InputPayload};
use inertia_protocol::message::{GameMessage, MessageDatagram};
use inertia_sandbox::{SandboxEvent, SandboxRequest};
use libfuzzer_sys::fuzz_target;

/// Asserts `T`'s decoder is canonical on `bytes`.
fn canonical<T: GameMessage>(bytes: &[u8], what: &str) {
    if let Ok(m) = T::decode(bytes) {
        assert_eq!(m.to_bytes(), bytes, "{what} not canonical");
    }
}

fuzz_target!(|data: &[u8]| {
    let Some((&which, bytes)) = data.split_first() else {
        return;
    };
    match which % 6 {
        0 => {
            if let Ok(message) = MessageDatagram::decode(bytes) {
                assert_eq!(MessageDatagram::encode(message).as_deref(), Ok(bytes));
            }
        }
        1 => canonical::<SandboxRequest>(bytes, "a sandbox request"),
        2 => canonical::<SandboxEvent>(bytes, "a sandbox event"),
        3 => canonical::<Ask>(bytes, "a football ask"),
        4 => canonical::<Tell>(bytes, "a football tell"),
        _ => {
            // An input of any size: the wrong sizes are refused before the
            // game's decoder sees them.
            if let Ok(payload) = InputPayload::new(bytes) {
                if let Ok(play) = Play::from_payload(&payload) {
                    assert_eq!(play.to_payload(), payload, "a football play not canonical");
                }
            }
        }
    }
});
