//! The game's replicated state over a real server: the stock sandbox
//! declares each avatar's jumps and pushes and the match's players; a
//! client holds them as the rules set them, hears each change, and reads
//! them by name; a second client sees the first's.

use std::time::{Duration, Instant};

use inertia_client::{Client, ClientEvent};
use inertia_protocol::property::PropertyValue;
use inertia_sandbox::buttons;
use inertia_tests::server::{start_server, test_config, token};

async fn until(what: &str, mut done: impl FnMut() -> bool) {
    let deadline = Instant::now() + Duration::from_secs(15);
    while !done() {
        assert!(Instant::now() < deadline, "{what}");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_43_properties_reach_every_client_and_are_read_by_name() {
    let server = start_server(test_config(None, "properties")).await;
    let (addr, t7) = token(&server, 7);
    let (_, t8) = token(&server, 8);
    let a = Client::connect(addr, &t7).await.expect("7 joins");
    let schema = a.property_schema();
    assert_eq!(schema.entity_index("jumps"), Some(0));
    assert_eq!(schema.match_index("players"), Some(0));
    until("7 sees one player", || {
        a.sample();
        a.match_property("players") == Some(PropertyValue::UInt(1))
    })
    .await;

    let b = Client::connect(addr, &t8).await.expect("8 joins");
    until("both see two players", || {
        a.sample();
        b.sample();
        a.match_property("players") == Some(PropertyValue::UInt(2))
            && b.match_property("players") == Some(PropertyValue::UInt(2))
    })
    .await;

    // 7 jumps a few times: its avatar's count goes up, on both clients.
    let avatar = a
        .entities()
        .into_iter()
        .find(|d| d.owner == Some(7))
        .map(|d| d.id)
        .expect("7's avatar described");
    let mut changed = false;
    let jumped = |c: &Client| {
        c.sample();
        matches!(c.property(avatar, "jumps"), Some(PropertyValue::UInt(n)) if n >= 2)
    };
    let deadline = Instant::now() + Duration::from_secs(15);
    let mut press = false;
    while !(jumped(&a) && jumped(&b)) {
        assert!(Instant::now() < deadline, "two jumps seen by both");
        press = !press;
        let held = if press { buttons::JUMP } else { 0 };
        a.set_input([0.0, 0.0], 0.0, held).expect("input");
        tokio::time::sleep(Duration::from_millis(300)).await;
        while let Some(e) = a.poll_event() {
            changed |= matches!(e, ClientEvent::PropertiesChanged { entity: Some(id), .. } if id == avatar);
        }
    }
    assert!(changed, "7 was told its avatar's properties changed");
    assert_eq!(b.property(avatar, "pushes"), Some(PropertyValue::UInt(0)));
    assert!(a.entities_with_properties().contains(&avatar));

    // 8 leaves: the players go down to one.
    b.close().await;
    until("one player again", || {
        a.sample();
        a.match_property("players") == Some(PropertyValue::UInt(1))
    })
    .await;
    a.close().await;
    server.shutdown().await;
}
