//! Golden vectors of the client's input datagram
//! (`tests/vectors/inputs.json`): datagrams the Rust encoder writes for
//! acknowledgements and inputs of every form the layout has (no ack; an
//! ack with its bits; one input; an empty payload and the largest; eight,
//! with sequence and tick steps of one and of more, backwards ticks,
//! payloads repeated and changed; views behind the tick of none, one
//! varint group and two, rounded, capped, ahead of the tick and NaN
//! (written as `null`)). Payloads are hex. The
//! browser client's encoder (`web/src/input.ts`) must write
//! the same bytes from the same fields.
//!
//! Ticks are decimal text (64-bit). A change to the layout that means to
//! change the datagrams rewrites the file with
//! `INERTIA_WRITE_VECTORS=1 cargo test -p inertia-protocol --test integration input_vectors::`.

use inertia_protocol::input::{InputPayload, MAX_INPUT_BYTES};
use inertia_protocol::{InputDatagram, PlayerInput};
use serde_json::{json, Value};

use crate::support;
use support::check_vectors;

const FILE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/vectors/inputs.json");

fn input(sequence: u32, tick: u64, payload: &[u8]) -> PlayerInput {
    PlayerInput {
        sequence,
        tick,
        payload: InputPayload::new(payload).expect("a payload in bounds"),
        view_behind: 0.0,
    }
}

/// `input` seen `view_behind` ticks behind its tick.
fn seen(input: PlayerInput, view_behind: f32) -> PlayerInput {
    PlayerInput {
        view_behind,
        ..input
    }
}

fn datagrams() -> Vec<(&'static str, InputDatagram)> {
    let eight: Vec<PlayerInput> = (0..8u32)
        .map(|k| {
            // Sequences step by one and then by more; ticks by one, by
            // none, by more and backwards.
            let sequence = 1_000_000 - k * k;
            let tick = [
                90_000u64, 89_999, 89_999, 89_990, 89_991, 89_000, 88_999, 70_000,
            ][k as usize];
            // Views of none, one varint group and two, rounded to the
            // nearest sixteenth, past the cap, ahead of the tick, NaN.
            let view = [0.0, 7.9375, 8.0, 3.03, 300.0, -2.0, f32::NAN, 12.25][k as usize];
            // Payloads repeated (k = 1, 2 and 6, 7) and changed.
            let b = [0u8, 0, 0, 3, 4, 250, 6, 6][k as usize];
            seen(
                input(sequence, tick, &[b, 0x7f, b ^ 0x55, 0x10, 0x02]),
                view,
            )
        })
        .collect();
    vec![
        ("nothing yet", InputDatagram::default()),
        (
            "an ack alone",
            InputDatagram {
                ack: Some(65_535),
                ack_bits: 0b1011,
                inputs: vec![],
            },
        ),
        (
            "one input, no ack",
            InputDatagram {
                ack: None,
                ack_bits: 0,
                inputs: vec![input(7, 123, &[0xfe, 0x00, 0x15, 0x18, 0x01])],
            },
        ),
        (
            "one input far in",
            InputDatagram {
                ack: Some(12),
                ack_bits: u32::MAX,
                inputs: vec![seen(
                    input(u32::MAX, (1 << 40) + 3, &[0x7f, 0xbf, 0, 0, 0]),
                    15.5,
                )],
            },
        ),
        (
            "a game without input bytes",
            InputDatagram {
                ack: None,
                ack_bits: 0,
                inputs: vec![input(3, 9, &[]), input(2, 8, &[])],
            },
        ),
        (
            "the largest payloads",
            InputDatagram {
                ack: Some(1),
                ack_bits: 0,
                inputs: (0..3u8)
                    .map(|k| {
                        let bytes: Vec<u8> = (0..MAX_INPUT_BYTES as u8).map(|b| b ^ k).collect();
                        input(50 - u32::from(k), 500 - u64::from(k), &bytes)
                    })
                    .collect(),
            },
        ),
        (
            "eight inputs",
            InputDatagram {
                ack: Some(300),
                ack_bits: 0x8000_0001,
                inputs: eight,
            },
        ),
    ]
}

fn vectors() -> Value {
    let list: Vec<Value> = datagrams()
        .into_iter()
        .map(|(name, d)| {
            let bytes = d.encode().expect("a valid datagram");
            assert_eq!(
                InputDatagram::decode(&bytes)
                    .expect("decodes")
                    .encode()
                    .unwrap(),
                bytes,
                "{name}: canonical"
            );
            let inputs: Vec<Value> = d
                .inputs
                .iter()
                .map(|i| {
                    json!({
                        "sequence": i.sequence,
                        "tick": i.tick.to_string(),
                        "payload": i.payload.as_bytes().iter().map(|b| format!("{b:02x}")).collect::<String>(),
                        // NaN has no JSON: written as null.
                        "view_behind": (!i.view_behind.is_nan()).then_some(i.view_behind),
                    })
                })
                .collect();
            json!({
                "name": name,
                "bytes": bytes.iter().map(|b| format!("{b:02x}")).collect::<String>(),
                "ack": d.ack,
                "ack_bits": d.ack_bits,
                "inputs": inputs,
            })
        })
        .collect();
    json!({ "datagrams": list })
}

#[test]
fn input_vectors_are_what_the_encoder_writes() {
    check_vectors(FILE, &vectors(), "inputs");
}
