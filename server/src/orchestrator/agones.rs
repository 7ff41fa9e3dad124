//! The server's side of Agones: the async shell that calls the SDK server
//! (see the [module docs](super) for what it does and when).

use std::collections::BTreeSet;
use std::time::Duration;

use tokio::sync::watch;
use tokio::task::JoinHandle;
use tracing::{debug, info, warn};

use super::allocation::MatchSettings;
use super::heartbeat::{Beat, Heartbeat};
use super::sdk::{CounterUpdate, GameServer, List, Sdk, SdkError};
use super::{Allocation, Probe};

/// Agones's health period when the game server's spec does not say.
const DEFAULT_HEALTH_PERIOD: Duration = Duration::from_secs(5);
/// First and longest wait between tries of `Ready` and of the watch.
const RETRY_FIRST: Duration = Duration::from_millis(100);
const RETRY_MOST: Duration = Duration::from_secs(2);
/// Name of the counter and of the list that hold the players.
pub const PLAYERS: &str = "players";

/// The Agones tasks of a running server.
#[derive(Debug)]
pub(super) struct Agones {
    sdk: Sdk,
    tasks: Vec<JoinHandle<()>>,
}

impl Agones {
    /// Spawns the lifecycle (ready, then health pings and the players)
    /// and the watch of the game server.
    pub(super) fn start(
        sdk: Sdk,
        probe: Probe,
        allocated: watch::Sender<Option<Allocation>>,
    ) -> Agones {
        info!(sdk = %sdk.addr(), "working with Agones");
        let (ready_tx, ready_rx) = watch::channel(false);
        let tasks = vec![
            tokio::spawn(lifecycle(sdk.clone(), probe, ready_tx)),
            tokio::spawn(watch_game_server(sdk.clone(), ready_rx, allocated)),
        ];
        Agones { sdk, tasks }
    }

    /// Stops the pings and the watch, then calls `Shutdown`.
    pub(super) async fn shutdown(&self) {
        for task in &self.tasks {
            task.abort();
        }
        match self.sdk.shutdown().await {
            Ok(()) => info!("told Agones the game server is shut down"),
            Err(e) => warn!(error = %e, "could not tell Agones the game server is shut down"),
        }
    }
}

/// `Ready` (retried until the SDK server answers), then a health ping every
/// half period while the tick loop turns, and the players kept in step.
async fn lifecycle(sdk: Sdk, probe: Probe, ready: watch::Sender<bool>) {
    let mut wait = RETRY_FIRST;
    let mut tries = 0u64;
    loop {
        tries += 1;
        match sdk.ready().await {
            Ok(()) => break,
            Err(e) => {
                // The first failure, then one in ten: a sidecar that starts
                // late is normal, one that never does is worth seeing.
                if tries == 1 || tries % 10 == 0 {
                    warn!(error = %e, tries, "Agones Ready not accepted yet; retrying");
                }
                tokio::time::sleep(wait).await;
                wait = (wait * 2).min(RETRY_MOST);
            }
        }
    }
    info!(tries, "told Agones the game server is ready");
    ready.send_replace(true);
    let period = match sdk.game_server().await {
        Ok(gs) => health_period(&gs),
        Err(e) => {
            warn!(error = %e, "cannot read the game server; assuming Agones's default health period");
            DEFAULT_HEALTH_PERIOD
        }
    };
    let mut ticker = tokio::time::interval(period / 2);
    ticker.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut heartbeat = Heartbeat::new();
    let mut link = SdkReach::Up;
    let mut players = Players::new(probe.capacity);
    loop {
        ticker.tick().await;
        let beat = heartbeat.look((probe.loops)());
        match beat {
            Beat::Alive => {}
            Beat::Recovered => info!("the tick loop turns again; health pings resume"),
            Beat::Stalled { first: true } => warn!(
                "the tick loop has not turned for a health period; health pings stop \
                 (Agones marks the game server Unhealthy after its failure threshold)"
            ),
            Beat::Stalled { first: false } => {}
        }
        if beat.ping() {
            link.note(sdk.health().await);
        }
        if link == SdkReach::Up {
            players.sync(&sdk, (probe.players)()).await;
        }
    }
}

/// Half of the game server's health period is how often pings go.
fn health_period(gs: &GameServer) -> Duration {
    let s = gs.spec.health.period_seconds;
    if gs.spec.health.disabled || s <= 0 {
        DEFAULT_HEALTH_PERIOD
    } else {
        Duration::from_secs(s as u64)
    }
}

/// Whether the SDK server answered the last call: a change is logged once.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum SdkReach {
    Up,
    Down,
}

impl SdkReach {
    fn note<T>(&mut self, result: Result<T, SdkError>) {
        match (result, *self) {
            (Ok(_), SdkReach::Down) => {
                info!("the Agones SDK server answers again");
                *self = SdkReach::Up;
            }
            (Err(e), SdkReach::Up) => {
                warn!(error = %e, "the Agones SDK server went away; serving on and retrying");
                *self = SdkReach::Down;
            }
            _ => {}
        }
    }
}

/// What Agones holds of one of the players' counter and list.
#[derive(Debug)]
enum Reported<T> {
    /// The game server does not declare it: never sent again.
    Undeclared,
    /// Not known (nothing sent yet, or the last send failed): sent whole.
    Unknown,
    /// This, as last sent.
    Is(T),
}

/// The players as Agones last heard of them, in the counter and the list
/// `players`.
#[derive(Debug)]
struct Players {
    capacity: i64,
    counter: Reported<i64>,
    list: Reported<BTreeSet<u64>>,
}

impl Players {
    fn new(capacity: u32) -> Players {
        Players {
            capacity: i64::from(capacity),
            counter: Reported::Unknown,
            list: Reported::Unknown,
        }
    }

    async fn sync(&mut self, sdk: &Sdk, now: Vec<u64>) {
        let now: BTreeSet<u64> = now.into_iter().collect();
        let count = now.len() as i64;
        let counter_due = match self.counter {
            Reported::Undeclared => false,
            Reported::Unknown => true,
            Reported::Is(told) => told != count,
        };
        if counter_due {
            let update = CounterUpdate {
                count: Some(count),
                capacity: Some(self.capacity),
                count_diff: None,
            };
            match sdk.update_counter(PLAYERS, &update).await {
                Ok(_) => self.counter = Reported::Is(count),
                Err(e) if e.is_not_found() => {
                    info!("the game server declares no `players` counter; not counting players");
                    self.counter = Reported::Undeclared;
                }
                Err(e) => debug!(error = %e, "players counter not updated; retrying"),
            }
        }
        let result = match &self.list {
            Reported::Undeclared => return,
            Reported::Is(told) if *told == now => return,
            // Replaced whole when what Agones holds is unknown.
            Reported::Unknown => sdk
                .update_list(&List {
                    name: PLAYERS.to_string(),
                    capacity: self.capacity,
                    values: now.iter().map(u64::to_string).collect(),
                })
                .await
                .map(drop),
            Reported::Is(told) => change_list(sdk, told, &now).await,
        };
        self.list = match result {
            Ok(()) => Reported::Is(now),
            Err(e) if e.is_not_found() => {
                info!("the game server declares no `players` list; not listing players");
                Reported::Undeclared
            }
            Err(e) => {
                debug!(error = %e, "players list not updated; retrying");
                Reported::Unknown
            }
        };
    }
}

/// Adds and removes what differs between `told` and `now`.
async fn change_list(sdk: &Sdk, told: &BTreeSet<u64>, now: &BTreeSet<u64>) -> Result<(), SdkError> {
    for gone in told.difference(now) {
        sdk.remove_list_value(PLAYERS, &gone.to_string()).await?;
    }
    for came in now.difference(told) {
        sdk.add_list_value(PLAYERS, &came.to_string()).await?;
    }
    Ok(())
}

/// Watches the game server from `Ready` on; the first time it is
/// `Allocated`, reads the match settings and announces them.
async fn watch_game_server(
    sdk: Sdk,
    mut ready: watch::Receiver<bool>,
    allocated: watch::Sender<Option<Allocation>>,
) {
    if ready.wait_for(|r| *r).await.is_err() {
        return;
    }
    let mut wait = RETRY_FIRST;
    loop {
        match sdk.watch().await {
            Ok(mut stream) => {
                wait = RETRY_FIRST;
                loop {
                    match stream.next().await {
                        Ok(Some(gs)) => {
                            if gs.status.state == "Allocated" && allocated.borrow().is_none() {
                                allocated.send_replace(Some(allocation_of(&gs)));
                            }
                        }
                        Ok(None) => break,
                        Err(e) => {
                            debug!(error = %e, "the game server watch ended; watching again");
                            break;
                        }
                    }
                }
            }
            Err(e) => debug!(error = %e, "cannot watch the game server yet; retrying"),
        }
        tokio::time::sleep(wait).await;
        wait = (wait * 2).min(RETRY_MOST);
    }
}

/// The match an allocated game server asks for; refused values are
/// logged.
fn allocation_of(gs: &GameServer) -> Allocation {
    let meta = &gs.object_meta;
    let (settings, refused) = MatchSettings::from_metadata(&meta.labels, &meta.annotations);
    for e in refused {
        warn!(error = %e, "a match setting of the allocation is refused and left out");
    }
    info!(
        game_server = %meta.name,
        length_s = settings.length.map(|d| d.as_secs()),
        scene = settings.scene.as_deref(),
        rules = settings.rules.as_deref(),
        replay_seed = settings.replay_seed,
        "allocated"
    );
    Allocation {
        settings,
        at: std::time::Instant::now(),
    }
}
