//! Whether a client may come in: its hello's token checked against the
//! current key and a replaced one in its grace period, room asked of the
//! tick thread (the rules may refuse, with their reason), and the welcome
//! it is told; the name a refusal is counted under in `/metrics`.
//!
//! The connection's shell ([`super::connection`]) asks when its state
//! machine hands it a hello, and tells the state machine the answer.

use std::time::{SystemTime, UNIX_EPOCH};

use inertia_protocol::control::{
    handshake, truncate_utf8, ClientControl, Refusal, ServerControl, SnapshotParams, TokenRefusal,
    MAX_REASON_BYTES,
};
use inertia_protocol::EntityId;
use tracing::info;

use super::NetShared;
use crate::rules;
use crate::sim::{CommandError, SimExit};

/// Seconds since the Unix epoch (0 before it), the clock connect tokens
/// are stamped with.
pub(crate) fn unix_now() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_secs())
}

/// The `reason` label of a refused hello.
pub(super) fn refusal_reason(refusal: &Refusal) -> &'static str {
    use inertia_protocol::control::TokenRefusal as T;
    match refusal {
        Refusal::VersionMismatch { .. } => "version_mismatch",
        Refusal::Token(T::Malformed) => "token_malformed",
        Refusal::Token(T::Forged) => "token_forged",
        Refusal::Token(T::Expired { .. }) => "token_expired",
        Refusal::Token(T::WrongServer { .. }) => "token_wrong_server",
        Refusal::Token(T::Reused) => "token_reused",
        Refusal::ServerFull => "server_full",
        Refusal::ShuttingDown => "shutting_down",
        Refusal::Malformed => "malformed_hello",
        Refusal::AlreadyConnected => "already_connected",
        Refusal::Busy => "busy",
        Refusal::SimulationStopped => "simulation_stopped",
        Refusal::Rejected { .. } => "rejected_by_rules",
    }
}

/// What a client is told when the rules refuse its join: the real reason.
fn join_refusal(client: u64, refusal: rules::JoinRefusal) -> Refusal {
    match refusal {
        rules::JoinRefusal::Full { .. } => Refusal::ServerFull,
        rules::JoinRefusal::AlreadyJoined(_) => Refusal::AlreadyConnected,
        rules::JoinRefusal::Unavailable => Refusal::Busy,
        refusal @ (rules::JoinRefusal::NoRoom | rules::JoinRefusal::Rules(_)) => {
            info!(client, reason = %refusal, "join refused by the rules");
            let mut reason = refusal.to_string();
            truncate_utf8(&mut reason, MAX_REASON_BYTES);
            Refusal::Rejected { reason }
        }
    }
}

/// Asks the tick thread to let `client` join: its avatar, or the real
/// reason it cannot.
async fn join(shared: &NetShared, client: u64) -> Result<Joined, Refusal> {
    let stopped = || not_running(shared).unwrap_or(Refusal::ShuttingDown);
    match shared.sim.request_join(client) {
        Ok(rx) => match rx.await {
            Ok(Ok(at)) => Ok(Joined {
                client,
                avatar: at.avatar,
                first_message: at.first_message,
            }),
            Ok(Err(refusal)) => Err(join_refusal(client, refusal)),
            // The tick thread dropped the question: it has stopped.
            Err(_) => Err(stopped()),
        },
        Err(CommandError::Busy) => Err(Refusal::Busy),
        Err(CommandError::Stopped) => Err(stopped()),
    }
}

/// Why nobody can join now: the simulation failed, or the server is
/// shutting down; `None` while it runs.
fn not_running(shared: &NetShared) -> Option<Refusal> {
    match shared.sim.exit() {
        Some(SimExit::Failed { .. }) => Some(Refusal::SimulationStopped),
        Some(SimExit::Shutdown) => Some(Refusal::ShuttingDown),
        None if shared.shutdown.borrow().is_some() => Some(Refusal::ShuttingDown),
        None => None,
    }
}

/// A client the world let in.
#[derive(Debug, Clone, Copy)]
pub(super) struct Joined {
    /// Its id, from its token.
    pub(super) client: u64,
    /// Its avatar's entity.
    pub(super) avatar: EntityId,
    /// The first of the rules' messages that is news to it.
    pub(super) first_message: u64,
}

/// Checks connection `connection`'s hello and asks the world for room:
/// the client and its welcome, or why not.
pub(super) async fn admit(
    shared: &NetShared,
    connection: u64,
    hello: &ClientControl,
) -> Result<(Joined, ServerControl), Refusal> {
    let token = {
        let now = unix_now();
        let keys = shared.tokens.keys.read().unwrap_or_else(|e| e.into_inner());
        let mut guard = shared
            .tokens
            .guard
            .lock()
            .unwrap_or_else(|e| e.into_inner());
        // The current key, then a replaced one still in its grace
        // period: a token only one of them seals is forged under the
        // other.
        let mut result = Err(Refusal::Token(TokenRefusal::Forged));
        for key in keys.at(now) {
            result = handshake(
                hello,
                now,
                key,
                &shared.tokens.public_addr,
                connection,
                &mut guard,
            );
            if !matches!(result, Err(Refusal::Token(TokenRefusal::Forged))) {
                break;
            }
        }
        result?
    };
    if let Some(refusal) = not_running(shared) {
        return Err(refusal);
    }
    let joined = join(shared, token.client_id).await?;
    let frame = shared.sim.frame();
    let welcome = ServerControl::Welcome {
        client_id: joined.client,
        tick: frame.tick,
        tick_hz: shared.streaming.tick_hz,
        snapshot_hz: shared.streaming.snapshot_hz,
        position_resolution: shared.streaming.snapshot.grid.resolution,
        position_bound: shared.streaming.snapshot.grid.bound,
        snapshot: SnapshotParams::from_config(&shared.streaming.snapshot),
        input_bytes: shared.connection.input_bytes.unwrap_or(0) as u16,
        server_version: env!("CARGO_PKG_VERSION").to_string(),
        game: shared.game.clone(),
        properties: (*shared.streaming.properties).clone(),
    };
    Ok((joined, welcome))
}
