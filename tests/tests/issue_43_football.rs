//! The example game plays a whole match over a bad network: four bots on
//! two teams join `inertia-football`'s rules through the link conditioner
//! (100 ms round trip, 2 % loss each way), play until a team wins, and every
//! client sees the same goals, the same score and the same winner, as
//! messages and as replicated properties. Then a seek back to the first
//! goal's tick reproduces the state hash recorded live on that tick: the
//! world, the rules' own state and the properties.

use std::collections::BTreeMap;
use std::time::{Duration, Instant};

use inertia_client::{Client, ClientEvent};
use inertia_football::bot::{view_of, Bot};
use inertia_football::properties::{Phase, Team};
use inertia_football::{FootballRules, FootballSettings, Tell, PITCH};
use inertia_protocol::admin::{AdminRequest, AdminResponse};
use inertia_protocol::property::PropertyValue;
use inertia_server::server::start_game;
use inertia_tests::admin::{admin, call};
use inertia_tests::server::{test_config, token};
use inertia_tests::{Conditioner, Impairment};

/// What one client was told and sees.
#[derive(Debug, Default)]
struct Seen {
    goals: Vec<Tell>,
    over: Option<Tell>,
}

fn listen(client: &Client, seen: &mut Seen) {
    while let Some(event) = client.poll_event() {
        if let ClientEvent::Disconnected(why) = &event {
            panic!("client {} left: {why:?}", client.client_id());
        }
        match event.message::<Tell>() {
            Some(Ok(goal @ Tell::Goal { .. })) => seen.goals.push(goal),
            Some(Ok(over @ Tell::Over { .. })) => seen.over = Some(over),
            Some(Err(e)) => panic!("a message the game does not define: {e}"),
            _ => {}
        }
    }
}

fn uint(client: &Client, name: &str) -> Option<u64> {
    match client.match_property(name) {
        Some(PropertyValue::UInt(n)) => Some(n),
        _ => None,
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_43_four_bots_play_football_to_a_winner_that_every_client_sees() {
    let settings = FootballSettings {
        match_seconds: 60.0,
        goals_to_win: 2,
        kickoff_seconds: 1.0,
        ..FootballSettings::default()
    };
    let config = test_config(None, "football");
    let data = config.data_dir.clone();
    let server = start_game(config, Box::new(FootballRules::new(settings)), PITCH)
        .await
        .expect("the football server starts");
    let link = Impairment::half_rtt(Duration::from_millis(100), Duration::ZERO, 0.02);
    let conditioner = Conditioner::start(server.addr(), link, link, 43)
        .await
        .expect("conditioner");
    let mut clients = Vec::new();
    for id in 1..=4 {
        let (_, token) = token(&server, id);
        let client = Client::connect(conditioner.addr(), &token)
            .await
            .expect("joins through the conditioner");
        assert_eq!(client.server_info().game, "football");
        clients.push(client);
    }
    let mut bots: Vec<Bot> = clients.iter().map(|_| Bot::new()).collect();
    let mut seen: Vec<Seen> = clients.iter().map(|_| Seen::default()).collect();

    // Play, a tick at a time, until every client has heard the final
    // whistle (or a bound that a match of two goals never nears).
    let started = Instant::now();
    let deadline = started + Duration::from_secs(240);
    let mut teams = BTreeMap::new();
    while seen.iter().any(|s| s.over.is_none()) {
        assert!(
            Instant::now() < deadline,
            "no winner after {:?}: {:?}",
            started.elapsed(),
            seen.iter().map(|s| &s.goals).collect::<Vec<_>>()
        );
        for ((client, bot), seen) in clients.iter().zip(&mut bots).zip(&mut seen) {
            listen(client, seen);
            if let Some(view) = view_of(client) {
                teams.insert(client.client_id(), view.team);
                client
                    .set_game_input(&bot.play(&view))
                    .expect("the game's input");
            }
        }
        tokio::time::sleep(Duration::from_millis(16)).await;
    }
    let played = started.elapsed();

    // Two teams of two.
    let reds = teams.values().filter(|t| **t == Team::Red).count();
    assert_eq!((reds, teams.len()), (2, 4), "{teams:?}");

    // Every client heard the same goals and the same result.
    let first = &seen[0];
    let Some(Tell::Over { winner, score }) = first.over.clone() else {
        unreachable!("the loop ends on it")
    };
    assert!(first.goals.len() >= 2, "{:?}", first.goals);
    for (k, s) in seen.iter().enumerate() {
        assert_eq!(s.goals, first.goals, "client {} heard other goals", k + 1);
        assert_eq!(s.over, first.over, "client {} heard another result", k + 1);
    }
    let winner_goals = score[usize::from(winner == Team::Blue)];
    assert!(
        winner_goals > score[usize::from(winner == Team::Red)],
        "{score:?}"
    );
    assert_eq!(winner_goals, 2, "the first to two");

    // And every client's replicated match state settles on it.
    let settle = Instant::now() + Duration::from_secs(10);
    loop {
        let agreed = clients.iter().all(|c| {
            c.sample();
            uint(c, "score_red") == Some(u64::from(score[0]))
                && uint(c, "score_blue") == Some(u64::from(score[1]))
                && uint(c, "winner") == Some(u64::from(winner.code()))
                && uint(c, "phase") == Some(u64::from(Phase::Over.code()))
        });
        if agreed {
            break;
        }
        assert!(
            Instant::now() < settle,
            "the clients' properties never agreed"
        );
        tokio::time::sleep(Duration::from_millis(20)).await;
    }

    // A seek back to the first goal's tick reproduces its recorded hash.
    let Some(Tell::Goal {
        tick: goal_tick, ..
    }) = first.goals.first().cloned()
    else {
        unreachable!("at least two goals")
    };
    let mut admin = admin(&server).await;
    let reply = call(&mut admin, AdminRequest::Seek { tick: goal_tick }).await;
    let AdminResponse::Hash {
        tick,
        state_hash,
        recorded_hash,
    } = reply
    else {
        panic!("a seek answers a hash: {reply:?}");
    };
    assert_eq!(tick, goal_tick);
    assert_eq!(
        recorded_hash,
        Some(state_hash),
        "the first goal's tick, re-simulated, hashes as recorded"
    );
    println!(
        "football: {} goals, {} won {}–{} in {:.1} s of wall time; the first goal on tick {goal_tick} reproduced ({state_hash:#018x})",
        first.goals.len(),
        winner.name(),
        score[0],
        score[1],
        played.as_secs_f64()
    );

    admin.close().await;
    for c in clients {
        c.close().await;
    }
    server.shutdown().await;
    let _ = std::fs::remove_dir_all(data);
}
