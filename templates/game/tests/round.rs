//! The template plays a round over a real server, as its clients would:
//! two players join, say they are ready, one rolls into the orb beside
//! it, and both see its ball's orbs go to 1, the orbs left go down, and
//! the collection told; a chat line goes round.

use std::time::{Duration, Instant};

use inertia_client::dev::dev_token;
use std::sync::Arc;

use inertia_client::predict::PredictionConfig;
use inertia_client::{Client, ClientEvent, ConnectOptions, ControllerFactory};
use inertia_game_template::predict::Roller;
use inertia_game_template::properties::PLAYING;
use inertia_game_template::{Ask, Drive, OrbsRules, Tell};
use inertia_protocol::message::Delivery;
use inertia_protocol::property::PropertyValue;
use inertia_server::config::ServerConfig;
use inertia_server::server::start_game;

async fn until(what: &str, mut done: impl FnMut() -> bool) {
    let deadline = Instant::now() + Duration::from_secs(20);
    while !done() {
        assert!(Instant::now() < deadline, "{what}");
        tokio::time::sleep(Duration::from_millis(20)).await;
    }
}

fn told(client: &Client, into: &mut Vec<Tell>) {
    while let Some(e) = client.poll_event() {
        if let Some(Ok(tell)) = e.message::<Tell>() {
            into.push(tell);
        } else if let ClientEvent::Disconnected(why) = e {
            panic!("disconnected: {why:?}");
        }
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_round_of_orbs_over_a_real_server() {
    let dir = std::env::temp_dir().join(format!("orbs-round-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    let config = ServerConfig {
        listen: Some("127.0.0.1:0".parse().expect("literal")),
        metrics: "127.0.0.1:0".parse().expect("literal"),
        data_dir: dir.clone(),
        ..ServerConfig::default()
    };
    let scene = include_str!("../scenes/arena.ron");
    let server = start_game(config, Box::new(OrbsRules::default()), scene)
        .await
        .expect("the server starts");
    let credentials = server.credentials_path().expect("dev mode").to_path_buf();
    // Player 1 predicts its own ball with the game's roller; player 2
    // draws everything from snapshots.
    let predicting = ConnectOptions {
        predict: Some(PredictionConfig::default()),
        controller: Some(ControllerFactory(Arc::new(|| Box::new(Roller)))),
        ..ConnectOptions::default()
    };
    let join = |id, options: ConnectOptions| {
        let (addr, token, _) = dev_token(&credentials, Some(id)).expect("a token");
        async move {
            Client::connect_with(addr, &token, options)
                .await
                .expect("joins")
        }
    };
    let a = join(1, predicting).await;
    let b = join(2, ConnectOptions::default()).await;
    assert_eq!(a.server_info().input_bytes, 3);

    // Both ready: the round starts, with twelve orbs on the floor.
    for c in [&a, &b] {
        c.send_message(&Ask::Ready, Delivery::Reliable)
            .expect("sent");
    }
    until("the round plays", || {
        a.sample();
        a.match_property("phase") == Some(PropertyValue::UInt(PLAYING))
            && a.match_property("orbs_left") == Some(PropertyValue::UInt(12))
    })
    .await;

    // Player 1 rolls right, into the orb a stride from where it started.
    a.set_game_input(&Drive {
        stick: [127, 0],
        dash: false,
    })
    .expect("the game's input");
    let ball = a
        .entities()
        .into_iter()
        .find(|d| d.owner == Some(1))
        .map(|d| d.id)
        .expect("1's ball");
    let start = a.predicted_avatar().map(|p| p.predicted.x);
    let (mut to_a, mut to_b) = (Vec::new(), Vec::new());
    until("both see 1 holding an orb", || {
        a.sample();
        b.sample();
        told(&a, &mut to_a);
        told(&b, &mut to_b);
        let holds =
            |c: &Client| matches!(c.property(ball, "orbs"), Some(PropertyValue::UInt(n)) if n >= 1);
        holds(&a) && holds(&b)
    })
    .await;
    until("the collection told to 2", || {
        told(&b, &mut to_b);
        to_b.iter()
            .any(|t| matches!(t, Tell::Collected { client: 1, .. }))
    })
    .await;
    assert!(to_b.contains(&Tell::Started));
    // 1's own ball was predicted with the game's roller, and rolled right.
    let predicted = a.predicted_avatar().expect("1's ball predicted");
    assert_eq!(predicted.id, ball);
    assert!(
        predicted.predicted.x > start.unwrap_or(-6.0) + 0.5,
        "{predicted:?}"
    );
    // As of the tick 2 draws, which the collection reaches a little
    // after it is told.
    until("2 sees fewer orbs left", || {
        b.sample();
        matches!(b.match_property("orbs_left"), Some(PropertyValue::UInt(n)) if n < 12)
    })
    .await;

    // A chat line goes round.
    b.send_message(&Ask::Say("nice".into()), Delivery::Reliable)
        .expect("sent");
    until("1 hears 2", || {
        told(&a, &mut to_a);
        to_a.contains(&Tell::Said {
            client: 2,
            text: "nice".into(),
        })
    })
    .await;

    a.close().await;
    b.close().await;
    server.shutdown().await;
    let _ = std::fs::remove_dir_all(&dir);
}
