//! The game's messages both ways over a real server: a client's chat line
//! goes to the sandbox's rules and back to every client (the sender
//! included, whose own join it also heard); a respawn asked unreliably
//! moves the avatar; a flood past the client's rate, an oversize message
//! and bytes the game does not define are refused and counted per client
//! and reason while the other client plays on; a client's series go when
//! it leaves.

use std::time::{Duration, Instant};

use inertia_client::{Client, ClientError, ClientEvent};
use inertia_protocol::message::{
    Delivery, MessageDatagram, MessageRefusal, MAX_MESSAGE_BYTES, MESSAGE_DATAGRAM_TAG,
};
use inertia_sandbox::{SandboxEvent, SandboxRequest};
use inertia_tests::server::{start_server, test_config, token};

async fn until(what: &str, mut done: impl FnMut() -> bool) {
    let deadline = Instant::now() + Duration::from_secs(10);
    while !done() {
        assert!(Instant::now() < deadline, "{what}");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

/// The sandbox events `client` has been told since the last call.
fn heard(client: &Client, into: &mut Vec<(Delivery, SandboxEvent)>) {
    while let Some(e) = client.poll_event() {
        if let ClientEvent::Message { delivery, .. } = &e {
            let event = e
                .message::<SandboxEvent>()
                .expect("a message")
                .expect("a sandbox event");
            into.push((*delivery, event));
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_43_messages_go_both_ways_and_a_flood_is_refused_and_counted() {
    let server = start_server(test_config(None, "messages")).await;
    let (addr, t7) = token(&server, 7);
    let (_, t8) = token(&server, 8);
    let a = Client::connect(addr, &t7).await.expect("7 joins");
    let b = Client::connect(addr, &t8).await.expect("8 joins");
    let m = server.metrics();
    let (mut to_a, mut to_b) = (Vec::new(), Vec::new());

    // Each client hears its own join: what the rules say as it joins is
    // news to it.
    until("7 hears its join", || {
        heard(&a, &mut to_a);
        to_a.iter()
            .any(|(_, e)| matches!(e, SandboxEvent::Joined { client: 7, .. }))
    })
    .await;

    // A chat line, reliable: to the rules, and back to everyone.
    let line = SandboxRequest::Chat {
        text: "gg — well played".into(),
    };
    a.send_message(&line, Delivery::Reliable).expect("sent");
    let said = |to: &[(Delivery, SandboxEvent)]| {
        to.iter().any(|(d, e)| {
            *d == Delivery::Reliable
                && matches!(e, SandboxEvent::Chat { client: 7, text } if text == "gg — well played")
        })
    };
    until("both hear the chat", || {
        heard(&a, &mut to_a);
        heard(&b, &mut to_b);
        said(&to_a) && said(&to_b)
    })
    .await;

    // A respawn asked unreliably: the avatar is made anew, and everyone
    // is told.
    a.send_message(&SandboxRequest::Respawn, Delivery::Unreliable)
        .expect("sent");
    until("8 hears 7 respawn", || {
        heard(&b, &mut to_b);
        to_b.iter()
            .any(|(_, e)| matches!(e, SandboxEvent::Respawned { client: 7, .. }))
    })
    .await;
    assert!(
        m.messages_received
            .get_or_create(&[("delivery", "unreliable")])
            .get()
            >= 1
    );

    // A flood: far past the burst. The connection refuses the excess as
    // it arrives; the rules see at most the burst and the rate.
    let ticks_before = server.frame().tick;
    let started = Instant::now();
    for i in 0..600 {
        let spam = SandboxRequest::Chat {
            text: format!("spam {i}"),
        };
        a.send_message(&spam, Delivery::Reliable).expect("sent");
    }
    until("the flood refused", || {
        m.messages_refused_count(7, "rate") >= 400
    })
    .await;
    let taken = m
        .messages_received
        .get_or_create(&[("delivery", "reliable")])
        .get();
    assert!(
        taken <= 1 + 60 + 60,
        "{taken} taken: the burst and about two seconds at the rate at most"
    );

    // The other client plays on: its snapshots keep coming, and the tick
    // kept its rate.
    let seen = b.stats().snapshots_received;
    until("8's snapshots keep coming", || {
        b.stats().snapshots_received > seen + 10
    })
    .await;
    let ticks = server.frame().tick - ticks_before;
    let expected = started.elapsed().as_secs_f64() * 60.0;
    assert!(
        ticks as f64 > 0.8 * expected,
        "{ticks} ticks in {:?}",
        started.elapsed()
    );
    assert_eq!(m.messages_refused_count(8, "rate"), 0);

    // The SDK refuses an oversize message before sending; a raw one is
    // refused by the server's connection, which lives on.
    assert!(matches!(
        a.send_message_bytes(vec![0; MAX_MESSAGE_BYTES + 1], Delivery::Reliable),
        Err(ClientError::Message(MessageRefusal::TooLong { .. }))
    ));
    let mut oversize = vec![MESSAGE_DATAGRAM_TAG];
    oversize.extend_from_slice(&[1; MAX_MESSAGE_BYTES + 1]);
    a.send_raw_datagram(oversize).expect("sent");
    until("the oversize datagram refused", || {
        m.messages_refused_count(7, "too_long") >= 1
    })
    .await;

    // Bytes the game does not define (after the rate refills): refused by
    // its decoder on the tick thread.
    tokio::time::sleep(Duration::from_millis(300)).await;
    a.send_raw_datagram(MessageDatagram::encode(&[9, 9]).unwrap())
        .expect("sent");
    until("the undecodable message refused", || {
        m.messages_refused_count(7, "undecodable") >= 1
    })
    .await;
    assert!(a.disconnected().is_none(), "7 is still in the game");

    // 7 leaves: its series go.
    a.close().await;
    until("7's series gone", || {
        m.messages_refused_count(7, "rate") == 0 && m.messages_refused_count(7, "too_long") == 0
    })
    .await;
    b.close().await;
    server.shutdown().await;
}
