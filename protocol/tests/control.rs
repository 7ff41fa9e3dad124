//! Property tests of the control channel, connect tokens and input
//! datagrams: every message type round-trips, every decoder survives any
//! bytes, and every way a token can be wrong is refused.

use inertia_protocol::control::{
    decode_payload, encode_frame, handshake, ClientControl, ControlError, DisconnectReason,
    FrameDecoder, Refusal, ServerControl, SnapshotParams, TokenRefusal, MAX_CONTROL_FRAME,
    MAX_MESSAGE_BYTES, PROTOCOL_VERSION,
};
use inertia_protocol::entity::{EntityDesc, EntityKind};
use inertia_protocol::input::{
    quantize_input, InputBuffer, InputDatagram, InputPayload, MAX_INPUT_BYTES, MAX_REDUNDANT_INPUTS,
};
use inertia_protocol::token::{
    mint, open, ConnectToken, ReplayGuard, TokenError, TokenKey, MAX_SERVER_ADDR_BYTES,
    MAX_TOKEN_BYTES, MAX_USER_DATA_BYTES,
};
use inertia_protocol::PlayerInput;
use proptest::collection::vec;
use proptest::prelude::*;

use crate::common;
use common::shape;

const NOW: u64 = 1_750_000_000;

fn entity() -> impl Strategy<Value = EntityDesc> {
    (
        any::<u32>(),
        prop_oneof![
            Just(EntityKind::Static),
            Just(EntityKind::Dynamic),
            Just(EntityKind::Kinematic),
            Just(EntityKind::Avatar),
            Just(EntityKind::Water),
            Just(EntityKind::SoftBody),
            Just(EntityKind::Fluid),
        ],
        shape(),
        any::<[u8; 4]>(),
        any::<Option<u64>>(),
        "\\PC{0,16}",
        [-1e6f64..1e6, -1e6f64..1e6, -1e6f64..1e6],
        [-1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0, -1.0f64..1.0],
    )
        .prop_map(
            |(id, kind, shape, color, owner, name, position, rotation)| EntityDesc {
                id,
                kind,
                shape,
                color,
                owner,
                name,
                position,
                rotation,
            },
        )
}

fn token_refusal() -> impl Strategy<Value = TokenRefusal> {
    prop_oneof![
        Just(TokenRefusal::Malformed),
        Just(TokenRefusal::Forged),
        (any::<u64>(), any::<u64>())
            .prop_map(|(expires_at, now)| TokenRefusal::Expired { expires_at, now }),
        ("\\PC{0,30}", "\\PC{0,30}")
            .prop_map(|(token, ours)| TokenRefusal::WrongServer { token, ours }),
        Just(TokenRefusal::Reused),
    ]
}

fn refusal() -> impl Strategy<Value = Refusal> {
    prop_oneof![
        (any::<u16>(), any::<u16>())
            .prop_map(|(server, client)| Refusal::VersionMismatch { server, client }),
        token_refusal().prop_map(Refusal::Token),
        Just(Refusal::ServerFull),
        Just(Refusal::ShuttingDown),
        Just(Refusal::Malformed),
        Just(Refusal::AlreadyConnected),
        Just(Refusal::Busy),
        Just(Refusal::SimulationStopped),
        "\\PC{0,40}".prop_map(|reason| Refusal::Rejected { reason }),
    ]
}

fn reason() -> impl Strategy<Value = DisconnectReason> {
    prop_oneof![
        Just(DisconnectReason::ServerShutdown),
        "\\PC{0,40}".prop_map(|reason| DisconnectReason::Kicked { reason }),
        Just(DisconnectReason::Timeout),
        Just(DisconnectReason::ClientLeft),
        "\\PC{0,40}".prop_map(|what| DisconnectReason::ProtocolError { what }),
        "\\PC{0,40}".prop_map(|reason| DisconnectReason::SimulationStopped { reason }),
        "\\PC{0,40}".prop_map(|reason| DisconnectReason::MatchOver { reason }),
    ]
}

fn server_control() -> impl Strategy<Value = ServerControl> {
    prop_oneof![
        (
            any::<u64>(),
            any::<u64>(),
            1u32..1000,
            1u32..1000,
            1e-4f64..1.0,
            1.0f64..1e4,
            "[0-9a-z.+-]{0,64}"
        )
            .prop_map(
                |(
                    client_id,
                    tick,
                    tick_hz,
                    snapshot_hz,
                    position_resolution,
                    position_bound,
                    server_version,
                )| ServerControl::Welcome {
                    client_id,
                    tick,
                    tick_hz,
                    snapshot_hz,
                    position_resolution,
                    position_bound,
                    snapshot: SnapshotParams::default(),
                    input_bytes: (tick % 65) as u16,
                    server_version,
                    game: "football".into(),
                    properties: Default::default(),
                }
            ),
        refusal().prop_map(ServerControl::Refused),
        entity().prop_map(ServerControl::Spawn),
        any::<u32>().prop_map(|id| ServerControl::Despawn { id }),
        vec(any::<u8>(), 0..=MAX_MESSAGE_BYTES).prop_map(ServerControl::Message),
        reason().prop_map(ServerControl::Goodbye),
    ]
}

fn client_control() -> impl Strategy<Value = ClientControl> {
    prop_oneof![
        (any::<u16>(), vec(any::<u8>(), 0..MAX_TOKEN_BYTES))
            .prop_map(|(version, token)| ClientControl::Hello { version, token }),
        Just(ClientControl::Goodbye),
        vec(any::<u8>(), 0..300).prop_map(ClientControl::Message),
    ]
}

/// An input whose payload is filled in by the datagram (one size for all).
fn player_input() -> impl Strategy<Value = PlayerInput> {
    (
        any::<u32>(),
        any::<u64>(),
        // Views behind the tick: none, within the cap, past it, ahead.
        prop_oneof![Just(0.0f32), 0.0f32..300.0, -5.0f32..0.0],
    )
        .prop_map(|(sequence, tick, view_behind)| PlayerInput {
            sequence,
            tick,
            payload: InputPayload::EMPTY,
            view_behind,
        })
}

/// Datagrams as a client writes them: consecutive sequences and ticks
/// mostly, odd steps sometimes.
fn input_datagram() -> impl Strategy<Value = InputDatagram> {
    (
        any::<Option<u16>>(),
        any::<u32>(),
        player_input(),
        vec(
            (
                prop_oneof![3 => Just(1u32), 1 => 1u32..=u32::MAX],
                prop_oneof![3 => Just(1i64), 1 => any::<i64>()],
                player_input(),
            ),
            0..MAX_REDUNDANT_INPUTS,
        ),
    )
        .prop_flat_map(|d| {
            // Payloads of one size, often repeated.
            let n = d.3.len() + 1;
            (
                Just(d),
                (0..=MAX_INPUT_BYTES).prop_flat_map(move |size| {
                    vec(
                        prop_oneof![2 => Just(None), 1 => vec(any::<u8>(), size).prop_map(Some)],
                        n,
                    )
                    .prop_map(move |p| (size, p))
                }),
            )
        })
        .prop_map(|((ack, ack_bits, newest, older), (size, payloads))| {
            let mut inputs = vec![newest];
            for (step, tick_step, body) in older {
                let prev = inputs[inputs.len() - 1];
                inputs.push(PlayerInput {
                    sequence: prev.sequence.wrapping_sub(step),
                    tick: prev.tick.wrapping_sub(tick_step as u64),
                    ..body
                });
            }
            let mut payload = InputPayload::new(&vec![0; size]).unwrap();
            for (input, fresh) in inputs.iter_mut().zip(payloads) {
                if let Some(bytes) = fresh {
                    payload = InputPayload::new(&bytes).unwrap();
                }
                input.payload = payload;
            }
            InputDatagram {
                ack,
                ack_bits: if ack.is_some() { ack_bits } else { 0 },
                inputs,
            }
        })
}

fn decode_stream<T: inertia_protocol::control::ControlMessage>(bytes: &[u8], chunk: usize) {
    let mut d = FrameDecoder::new();
    for piece in bytes.chunks(chunk.max(1)) {
        if d.push(piece).is_err() {
            return;
        }
        // At most one message per 4 bytes, and a fatal error repeats.
        for _ in 0..=bytes.len() / 4 {
            match d.next::<T>() {
                None => break,
                Some(Err(ControlError::FrameTooLarge { .. })) => return,
                Some(_) => {}
            }
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(256))]

    /// A client that sees the server's close before its goodbye still
    /// learns the whole reason, a kick's text included (the server used
    /// to close every kick with the text "kicked").
    #[test]
    fn issue_13_a_close_says_the_whole_disconnect_reason(r in reason()) {
        let (code, text) = r.to_close();
        prop_assert_eq!(DisconnectReason::from_close(u64::from(code), text.as_bytes()), r);
    }

    #[test]
    fn server_messages_round_trip(msgs in vec(server_control(), 1..5), chunk in 1usize..200) {
        let stream: Vec<u8> = msgs.iter().flat_map(|m| encode_frame(m).unwrap()).collect();
        let mut d = FrameDecoder::new();
        let mut got = Vec::new();
        for piece in stream.chunks(chunk) {
            d.push(piece).unwrap();
            while let Some(m) = d.next::<ServerControl>() {
                got.push(m.unwrap());
            }
        }
        prop_assert_eq!(got, msgs);
    }

    #[test]
    fn client_messages_round_trip(msg in client_control()) {
        let bytes = encode_frame(&msg).unwrap();
        prop_assert_eq!(decode_payload::<ClientControl>(&bytes[4..]).unwrap(), msg);
    }

    #[test]
    fn random_bytes_never_panic_the_control_decoders(
        bytes in vec(any::<u8>(), 0..600),
        chunk in 1usize..64,
    ) {
        let _ = decode_payload::<ServerControl>(&bytes);
        let _ = decode_payload::<ClientControl>(&bytes);
        decode_stream::<ServerControl>(&bytes, chunk);
        decode_stream::<ClientControl>(&bytes, chunk);
    }

    #[test]
    fn mutated_frames_never_panic_and_stay_valid(
        msg in server_control(),
        flips in vec((any::<prop::sample::Index>(), any::<u8>()), 1..4),
    ) {
        let mut bytes = encode_frame(&msg).unwrap();
        for (at, x) in flips {
            let i = at.index(bytes.len());
            bytes[i] ^= x;
        }
        if let Ok(m) = decode_payload::<ServerControl>(&bytes[4..]) {
            // Whatever decodes has passed validation, so it re-encodes.
            prop_assert!(encode_frame(&m).is_ok());
        }
        decode_stream::<ServerControl>(&bytes, 7);
    }

    #[test]
    fn tokens_round_trip_and_open(
        client_id in any::<u64>(),
        addr in "[a-z0-9.-]{1,40}:[0-9]{1,5}",
        fingerprint in any::<[u8; 32]>(),
        ttl in 1u64..100_000,
        user_data in vec(any::<u8>(), 0..=MAX_USER_DATA_BYTES),
        key in any::<[u8; 32]>(),
    ) {
        let key = TokenKey::from_bytes(key);
        let token = mint(&key, client_id, &addr, fingerprint, ttl, &user_data, NOW).unwrap();
        let bytes = token.to_bytes();
        prop_assert!(bytes.len() <= MAX_TOKEN_BYTES);
        let public = ConnectToken::from_bytes(&bytes).unwrap();
        prop_assert_eq!(&public, &token);
        prop_assert_eq!(public.public.version, PROTOCOL_VERSION);
        prop_assert_eq!(&public.public.server_addr, &addr);
        prop_assert_eq!(public.public.cert_fingerprint, fingerprint);
        let opened = open(&bytes, &key, NOW + ttl - 1, &addr).unwrap();
        prop_assert_eq!(opened.client_id, client_id);
        prop_assert_eq!(opened.expires_at, NOW + ttl);
        prop_assert_eq!(opened.user_data, user_data);
        prop_assert_eq!(
            open(&bytes, &key, NOW + ttl, &addr),
            Err(TokenError::Expired { expires_at: NOW + ttl, now: NOW + ttl })
        );
        let elsewhere = format!("x{addr}");
        let wrong_server = matches!(
            open(&bytes, &key, NOW, &elsewhere),
            Err(TokenError::WrongServer { .. })
        );
        prop_assert!(wrong_server);
    }

    #[test]
    fn any_altered_token_byte_is_refused(
        at in any::<prop::sample::Index>(),
        x in 1u8..=255,
        user_data in vec(any::<u8>(), 0..40),
    ) {
        let key = TokenKey::from_bytes([3; 32]);
        let addr = "10.0.0.1:7777";
        let mut bytes = mint(&key, 1, addr, [0; 32], 60, &user_data, NOW).unwrap().to_bytes();
        let i = at.index(bytes.len());
        bytes[i] ^= x;
        let refused = matches!(
            open(&bytes, &key, NOW, addr),
            Err(TokenError::Forged | TokenError::Malformed(_))
        );
        prop_assert!(refused);
    }

    #[test]
    fn random_bytes_never_panic_the_token_decoder(bytes in vec(any::<u8>(), 0..1200)) {
        let key = TokenKey::from_bytes([3; 32]);
        let _ = ConnectToken::from_bytes(&bytes);
        prop_assert!(open(&bytes, &key, NOW, "10.0.0.1:7777").is_err());
    }

    #[test]
    fn reused_tokens_are_refused_on_other_connections(
        first in any::<u64>(),
        other in any::<u64>(),
        later in 0u64..60,
    ) {
        prop_assume!(first != other);
        let key = TokenKey::from_bytes([5; 32]);
        let addr = "game:7777";
        let token = mint(&key, 9, addr, [0; 32], 60, b"", NOW).unwrap().to_bytes();
        let hello = ClientControl::Hello { version: PROTOCOL_VERSION, token };
        let mut guard = ReplayGuard::new(8);
        prop_assert!(handshake(&hello, NOW, &key, addr, first, &mut guard).is_ok());
        prop_assert!(handshake(&hello, NOW + later, &key, addr, first, &mut guard).is_ok());
        prop_assert_eq!(
            handshake(&hello, NOW + later, &key, addr, other, &mut guard),
            Err(Refusal::Token(TokenRefusal::Reused))
        );
    }

    #[test]
    fn version_mismatch_is_told_whatever_the_token(version in any::<u16>(), token in vec(any::<u8>(), 0..100)) {
        prop_assume!(version != PROTOCOL_VERSION);
        let key = TokenKey::from_bytes([5; 32]);
        let mut guard = ReplayGuard::new(8);
        let hello = ClientControl::Hello { version, token };
        prop_assert_eq!(
            handshake(&hello, NOW, &key, "game:7777", 1, &mut guard),
            Err(Refusal::VersionMismatch { server: PROTOCOL_VERSION, client: version })
        );
    }

    #[test]
    fn input_datagrams_round_trip_quantized(d in input_datagram()) {
        let bytes = d.encode().unwrap();
        let back = InputDatagram::decode(&bytes).unwrap();
        let expected = InputDatagram {
            inputs: d.inputs.iter().map(quantize_input).collect(),
            ..d
        };
        prop_assert_eq!(&back, &expected);
        prop_assert_eq!(back.encode().unwrap(), bytes);
    }

    #[test]
    fn random_bytes_never_panic_the_input_decoder(mut bytes in vec(any::<u8>(), 0..200), tagged in any::<bool>()) {
        if tagged && !bytes.is_empty() {
            bytes[0] = 0x49;
        }
        if let Ok(d) = InputDatagram::decode(&bytes) {
            // Canonical: what decodes re-encodes to the same bytes.
            prop_assert_eq!(d.encode().unwrap(), bytes);
        }
    }

    #[test]
    fn the_input_buffer_yields_each_sequence_once_in_order(
        start in any::<u32>(),
        lost in vec(any::<bool>(), 40),
        shuffle in vec(any::<prop::sample::Index>(), 40),
    ) {
        // Datagrams for 40 ticks, each carrying the last 8 inputs, some
        // lost, delivered somewhat out of order.
        let mut sends: Vec<InputDatagram> = (0..40u32)
            .map(|k| InputDatagram {
                ack: None,
                ack_bits: 0,
                inputs: (0..8u32.min(k + 1))
                    .map(|j| PlayerInput {
                        sequence: start.wrapping_add(k - j),
                        tick: u64::from(k - j),
                        ..PlayerInput::default()
                    })
                    .collect(),
            })
            .collect();
        for (i, at) in shuffle.iter().enumerate() {
            let j = (i + at.index(3)).min(sends.len() - 1);
            sends.swap(i, j);
        }
        let mut buffer = InputBuffer::new(16);
        let mut out = Vec::new();
        for (d, lost) in sends.iter().zip(lost) {
            if !lost {
                buffer.push_datagram(d);
            }
            out.extend(buffer.pop());
        }
        out.extend(std::iter::from_fn(|| buffer.pop()));
        let offsets: Vec<u32> = out.iter().map(|i| i.sequence.wrapping_sub(start)).collect();
        prop_assert!(offsets.windows(2).all(|w| w[0] < w[1]), "{:?}", offsets);
        prop_assert!(buffer.is_empty());
    }
}

#[test]
fn bounds_that_serde_cannot_see_are_refused_on_decode() {
    let long_message = ServerControl::Message(vec![7; MAX_MESSAGE_BYTES + 1]);
    let payload = postcard::to_allocvec(&long_message).unwrap();
    assert!(matches!(
        decode_payload::<ServerControl>(&payload),
        Err(ControlError::TooLong { .. })
    ));
    let huge_token = ClientControl::Hello {
        version: PROTOCOL_VERSION,
        token: vec![0; MAX_TOKEN_BYTES + 1],
    };
    let payload = postcard::to_allocvec(&huge_token).unwrap();
    assert!(matches!(
        decode_payload::<ClientControl>(&payload),
        Err(ControlError::TooLong { .. })
    ));
    assert!(matches!(
        decode_payload::<ServerControl>(&vec![0; MAX_CONTROL_FRAME + 1]),
        Err(ControlError::FrameTooLarge { .. })
    ));
}

#[test]
fn token_limits_hold_at_the_edges() {
    let key = TokenKey::generate().unwrap();
    let addr = "s".repeat(MAX_SERVER_ADDR_BYTES);
    let t = mint(
        &key,
        u64::MAX,
        &addr,
        [0xFF; 32],
        u64::MAX - NOW,
        &[0xAB; MAX_USER_DATA_BYTES],
        NOW,
    )
    .unwrap();
    let bytes = t.to_bytes();
    assert_eq!(bytes.len(), MAX_TOKEN_BYTES);
    assert_eq!(open(&bytes, &key, NOW, &addr).unwrap().client_id, u64::MAX);
    let mut longer = bytes.clone();
    longer.push(0);
    assert!(matches!(
        open(&longer, &key, NOW, &addr),
        Err(TokenError::Malformed(_))
    ));
}

#[test]
fn close_codes_map_to_disconnect_reasons() {
    use inertia_protocol::control::{close_code, DisconnectReason as R, MAX_REASON_BYTES};
    let from = |code: u32, text: &str| R::from_close(u64::from(code), text.as_bytes());
    assert_eq!(
        from(close_code::SIMULATION_STOPPED, "simulation stopped: a NaN"),
        R::SimulationStopped {
            reason: "a NaN".into()
        }
    );
    assert_eq!(
        from(close_code::SHUTDOWN, "server shutting down"),
        R::ServerShutdown
    );
    assert_eq!(from(close_code::GOODBYE, "goodbye"), R::ClientLeft);
    assert_eq!(
        from(close_code::PROTOCOL, "protocol error"),
        R::ProtocolError {
            what: "protocol error".into()
        }
    );
    assert_eq!(
        from(close_code::KICKED, "kicked"),
        R::Kicked {
            reason: "kicked".into()
        }
    );
    // Unknown codes read as kicks; untrusted text is cut to its bound.
    let long = "x".repeat(10 * MAX_REASON_BYTES);
    match R::from_close(99, long.as_bytes()) {
        R::Kicked { reason } => assert_eq!(reason.len(), MAX_REASON_BYTES),
        other => panic!("{other:?}"),
    }
    assert_eq!(
        R::from_close(u64::MAX, b"\xff\xfe"),
        R::Kicked {
            reason: "\u{fffd}\u{fffd}".into()
        }
    );
}
