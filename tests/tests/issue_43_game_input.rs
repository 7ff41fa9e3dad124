//! A game's input travels as the game's bytes: a client whose inputs are
//! of another size, or whose bytes the game's decoder refuses, is refused
//! input by input, counted per client and reason in `/metrics`, and keeps
//! its snapshots; its series go when it leaves; the size the welcome
//! announced is the one the SDK checks before sending.

use std::time::{Duration, Instant};

use inertia_client::{Client, ClientError};
use inertia_protocol::input::{GameInput, InputDatagram, InputPayload};
use inertia_protocol::PlayerInput;
use inertia_sandbox::{SandboxInput, SANDBOX_INPUT_BYTES};
use inertia_tests::server::{start_server, test_config, token};

/// A datagram of one input for `tick` carrying `payload`.
fn datagram(sequence: u32, tick: u64, payload: &[u8]) -> Vec<u8> {
    InputDatagram {
        ack: None,
        ack_bits: 0,
        inputs: vec![PlayerInput {
            sequence,
            tick,
            payload: InputPayload::new(payload).unwrap(),
            view_behind: 0.0,
        }],
    }
    .encode()
    .unwrap()
}

async fn until(what: &str, mut done: impl FnMut() -> bool) {
    let deadline = Instant::now() + Duration::from_secs(10);
    while !done() {
        assert!(Instant::now() < deadline, "{what}");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_43_inputs_the_game_does_not_define_are_refused_and_counted_per_client() {
    let server = start_server(test_config(None, "game-input")).await;
    let (addr, t) = token(&server, 7);
    let client = Client::connect(addr, &t).await.expect("joins");
    assert_eq!(client.server_info().input_bytes, SANDBOX_INPUT_BYTES);
    let m = server.metrics();

    // Inputs of another game's size: refused whole, before the rules.
    let tick = server.frame().tick;
    client
        .send_raw_datagram(datagram(1_000, tick, &[1, 2, 3]))
        .unwrap();
    until("a wrong size counted", || {
        m.inputs_refused_count(7, "wrong_size") >= 1
    })
    .await;

    // The sandbox's size, but an undefined button: the game's decoder
    // refuses it on the tick thread.
    let mut junk = SandboxInput::default().to_payload().as_bytes().to_vec();
    junk[3] |= 0x40;
    client
        .send_raw_datagram(datagram(1_001, server.frame().tick, &junk))
        .unwrap();
    until("an undecodable input counted", || {
        m.inputs_refused_count(7, "undecodable") >= 1
    })
    .await;

    // The player's own inputs still go, and snapshots still come.
    client
        .set_input([0.0, 1.0], 0.0, 0)
        .expect("the sandbox's input");
    let seen = client.stats().snapshots_received;
    until("snapshots keep coming", || {
        client.stats().snapshots_received > seen + 10
    })
    .await;

    // The SDK refuses another game's input before it is sent.
    struct Wide;
    impl GameInput for Wide {
        const BYTES: usize = 9;
        fn encode(&self, _: &mut [u8]) {}
        fn decode(_: &[u8]) -> Result<Self, inertia_protocol::input::InputDecodeError> {
            Ok(Wide)
        }
    }
    assert!(matches!(
        client.set_game_input(&Wide),
        Err(ClientError::InputSize { ours: 9, server: 5 })
    ));

    // Its series go with it.
    client.close().await;
    until("the client's series removed", || {
        let text = m.encode();
        !text.contains("client=\"7\"")
    })
    .await;
    server.shutdown().await;
}
