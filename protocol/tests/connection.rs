//! A game connection's life on a virtual clock: the server's
//! [`ServerConnection`], the very type the server's connection task
//! drives, taken through every state and every deadline in milliseconds
//! of test time, without sockets or waiting.

use std::time::{Duration, Instant};

use inertia_protocol::connection::{
    ServerConnection, ServerConnectionConfig, ServerConnectionEnd, ServerConnectionEvent,
    CONTROL_STALL, FINISH_WAIT, GOODBYE_WAIT, HELLO_TIMEOUT, SILENT_TIMEOUT,
};
use inertia_protocol::control::{
    close_code, encode_frame, ClientControl, DisconnectReason, FrameDecoder, Refusal,
    ServerControl, SnapshotParams, PROTOCOL_VERSION,
};
use inertia_protocol::input::{InputDatagram, InputError, InputPayload};
use inertia_protocol::PlayerInput;

/// An input datagram acknowledging `ack`, with inputs of `sequences`
/// (newest first).
fn datagram(ack: Option<u16>, sequences: &[u32]) -> Vec<u8> {
    InputDatagram {
        ack,
        ack_bits: 0,
        inputs: sequences
            .iter()
            .map(|&sequence| PlayerInput {
                sequence,
                tick: u64::from(sequence),
                ..PlayerInput::default()
            })
            .collect(),
    }
    .encode()
    .expect("encodes")
}

fn ms(n: u64) -> Duration {
    Duration::from_millis(n)
}

fn hello() -> Vec<u8> {
    encode_frame(&ClientControl::Hello {
        version: PROTOCOL_VERSION,
        token: vec![7; 40],
    })
    .expect("encodes")
}

fn welcome() -> ServerControl {
    ServerControl::Welcome {
        client_id: 9,
        tick: 100,
        tick_hz: 60,
        snapshot_hz: 30,
        position_resolution: 0.001,
        position_bound: 1000.0,
        snapshot: SnapshotParams::default(),
        input_bytes: 5,
        server_version: "test".into(),
        game: "sandbox".into(),
        properties: Default::default(),
    }
}

/// Writes what the connection has for the client at `now`, `piece` bytes
/// at a time, and decodes it as the client would.
fn take(conn: &mut ServerConnection, now: Instant, piece: usize) -> Vec<ServerControl> {
    let mut frames = FrameDecoder::new();
    while !conn.pending_control().is_empty() {
        let n = conn.pending_control().len().min(piece);
        frames.push(&conn.pending_control()[..n]).expect("fits");
        conn.control_written(n, now);
    }
    let mut out = Vec::new();
    while let Some(msg) = frames.next::<ServerControl>() {
        out.push(msg.expect("the server's frames decode"));
    }
    out
}

fn events(conn: &mut ServerConnection) -> Vec<ServerConnectionEvent> {
    std::iter::from_fn(|| conn.poll_event()).collect()
}

/// The stream is finished and taken: the connection closes.
fn finish(conn: &mut ServerConnection) {
    assert!(conn.wants_finish(), "the stream is to be finished");
    conn.finish_sent();
    assert!(conn.awaits_finish());
    conn.on_finish_taken();
}

/// A connection past its hello and welcome at `t0 + 10 ms`.
fn live(t0: Instant) -> ServerConnection {
    let mut conn = ServerConnection::new(ServerConnectionConfig::default(), t0);
    conn.on_control_data(&hello(), t0 + ms(5));
    assert!(matches!(
        events(&mut conn)[..],
        [ServerConnectionEvent::Hello {
            version: PROTOCOL_VERSION,
            ..
        }]
    ));
    conn.admit(&welcome(), t0 + ms(10));
    assert_eq!(take(&mut conn, t0 + ms(10), 1000), vec![welcome()]);
    assert_eq!(events(&mut conn), vec![ServerConnectionEvent::Live]);
    assert!(conn.is_live());
    conn
}

fn assert_closed(conn: &ServerConnection, code: u32) {
    assert!(conn.is_closed(), "closed");
    assert_eq!(
        conn.close_frame().map(|c| c.code),
        Some(code),
        "{:?}",
        conn.close_frame()
    );
}

#[test]
fn a_client_that_says_no_hello_is_let_go_at_the_hello_timeout() {
    let t0 = Instant::now();
    let mut conn = ServerConnection::new(ServerConnectionConfig::default(), t0);
    assert_eq!(conn.poll_timeout(), Some(t0 + HELLO_TIMEOUT));
    // Half a hello, then nothing.
    let bytes = hello();
    conn.on_control_data(&bytes[..7], t0 + ms(100));
    conn.handle_timeout(t0 + HELLO_TIMEOUT - ms(1));
    assert!(!conn.is_closed());
    conn.handle_timeout(t0 + HELLO_TIMEOUT);
    assert_closed(&conn, close_code::REFUSED);
    assert_eq!(conn.end(), Some(&ServerConnectionEnd::HelloTimeout));
    assert_eq!(events(&mut conn), vec![ServerConnectionEvent::Ending]);
    assert_eq!(conn.poll_timeout(), None, "nothing more to wait for");
}

#[test]
fn issue_42_a_control_stream_ended_before_a_whole_hello_is_closed_at_once() {
    let t0 = Instant::now();
    let bytes = hello();
    // Ended with nothing, with part of a hello, and reset part way.
    for (sent, reset) in [(0, false), (7, false), (bytes.len() - 1, false), (7, true)] {
        let mut conn = ServerConnection::new(ServerConnectionConfig::default(), t0);
        conn.on_control_data(&bytes[..sent], t0 + ms(1));
        if reset {
            conn.on_control_reset("reset by peer", t0 + ms(2));
        } else {
            conn.on_control_finished();
        }
        assert_closed(&conn, close_code::REFUSED);
        assert_eq!(
            conn.end(),
            Some(&ServerConnectionEnd::StreamEndedBeforeHello),
            "{sent} {reset}"
        );
        assert_eq!(events(&mut conn), vec![ServerConnectionEvent::Ending]);
    }
}

#[test]
fn a_hello_in_pieces_is_answered_and_the_client_finishing_after_it_still_gets_the_answer() {
    let t0 = Instant::now();
    let bytes = hello();
    let mut conn = ServerConnection::new(ServerConnectionConfig::default(), t0);
    for (i, b) in bytes.iter().enumerate() {
        conn.on_control_data(std::slice::from_ref(b), t0 + ms(i as u64));
    }
    conn.on_control_finished();
    assert!(matches!(
        events(&mut conn)[..],
        [ServerConnectionEvent::Hello { .. }]
    ));
    assert_eq!(
        conn.poll_timeout(),
        None,
        "the server's part has no deadline of the client's"
    );
    conn.refuse(Refusal::ServerFull, t0 + ms(100));
    assert_eq!(
        take(&mut conn, t0 + ms(100), 3),
        vec![ServerControl::Refused(Refusal::ServerFull)]
    );
    finish(&mut conn);
    assert_closed(&conn, close_code::REFUSED);
    assert_eq!(
        conn.end(),
        Some(&ServerConnectionEnd::Refused(Refusal::ServerFull))
    );

    // Admitted after it finished: welcomed, then gone.
    let mut conn = ServerConnection::new(ServerConnectionConfig::default(), t0);
    conn.on_control_data(&bytes, t0);
    conn.on_control_finished();
    let _ = events(&mut conn);
    conn.admit(&welcome(), t0 + ms(1));
    assert_eq!(take(&mut conn, t0 + ms(1), 100), vec![welcome()]);
    assert_eq!(
        events(&mut conn),
        vec![ServerConnectionEvent::Live, ServerConnectionEvent::Ending]
    );
    assert_closed(&conn, close_code::GOODBYE);
    assert_eq!(conn.end(), Some(&ServerConnectionEnd::Left));
}

#[test]
fn anything_but_a_hello_first_is_refused_as_malformed() {
    let t0 = Instant::now();
    let mut garbage = (9u32).to_le_bytes().to_vec();
    garbage.extend([7u8; 9]);
    for first in [
        encode_frame(&ClientControl::Goodbye).expect("encodes"),
        garbage,
        u32::MAX.to_le_bytes().to_vec(),
    ] {
        let mut conn = ServerConnection::new(ServerConnectionConfig::default(), t0);
        conn.on_control_data(&first, t0 + ms(1));
        assert_eq!(
            conn.end(),
            Some(&ServerConnectionEnd::Refused(Refusal::Malformed))
        );
        assert_eq!(
            take(&mut conn, t0 + ms(2), 1000),
            vec![ServerControl::Refused(Refusal::Malformed)]
        );
        finish(&mut conn);
        assert_closed(&conn, close_code::REFUSED);
    }
}

#[test]
fn a_welcome_not_taken_in_time_lets_the_client_go() {
    let t0 = Instant::now();
    let mut conn = ServerConnection::new(ServerConnectionConfig::default(), t0);
    conn.on_control_data(&hello(), t0);
    let _ = events(&mut conn);
    // The join took the tick thread 3 s; the client then has 5 s more.
    conn.admit(&welcome(), t0 + ms(3000));
    assert_eq!(conn.poll_timeout(), Some(t0 + ms(3000) + HELLO_TIMEOUT));
    conn.handle_timeout(t0 + ms(3000) + HELLO_TIMEOUT);
    assert_eq!(conn.end(), Some(&ServerConnectionEnd::HelloTimeout));
    assert_eq!(events(&mut conn), vec![ServerConnectionEvent::Ending]);
    assert_closed(&conn, close_code::REFUSED);
}

#[test]
fn issue_43_inputs_of_another_size_are_refused_and_their_ack_taken() {
    let t0 = Instant::now();
    let mut conn = ServerConnection::new(
        ServerConnectionConfig {
            input_bytes: Some(5),
            ..ServerConnectionConfig::default()
        },
        t0,
    );
    conn.on_control_data(&hello(), t0 + ms(5));
    events(&mut conn);
    conn.admit(&welcome(), t0 + ms(10));
    take(&mut conn, t0 + ms(10), 1000);
    assert_eq!(events(&mut conn), vec![ServerConnectionEvent::Live]);
    let with = |ack: u16, sequence: u32, size: usize| {
        InputDatagram {
            ack: Some(ack),
            ack_bits: 0,
            inputs: vec![PlayerInput {
                sequence,
                tick: u64::from(sequence),
                payload: InputPayload::new(&vec![7; size]).unwrap(),
                view_behind: 0.0,
            }],
        }
        .encode()
        .unwrap()
    };
    // Another game's size: the inputs are refused, once, and the
    // acknowledgement still goes to the client's session.
    assert_eq!(conn.on_datagram(&with(3, 1, 2), t0 + ms(20)), Ok(Some(3)));
    assert_eq!(conn.poll_input(), None);
    assert_eq!(
        conn.poll_refused_inputs(),
        Some(InputError::WrongPayloadSize {
            size: 2,
            expected: 5
        })
    );
    assert_eq!(conn.poll_refused_inputs(), None);
    // The game's size goes through.
    assert_eq!(conn.on_datagram(&with(4, 2, 5), t0 + ms(30)), Ok(Some(4)));
    assert_eq!(conn.poll_input().map(|i| i.sequence), Some(2));
    assert_eq!(conn.poll_refused_inputs(), None);
    assert!(conn.is_live());
}

#[test]
fn a_silent_client_is_told_why_and_closed() {
    let t0 = Instant::now();
    let mut conn = live(t0);
    // Datagrams keep it (garbage too: it is the client's); only the last
    // one counts. Each hands on its acknowledgement and keeps its inputs.
    for i in 1..=4u16 {
        let bytes = datagram(Some(i), &[u32::from(i)]);
        assert_eq!(
            conn.on_datagram(&bytes, t0 + ms(1000 * u64::from(i))),
            Ok(Some(i))
        );
        assert_eq!(
            conn.poll_input().map(|input| input.sequence),
            Some(u32::from(i))
        );
        assert_eq!(conn.poll_input(), None);
    }
    assert!(conn.on_datagram(&[0xff; 3], t0 + ms(5000)).is_err());
    let heard = t0 + ms(5000);
    assert_eq!(conn.poll_timeout(), Some(heard + SILENT_TIMEOUT));
    conn.handle_timeout(heard + SILENT_TIMEOUT - ms(1));
    assert!(conn.is_live());
    conn.handle_timeout(heard + SILENT_TIMEOUT);
    assert_eq!(events(&mut conn), vec![ServerConnectionEvent::Ending]);
    let said = take(&mut conn, heard + SILENT_TIMEOUT, 1000);
    match &said[..] {
        [ServerControl::Goodbye(DisconnectReason::ProtocolError { what })] => {
            assert!(what.starts_with("silent"), "{what}")
        }
        other => panic!("expected a goodbye, got {other:?}"),
    }
    assert_eq!(
        conn.on_datagram(&datagram(Some(9), &[9]), heard + SILENT_TIMEOUT),
        Ok(None),
        "dropped once ending"
    );
    assert_eq!(conn.poll_input(), None);
    finish(&mut conn);
    assert_closed(&conn, close_code::PROTOCOL);
    assert!(conn
        .close_frame()
        .expect("a close")
        .reason
        .starts_with("silent"));
}

#[test]
fn a_client_that_stops_reading_is_let_go_at_the_stall_and_its_last_words_wait_bounded() {
    let t0 = Instant::now();
    let mut conn = live(t0);
    let spawn = encode_frame(&ServerControl::Despawn { id: 3 }).expect("encodes");
    let queued = t0 + ms(100);
    conn.queue_control(&spawn, queued);
    // Datagrams keep coming, the stream never moves.
    for i in 1..=10 {
        let _ = conn.on_datagram(&datagram(None, &[]), queued + ms(1000 * i));
    }
    assert_eq!(conn.poll_timeout(), Some(queued + CONTROL_STALL));
    conn.handle_timeout(queued + CONTROL_STALL);
    match conn.end() {
        Some(ServerConnectionEnd::Protocol(what)) => {
            assert!(what.contains("was not read"), "{what}")
        }
        other => panic!("expected a stall, got {other:?}"),
    }
    // Its goodbye cannot be written either: given up after the goodbye
    // wait, the stream finished and not taken, closed after the finish
    // wait.
    let stalled = queued + CONTROL_STALL;
    assert_eq!(conn.poll_timeout(), Some(stalled + GOODBYE_WAIT));
    conn.handle_timeout(stalled + GOODBYE_WAIT);
    assert!(conn.wants_finish());
    assert!(
        conn.pending_control().is_empty(),
        "nothing is written to a finished stream: what did not go is given up"
    );
    conn.finish_sent();
    assert_eq!(
        conn.poll_timeout(),
        Some(stalled + GOODBYE_WAIT + FINISH_WAIT)
    );
    conn.handle_timeout(stalled + GOODBYE_WAIT + FINISH_WAIT);
    assert_closed(&conn, close_code::PROTOCOL);
}

#[test]
fn a_client_too_far_behind_is_let_go() {
    let t0 = Instant::now();
    let config = ServerConnectionConfig {
        outbox_limit: 1000,
        ..ServerConnectionConfig::default()
    };
    let mut conn = ServerConnection::new(config, t0);
    conn.on_control_data(&hello(), t0);
    conn.admit(&welcome(), t0);
    let _ = take(&mut conn, t0, 1000);
    conn.queue_control(&[0u8; 999], t0 + ms(1));
    assert!(conn.is_live());
    conn.queue_control(&[0u8; 2], t0 + ms(2));
    match conn.end() {
        Some(ServerConnectionEnd::Protocol(what)) => {
            assert!(what.contains("more than 1000"), "{what}")
        }
        other => panic!("expected too far behind, got {other:?}"),
    }
}

#[test]
fn kicks_shutdowns_goodbyes_and_bad_bytes_close_with_their_codes() {
    let t0 = Instant::now();
    let now = t0 + ms(50);

    let mut conn = live(t0);
    conn.kick("griefing".into(), now);
    assert_eq!(
        take(&mut conn, now, 1000),
        vec![ServerControl::Goodbye(DisconnectReason::Kicked {
            reason: "griefing".into()
        })]
    );
    finish(&mut conn);
    assert_closed(&conn, close_code::KICKED);
    assert_eq!(conn.close_frame().expect("closed").reason, "griefing");

    let mut conn = live(t0);
    // What waits goes before the goodbye.
    let despawn = ServerControl::Despawn { id: 4 };
    conn.queue_control(&encode_frame(&despawn).expect("encodes"), now);
    conn.shut_down(DisconnectReason::ServerShutdown, now);
    assert_eq!(
        take(&mut conn, now, 5),
        vec![
            despawn,
            ServerControl::Goodbye(DisconnectReason::ServerShutdown)
        ]
    );
    finish(&mut conn);
    assert_closed(&conn, close_code::SHUTDOWN);

    let mut conn = live(t0);
    conn.on_control_data(
        &encode_frame(&ClientControl::Goodbye).expect("encodes"),
        now,
    );
    assert_eq!(conn.end(), Some(&ServerConnectionEnd::Left));
    assert_closed(&conn, close_code::GOODBYE);

    let mut conn = live(t0);
    conn.on_control_finished();
    assert_eq!(conn.end(), Some(&ServerConnectionEnd::Left));
    assert_closed(&conn, close_code::GOODBYE);

    let mut conn = live(t0);
    conn.on_control_data(&hello(), now);
    assert_eq!(
        conn.end(),
        Some(&ServerConnectionEnd::Protocol("a second hello".into()))
    );
    let _ = take(&mut conn, now, 1000);
    finish(&mut conn);
    assert_closed(&conn, close_code::PROTOCOL);

    let mut conn = live(t0);
    conn.on_control_reset("reset by peer", now);
    assert!(matches!(conn.end(), Some(ServerConnectionEnd::Protocol(_))));

    let mut conn = live(t0);
    conn.on_lost("timed out");
    assert_eq!(
        conn.end(),
        Some(&ServerConnectionEnd::Lost("timed out".into()))
    );
    assert!(conn.is_closed());
    assert_eq!(conn.close_frame(), None, "nothing to close on a lost link");
    assert_eq!(events(&mut conn), vec![ServerConnectionEvent::Ending]);

    // A shutdown before the client is live leaves it to its hello.
    let mut conn = ServerConnection::new(ServerConnectionConfig::default(), t0);
    conn.shut_down(DisconnectReason::ServerShutdown, now);
    assert_eq!(conn.end(), None);
}

#[test]
fn what_came_behind_the_hello_is_read_once_the_client_is_live() {
    let t0 = Instant::now();
    let mut conn = ServerConnection::new(ServerConnectionConfig::default(), t0);
    let mut bytes = hello();
    bytes.extend(encode_frame(&ClientControl::Goodbye).expect("encodes"));
    conn.on_control_data(&bytes, t0);
    assert!(matches!(
        events(&mut conn)[..],
        [ServerConnectionEvent::Hello { .. }]
    ));
    conn.admit(&welcome(), t0 + ms(1));
    let _ = take(&mut conn, t0 + ms(1), 1000);
    assert_eq!(
        events(&mut conn),
        vec![ServerConnectionEvent::Live, ServerConnectionEvent::Ending]
    );
    assert_eq!(conn.end(), Some(&ServerConnectionEnd::Left));
}

// ---------------------------------------------------------------------
// The client's side, and both sides talking.

use inertia_protocol::connection::{
    ClientConnection, ClientConnectionConfig, ClientConnectionEnd, ClientConnectionEvent,
    HANDSHAKE_TIMEOUT,
};

fn client(t0: Instant) -> ClientConnection {
    ClientConnection::new(
        PROTOCOL_VERSION,
        vec![7; 40],
        ClientConnectionConfig::default(),
        t0,
    )
}

/// Moves every byte each side has for the other, `piece` bytes at a time,
/// until neither has any.
fn exchange(c: &mut ClientConnection, s: &mut ServerConnection, now: Instant, piece: usize) {
    loop {
        let (to_server, to_client) = (c.pending_control().len(), s.pending_control().len());
        if to_server == 0 && to_client == 0 {
            return;
        }
        if to_server > 0 {
            let n = to_server.min(piece);
            let bytes = c.pending_control()[..n].to_vec();
            c.control_written(n, now);
            s.on_control_data(&bytes, now);
        }
        if to_client > 0 {
            let n = to_client.min(piece);
            let bytes = s.pending_control()[..n].to_vec();
            s.control_written(n, now);
            c.on_control_data(&bytes, now);
        }
    }
}

#[test]
fn a_client_and_a_server_connection_talk_from_hello_to_goodbye() {
    let t0 = Instant::now();
    let mut c = client(t0);
    let mut s = ServerConnection::new(ServerConnectionConfig::default(), t0);
    exchange(&mut c, &mut s, t0 + ms(1), 3);
    match events(&mut s)[..] {
        [ServerConnectionEvent::Hello { version, ref token }] => {
            assert_eq!((version, token.len()), (PROTOCOL_VERSION, 40))
        }
        ref other => panic!("{other:?}"),
    }
    s.admit(&welcome(), t0 + ms(2));
    // A spawn right behind the welcome, in the same bytes.
    exchange(&mut c, &mut s, t0 + ms(3), 1000);
    s.queue_control(
        &encode_frame(&ServerControl::Despawn { id: 5 }).expect("encodes"),
        t0 + ms(3),
    );
    exchange(&mut c, &mut s, t0 + ms(3), 1000);
    match c.poll_event() {
        Some(ClientConnectionEvent::Welcomed(info)) => {
            assert_eq!((info.client_id, info.tick, info.tick_hz), (9, 100, 60))
        }
        other => panic!("expected the welcome, got {other:?}"),
    }
    assert_eq!(
        c.poll_event(),
        Some(ClientConnectionEvent::Message(ServerControl::Despawn {
            id: 5
        }))
    );
    assert!(c.is_live() && s.is_live());
    assert_eq!(c.poll_timeout(), None, "a live client waits on nothing");

    // The client leaves: its goodbye ends the server's side at once.
    c.close(t0 + ms(10));
    exchange(&mut c, &mut s, t0 + ms(10), 1000);
    assert_eq!(s.end(), Some(&ServerConnectionEnd::Left));
    assert_closed(&s, close_code::GOODBYE);
    assert!(c.wants_finish());
    c.finish_sent();
    c.on_finish_taken();
    assert!(c.is_closed());
    assert_eq!(c.close_frame().map(|f| f.code), Some(close_code::GOODBYE));
    assert_eq!(
        c.end(),
        Some(&ClientConnectionEnd::Disconnected(
            DisconnectReason::ClientLeft
        ))
    );
}

#[test]
fn a_client_learns_why_it_was_refused_or_let_go() {
    let t0 = Instant::now();
    let mut c = client(t0);
    let mut s = ServerConnection::new(ServerConnectionConfig::default(), t0);
    exchange(&mut c, &mut s, t0, 1000);
    let _ = events(&mut s);
    s.refuse(
        Refusal::VersionMismatch {
            server: PROTOCOL_VERSION,
            client: 1,
        },
        t0,
    );
    exchange(&mut c, &mut s, t0, 1000);
    assert!(matches!(
        c.end(),
        Some(ClientConnectionEnd::Refused(
            Refusal::VersionMismatch { .. }
        ))
    ));
    assert!(c.is_closed());

    // Kicked: the goodbye's reason is the end, kept through the drain.
    let mut c = client(t0);
    let mut s = ServerConnection::new(ServerConnectionConfig::default(), t0);
    exchange(&mut c, &mut s, t0, 1000);
    let _ = events(&mut s);
    s.admit(&welcome(), t0);
    exchange(&mut c, &mut s, t0, 1000);
    s.kick("afk".into(), t0 + ms(5));
    exchange(&mut c, &mut s, t0 + ms(5), 1000);
    let kicked = DisconnectReason::Kicked {
        reason: "afk".into(),
    };
    let said: Vec<_> = std::iter::from_fn(|| c.poll_event()).collect();
    assert_eq!(
        said.last(),
        Some(&ClientConnectionEvent::Message(ServerControl::Goodbye(
            kicked.clone()
        )))
    );
    assert!(!c.reads_control(), "draining");
    c.on_lost(DisconnectReason::from_close(
        u64::from(close_code::KICKED),
        b"afk",
    ));
    assert_eq!(c.end(), Some(&ClientConnectionEnd::Disconnected(kicked)));
    assert_eq!(c.close_frame(), None, "the server closed it");
}

#[test]
fn a_client_gives_up_without_a_welcome_and_refuses_what_breaks_the_protocol() {
    let t0 = Instant::now();
    let mut c = client(t0);
    assert_eq!(c.poll_timeout(), Some(t0 + HANDSHAKE_TIMEOUT));
    c.handle_timeout(t0 + HANDSHAKE_TIMEOUT);
    assert_eq!(c.end(), Some(&ClientConnectionEnd::HandshakeTimeout));

    // A second welcome, a welcome with a zero rate (which no server can
    // code), garbage, and a message before the welcome.
    let mut zero = encode_frame(&welcome()).expect("encodes");
    let at = zero
        .windows(3)
        .position(|w| w == [100, 60, 30])
        .expect("the tick, then the rates, 60 and 30 Hz, as varints");
    zero[at + 1] = 0;
    let welcome_bytes = encode_frame(&welcome()).expect("encodes");
    let cases: Vec<Vec<u8>> = vec![
        [welcome_bytes.clone(), welcome_bytes.clone()].concat(),
        zero,
        u32::MAX.to_le_bytes().to_vec(),
        encode_frame(&ServerControl::Despawn { id: 1 }).expect("encodes"),
    ];
    for bytes in cases {
        let mut c = client(t0);
        c.on_control_data(&bytes, t0 + ms(1));
        assert!(
            matches!(c.end(), Some(ClientConnectionEnd::Protocol(_))),
            "{:?}",
            c.end()
        );
        assert_eq!(c.close_frame().map(|f| f.code), Some(close_code::PROTOCOL));
    }

    // The server's stream ends without a goodbye and it never closes:
    // the client gives up after the drain wait.
    let mut c = client(t0);
    c.on_control_data(&welcome_bytes, t0);
    c.on_control_finished(t0 + ms(10));
    let drained = t0 + ms(10) + inertia_protocol::connection::client::DRAIN_WAIT;
    assert_eq!(c.poll_timeout(), Some(drained));
    c.handle_timeout(drained);
    assert!(c.is_closed());
}

#[test]
fn issue_43_a_clients_messages_are_taken_in_order_and_a_flood_or_an_oversize_one_refused() {
    use inertia_protocol::connection::ReceivedMessage;
    use inertia_protocol::message::{
        Delivery, MessageDatagram, MessageLimits, MessageRefusal, MAX_MESSAGE_BYTES,
    };
    let t0 = Instant::now();
    let limits = MessageLimits {
        per_second: 10,
        burst: 4,
        bytes_per_second: 4096,
        byte_burst: 4096,
    };
    let mut c = client(t0);
    let mut s = ServerConnection::new(
        ServerConnectionConfig {
            messages: limits,
            ..ServerConnectionConfig::default()
        },
        t0,
    );
    // Not live yet: the client's connection refuses to send.
    assert_eq!(
        c.send_message(b"early".to_vec(), t0),
        Err(MessageRefusal::NotConnected)
    );
    exchange(&mut c, &mut s, t0 + ms(1), 1000);
    events(&mut s);
    s.admit(&welcome(), t0 + ms(2));
    exchange(&mut c, &mut s, t0 + ms(3), 1000);
    assert!(c.is_live() && s.is_live());
    assert!(matches!(
        c.poll_event(),
        Some(ClientConnectionEvent::Welcomed(_))
    ));

    // Three reliable messages, cut into 3-byte pieces on the stream, and
    // one unreliable one: taken in arrival order.
    for text in ["buy", "ready", "vote 2"] {
        c.send_message(text.as_bytes().to_vec(), t0 + ms(4))
            .unwrap();
    }
    exchange(&mut c, &mut s, t0 + ms(4), 3);
    let datagram = MessageDatagram::encode(b"ping").unwrap();
    assert_eq!(s.on_datagram(&datagram, t0 + ms(5)), Ok(None));
    let taken: Vec<_> = std::iter::from_fn(|| s.poll_message()).collect();
    let msg = |delivery, bytes: &[u8]| {
        Ok(ReceivedMessage {
            delivery,
            bytes: bytes.to_vec(),
        })
    };
    assert_eq!(
        taken,
        [
            msg(Delivery::Reliable, b"buy"),
            msg(Delivery::Reliable, b"ready"),
            msg(Delivery::Reliable, b"vote 2"),
            msg(Delivery::Unreliable, b"ping"),
        ]
    );

    // The burst is spent: a flood is refused message by message, counted
    // by the caller, and nothing waits.
    for _ in 0..100 {
        c.send_message(b"spam".to_vec(), t0 + ms(6)).unwrap();
    }
    exchange(&mut c, &mut s, t0 + ms(6), 1000);
    let flood: Vec<_> = std::iter::from_fn(|| s.poll_message()).collect();
    assert_eq!(flood.len(), 100);
    assert!(flood
        .iter()
        .all(|m| matches!(m, Err(MessageRefusal::RateLimited { .. }))));

    // An oversize message (a client that skips its SDK's check) is
    // refused too, and the connection lives on; so is a datagram tagged
    // as a message that holds too much.
    let later = t0 + ms(2000);
    let long = encode_frame(&ClientControl::Message(vec![1; MAX_MESSAGE_BYTES + 1])).unwrap();
    s.on_control_data(&long, later);
    assert!(matches!(
        s.poll_message(),
        Some(Err(MessageRefusal::TooLong { .. }))
    ));
    let mut long_datagram = vec![0x4D];
    long_datagram.extend_from_slice(&[0; MAX_MESSAGE_BYTES + 1]);
    assert_eq!(s.on_datagram(&long_datagram, later), Ok(None));
    assert!(matches!(
        s.poll_message(),
        Some(Err(MessageRefusal::TooLong { .. }))
    ));
    assert!(s.is_live());
    // Refilled at the rate: the next message passes.
    c.send_message(b"gg".to_vec(), later).unwrap();
    exchange(&mut c, &mut s, later, 1000);
    assert_eq!(s.poll_message(), Some(msg(Delivery::Reliable, b"gg")));

    // The server's reliable message reaches the client as a message.
    s.queue_control(
        &encode_frame(&ServerControl::Message(b"goal".to_vec())).unwrap(),
        later,
    );
    exchange(&mut c, &mut s, later, 1000);
    assert_eq!(
        c.poll_event(),
        Some(ClientConnectionEvent::Message(ServerControl::Message(
            b"goal".to_vec()
        )))
    );
}
