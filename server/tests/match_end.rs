//! A match ends when its time is up (`--match-seconds`) or when the game
//! rules say so: every client is told `MatchOver` with the reason, and the
//! server drains and stops with its recording ended.

use std::time::Duration;

use inertia_protocol::control::DisconnectReason;
use inertia_protocol::{EntityId, PlayerInput};
use inertia_server::config::ServerConfig;
use inertia_server::orchestrator::OrchestratorMode;
use inertia_server::rules::{
    ClientId, GameRules, InputRefusal, JoinRefusal, SandboxRules, SimContext,
};
use inertia_server::server::{start, start_with_rules, RunningServer};

use crate::common::player::Player;

fn config(what: &str, match_seconds: Option<u64>) -> ServerConfig {
    let dir = std::env::temp_dir().join(format!("inertia-match-{what}-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&dir);
    ServerConfig {
        listen: Some("127.0.0.1:0".parse().expect("literal")),
        metrics: "127.0.0.1:0".parse().expect("literal"),
        data_dir: dir,
        orchestrator: OrchestratorMode::Standalone,
        match_seconds,
        ..ServerConfig::default()
    }
}

/// A client in the game, joined on the blocking pool.
async fn join(server: &RunningServer) -> Player {
    let credentials = server.credentials_path().expect("dev mode").clone();
    tokio::task::spawn_blocking(move || Player::join_dev(&credentials, None).expect("joins"))
        .await
        .expect("joined")
}

/// Ends `server`'s match as the process does, and returns what `client`
/// was told.
async fn end_and_hear(server: RunningServer, client: Player) -> Option<DisconnectReason> {
    let why = tokio::time::timeout(Duration::from_secs(10), server.match_over())
        .await
        .expect("the match ends");
    server.end_match(why).await;
    tokio::task::spawn_blocking(move || {
        let deadline = std::time::Instant::now() + Duration::from_secs(5);
        while client.disconnected().is_none() && std::time::Instant::now() < deadline {
            std::thread::sleep(Duration::from_millis(20));
        }
        client.disconnected()
    })
    .await
    .expect("heard")
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_14_match_seconds_ends_the_match_and_clients_are_told() {
    let server = start(config("seconds", Some(2))).await.expect("starts");
    let client = join(&server).await;
    let started = std::time::Instant::now();
    let heard = end_and_hear(server, client).await;
    assert!(started.elapsed() >= Duration::from_millis(1500));
    assert_eq!(
        heard,
        Some(DisconnectReason::MatchOver {
            reason: "the match's time is up".into()
        })
    );
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_14_a_match_without_a_length_does_not_end() {
    let server = start(config("endless", None)).await.expect("starts");
    let over = tokio::time::timeout(Duration::from_secs(2), server.match_over()).await;
    assert!(
        over.is_err(),
        "a match with no length and no rules' end went on"
    );
    server.shutdown().await;
}

/// The sandbox, ending the match after `ticks` ticks.
struct EndsAfter {
    inner: SandboxRules,
    ticks: u64,
    seen: u64,
}

impl GameRules for EndsAfter {
    fn input_bytes(&self) -> usize {
        self.inner.input_bytes()
    }
    fn on_connect(
        &mut self,
        c: ClientId,
        ctx: &mut SimContext<'_>,
    ) -> Result<EntityId, JoinRefusal> {
        self.inner.on_connect(c, ctx)
    }
    fn on_disconnect(&mut self, c: ClientId, ctx: &mut SimContext<'_>) {
        self.inner.on_disconnect(c, ctx)
    }
    fn on_input(
        &mut self,
        c: ClientId,
        input: &PlayerInput,
        ctx: &mut SimContext<'_>,
    ) -> Result<(), InputRefusal> {
        self.inner.on_input(c, input, ctx)
    }
    fn before_tick(&mut self, ctx: &mut SimContext<'_>) {
        self.inner.before_tick(ctx)
    }
    fn after_tick(&mut self, ctx: &mut SimContext<'_>) {
        self.seen += 1;
        self.inner.after_tick(ctx)
    }
    fn match_over(&self) -> Option<String> {
        (self.seen >= self.ticks).then(|| "red team captured the flag".to_string())
    }
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_14_the_game_rules_end_the_match_with_their_reason() {
    let rules = EndsAfter {
        inner: SandboxRules::default(),
        ticks: 90,
        seen: 0,
    };
    let server = start_with_rules(config("rules", None), Box::new(rules))
        .await
        .expect("starts");
    let client = join(&server).await;
    let heard = end_and_hear(server, client).await;
    assert_eq!(
        heard,
        Some(DisconnectReason::MatchOver {
            reason: "red team captured the flag".into()
        })
    );
}

/// A fleet keeps its matches on a volume of their own (`--matches-dir`),
/// another file system than the data directory: the recording is copied
/// there whole, and the live one removed.
#[cfg(target_os = "linux")]
#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn issue_14_a_match_is_kept_on_another_file_system() {
    // /dev/shm is a tmpfs; the data directory is not.
    let shared = std::path::Path::new("/dev/shm")
        .join(format!("inertia-matches-elsewhere-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&shared);
    let mut config = config("elsewhere", Some(1));
    config.matches_dir = Some(shared.clone());
    let recording = config.recording_dir();
    let server = start(config).await.expect("starts");
    let why = tokio::time::timeout(Duration::from_secs(10), server.match_over())
        .await
        .expect("the match ends");
    let name = server.end_match(why).await.expect("kept");
    assert!(!recording.exists(), "the live recording is gone");
    let kept = shared.join(name.as_str());
    let records: Vec<_> = inertia_server::record::RecordReader::open(&kept)
        .expect("the kept recording")
        .iter()
        .collect::<Result<_, _>>()
        .expect("whole");
    assert!(matches!(
        records.last(),
        Some(inertia_server::record::Record::Keyframe { .. })
    ));
    let _ = std::fs::remove_dir_all(&shared);
}
