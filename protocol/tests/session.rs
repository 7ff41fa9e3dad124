//! A whole session without sockets: the client's [`ClientSession`] and
//! the server's [`ServerSession`], the very types the SDK and the server
//! run, talk through simulated links on a virtual clock.
//! The hello and welcome go between the connections' state machines
//! ([`ClientConnection`], [`ServerConnection`]) over a reliable, ordered
//! byte stream cut into arbitrary pieces; snapshots and input datagrams go over lossy,
//! jittered, reordering, duplicating links both ways. The client's view
//! matches the server's at every snapshot it decodes, and every input the
//! client made reaches the server exactly once and in order.

use std::time::{Duration, Instant};

use glam::{DQuat, DVec3};
use inertia_protocol::connection::{
    ClientConnection, ClientConnectionConfig, ClientConnectionEvent, ServerConnection,
    ServerConnectionConfig, ServerConnectionEvent,
};
use inertia_protocol::control::{
    handshake, ClientControl, Refusal, ServerControl, SnapshotParams, TokenRefusal,
    PROTOCOL_VERSION,
};
use inertia_protocol::input::{InputDatagram, MAX_REDUNDANT_INPUTS};
use inertia_protocol::sim_link::{SimLink, SimLinkConfig};
use inertia_protocol::snapshot::{QuantizedFrame, SharedDeltas};
use inertia_protocol::token::{mint, ReplayGuard, TokenKey};
use inertia_protocol::{
    ClientConfig, ClientSession, EntityState, PlayerInput, ServerSession, SessionConfig,
    SnapshotConfig,
};

const SERVER: &str = "127.0.0.1:7777";
const NOW: u64 = 1_800_000_000;

/// A world of `n` bodies on circles, at `tick`.
fn world(n: u32, tick: u64) -> Vec<EntityState> {
    let t = tick as f64 / 60.0;
    (1..=n)
        .map(|id| {
            let phase = f64::from(id) * 0.7 + t * (1.0 + f64::from(id % 3));
            let moving = id % 4 != 0;
            let position = if moving {
                DVec3::new(
                    phase.cos() * 5.0,
                    1.0 + f64::from(id) * 0.1,
                    phase.sin() * 5.0,
                )
            } else {
                DVec3::new(f64::from(id), 0.5, -3.0)
            };
            EntityState {
                id,
                position,
                rotation: DQuat::from_rotation_y(if moving { phase } else { 0.3 }),
                linear_velocity: if moving {
                    DVec3::new(-phase.sin(), 0.0, phase.cos()) * 5.0
                } else {
                    DVec3::ZERO
                },
                angular_velocity: DVec3::ZERO,
                asleep: !moving,
            }
        })
        .collect()
}

/// Moves the control-stream bytes each side has for the other, in pieces
/// of 1, 2, 3, ... bytes as a stream may cut them, until neither has any.
fn exchange(client: &mut ClientConnection, server: &mut ServerConnection, now: Instant) {
    let mut piece = 1;
    loop {
        let up = client.pending_control().len().min(piece);
        let down = server.pending_control().len().min(piece);
        if up == 0 && down == 0 {
            return;
        }
        let bytes = client.pending_control()[..up].to_vec();
        client.control_written(up, now);
        server.on_control_data(&bytes, now);
        let bytes = server.pending_control()[..down].to_vec();
        server.control_written(down, now);
        client.on_control_data(&bytes, now);
        piece = piece % 7 + 1;
    }
}

#[test]
fn a_session_over_bad_links_keeps_both_ends_in_step() {
    // The hello and the welcome over the reliable stream, between the
    // connections the SDK and the server run; the server's part (the
    // token, the welcome) as its connection task does it.
    let t0 = Instant::now();
    let key = TokenKey::from_bytes([9; 32]);
    let token = mint(&key, 42, SERVER, [1; 32], 60, b"team=blue", NOW).unwrap();
    let mut client_conn = ClientConnection::new(
        PROTOCOL_VERSION,
        token.to_bytes(),
        ClientConnectionConfig::default(),
        t0,
    );
    let mut server_conn = ServerConnection::new(ServerConnectionConfig::default(), t0);
    exchange(&mut client_conn, &mut server_conn, t0);
    let Some(ServerConnectionEvent::Hello { version, token }) = server_conn.poll_event() else {
        panic!("expected the hello");
    };
    let hello = ClientControl::Hello { version, token };
    let mut guard = ReplayGuard::new(16);
    let opened = handshake(&hello, NOW + 1, &key, SERVER, 1, &mut guard).unwrap();
    assert_eq!(opened.client_id, 42);
    assert_eq!(opened.user_data, b"team=blue");
    // The same hello on another connection is a replay.
    assert_eq!(
        handshake(&hello, NOW + 1, &key, SERVER, 2, &mut guard).unwrap_err(),
        Refusal::Token(TokenRefusal::Reused)
    );

    let config = SnapshotConfig {
        velocities: true,
        ..SnapshotConfig::default()
    };
    server_conn.admit(
        &ServerControl::Welcome {
            client_id: opened.client_id,
            tick: 0,
            tick_hz: 60,
            snapshot_hz: 30,
            position_resolution: config.grid.resolution,
            position_bound: config.grid.bound,
            snapshot: SnapshotParams::from_config(&config),
            input_bytes: 5,
            server_version: "test".into(),
            game: "sandbox".into(),
            properties: Default::default(),
        },
        t0,
    );
    exchange(&mut client_conn, &mut server_conn, t0);
    assert_eq!(server_conn.poll_event(), Some(ServerConnectionEvent::Live));
    let Some(ClientConnectionEvent::Welcomed(info)) = client_conn.poll_event() else {
        panic!("expected a welcome");
    };
    assert_eq!(info.client_id, 42);
    let client_config = info.snapshot;
    assert_eq!(client_config, config);

    // Then datagrams, both ways, for 20 s of a 60 Hz world with 30 Hz
    // snapshots and 60 Hz inputs.
    let bad = SimLinkConfig {
        delay: 0.05,
        jitter: 0.02,
        loss: 0.15,
        duplicate: 0.05,
    };
    let mut down = SimLink::new(bad, 1).unwrap();
    let mut up = SimLink::new(bad, 2).unwrap();
    // The server's half is the session the server runs, the client's the
    // one the SDK runs: inputs at 60 Hz, the last eight in each datagram.
    let mut session = ServerSession::new(SessionConfig::new(config, 1200)).unwrap();
    let mut deltas = SharedDeltas::new();
    let mut client = ClientSession::new(
        ClientConfig {
            snapshot: client_config,
            input_hz: 60,
            input_redundancy: MAX_REDUNDANT_INPUTS,
            properties: Default::default(),
        },
        0,
    )
    .unwrap();
    let mut sent_inputs: Vec<PlayerInput> = Vec::new();
    let mut received_inputs: Vec<PlayerInput> = Vec::new();
    let (mut decoded, mut compared) = (0, 0);
    for tick in 1..=1200u64 {
        let now = tick as f64 / 60.0;
        // Server: a snapshot slot every other tick, on its frame.
        if tick % 2 == 0 {
            let frame = QuantizedFrame::new(tick, 1.0, false, &world(40, tick), &config);
            let bytes = session
                .poll_snapshot(&frame, &mut deltas, tick / 2, 1200)
                .expect("every slot is served");
            assert!(bytes.len() <= 1200);
            down.send(now, bytes);
        }
        // Client: decode what arrived and check it against what the
        // server says it sent.
        for bytes in down.receive(now) {
            let Ok(sequence) = client.on_datagram(&bytes).map(|s| s.sequence) else {
                continue;
            };
            decoded += 1;
            let sent = session
                .encoder()
                .view(sequence)
                .expect("the server still holds it");
            let entities = client.decoder().entities(sequence).expect("just decoded");
            assert_eq!(sent.len(), entities.len());
            for e in &entities {
                let q = sent.get(e.id).expect("same ids");
                assert_eq!(q.dequantize(e.id, &config), *e);
                compared += 1;
            }
        }
        // Client: a new stick every tick; one datagram a tick, carrying
        // it (quantized for the wire) and the seven before.
        client.set_input(
            inertia_protocol::input::InputPayload::new(&[
                (tick % 7) as u8,
                0x80,
                (tick % 100) as u8,
            ])
            .unwrap(),
        );
        let bytes = client
            .poll_input(now, Some(tick))
            .expect("one input a tick at 60 Hz");
        let datagram = InputDatagram::decode(&bytes).unwrap();
        assert!(datagram.inputs.len() <= MAX_REDUNDANT_INPUTS);
        let newest = datagram.inputs[0];
        assert_eq!((newest.sequence, newest.tick), (tick as u32, tick));
        sent_inputs.push(newest);
        up.send(now, bytes);
        // Server: the connection keeps the inputs, which come out once,
        // in order; the acks it hands on move the session's baseline.
        let at = t0 + Duration::from_secs_f64(now);
        for bytes in up.receive(now) {
            if let Some(ack) = server_conn.on_datagram(&bytes, at).unwrap() {
                session.on_ack(ack);
            }
            while let Some(i) = server_conn.poll_input() {
                received_inputs.push(i);
            }
        }
        server_conn.handle_timeout(at);
        assert!(server_conn.is_live(), "a client that sends is never silent");
    }
    // The tail still in flight is not counted.
    let got = received_inputs.len();
    assert!(got > 1150, "{got} inputs arrived");
    assert_eq!(
        received_inputs,
        sent_inputs[..got],
        "inputs out of order or altered"
    );
    assert!(decoded > 450, "{decoded} snapshots decoded of 600");
    assert!(compared > 15_000);
    // The baseline followed the acks: most snapshots were deltas.
    assert!(session.encoder().acked().is_some());
}

/// A client served every third slot is served in exactly those.
#[test]
fn a_slower_client_skips_slots_deterministically() {
    let config = SnapshotConfig::default();
    let mut session = ServerSession::new(SessionConfig {
        every_slots: 3,
        ..SessionConfig::new(config, 1200)
    })
    .unwrap();
    let mut deltas = SharedDeltas::new();
    let served: Vec<u64> = (0..10u64)
        .filter(|&slot| {
            let frame = QuantizedFrame::new(slot, 1.0, false, &world(10, slot), &config);
            session
                .poll_snapshot(&frame, &mut deltas, slot, 1200)
                .is_some()
        })
        .collect();
    assert_eq!(served, [0, 3, 6, 9]);
    assert_eq!(session.encoder().acked(), None);
}

/// A server that lowers a client's rate takes one slot of every
/// `divisor` the client would take, at its phase; full rate again serves
/// every slot the configuration gives.
#[test]
fn a_rate_divisor_takes_every_nth_slot_at_its_phase() {
    let config = SnapshotConfig::default();
    let mut session = ServerSession::new(SessionConfig::new(config, 1200)).unwrap();
    let mut deltas = SharedDeltas::new();
    let mut served_in = |session: &mut ServerSession, slots: std::ops::Range<u64>| -> Vec<u64> {
        slots
            .filter(|&slot| {
                let frame = QuantizedFrame::new(slot, 1.0, false, &world(10, slot), &config);
                session
                    .poll_snapshot(&frame, &mut deltas, slot, 1200)
                    .is_some()
            })
            .collect()
    };
    session.set_rate_divisor(2, 1);
    assert_eq!(session.rate_divisor(), 2);
    assert_eq!(served_in(&mut session, 0..8), [1, 3, 5, 7]);
    session.set_rate_divisor(2, 0);
    assert_eq!(served_in(&mut session, 8..14), [8, 10, 12]);
    session.set_rate_divisor(1, 5);
    assert_eq!(served_in(&mut session, 14..18), [14, 15, 16, 17]);
}
