//! Game messages from the network: a message datagram, and the sandbox's
//! own message decoders (its players' requests, its rules' events), never
//! panic, and what decodes encodes to the same bytes (each decoder is
//! canonical). The first byte picks the decoder; the rest is the input.
#![no_main]

use inertia_protocol::message::{GameMessage, MessageDatagram};
use inertia_sandbox::{SandboxEvent, SandboxRequest};
use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&which, bytes)) = data.split_first() else {
        return;
    };
    match which % 3 {
        0 => {
            if let Ok(message) = MessageDatagram::decode(bytes) {
                assert_eq!(MessageDatagram::encode(message).as_deref(), Ok(bytes));
            }
        }
        1 => {
            if let Ok(request) = SandboxRequest::decode(bytes) {
                assert_eq!(request.to_bytes(), bytes, "request not canonical");
            }
        }
        _ => {
            if let Ok(event) = SandboxEvent::decode(bytes) {
                assert_eq!(event.to_bytes(), bytes, "event not canonical");
            }
        }
    }
});
