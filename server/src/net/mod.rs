//! The game port: a quinn endpoint that accepts connections, checks each
//! client's hello and connect token, and then serves it (see
//! [`connection`]; its snapshots come from the one stage for every client,
//! [`snapshots`]). Everything here runs on tokio's I/O workers; the
//! physics runs on the simulation's own thread and is reached only through
//! the [`SimHandle`]'s channels and published frames.

pub(crate) mod admission;
pub mod catalog;
pub mod connection;
pub mod gate;
pub mod governor;
pub mod link;
pub mod replays;
pub mod snapshots;
pub mod streaming;
pub mod tls;
pub mod token_keys;
pub mod web_transport;

use std::collections::BTreeMap;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};

use inertia_protocol::admin::ADMIN_ALPN;
use inertia_protocol::connection::ServerConnectionConfig;
use inertia_protocol::control::DisconnectReason;
use inertia_protocol::control::WEB_TRANSPORT_ALPN;
use tokio::sync::watch;
use tracing::{debug, info};

use crate::admin::AdminShared;
use crate::metrics::Metrics;
use crate::sim::{Frame, SimHandle};
use gate::{Admission, GateConfig, HandshakeGate};
pub use streaming::Streaming;
pub use token_keys::ConnectTokens;

/// What every connection shares.
pub struct NetShared {
    /// The simulation.
    pub sim: Arc<SimHandle>,
    /// Metrics.
    pub metrics: Metrics,
    /// What connect tokens are opened and checked with.
    pub tokens: ConnectTokens,
    /// The snapshot stream every client gets.
    pub streaming: Streaming,
    /// Becomes the reason every client is given when the server stops
    /// (a shutdown, or the simulation failing).
    pub shutdown: watch::Receiver<Option<DisconnectReason>>,
    /// Recent frames by tick, so tests and tools can compare what clients
    /// saw with the truth (at most `history_len`; none by default).
    pub history: Mutex<BTreeMap<u64, Arc<Frame>>>,
    /// Frames kept in `history` ([`crate::config::ServerConfig::frame_history`]).
    history_len: usize,
    /// Connections numbered from 1.
    next_connection: AtomicU64,
    /// Clients connected now, by client id, with their connection number.
    pub connected: Mutex<BTreeMap<u64, u64>>,
    /// What the admin connections share.
    pub admin: Arc<AdminShared>,
    /// The clients the snapshot stage serves ([`snapshots::run`]).
    pub served: Arc<snapshots::ServedClients>,
    /// The deadlines of each game connection's life.
    pub connection: ServerConnectionConfig,
    /// The game's name, as its rules give it; every welcome carries it.
    pub game: String,
}

impl std::fmt::Debug for NetShared {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("NetShared")
            .field("public_addr", &self.tokens.public_addr)
            .field("snapshot_hz", &self.streaming.snapshot_hz)
            .finish_non_exhaustive()
    }
}

impl NetShared {
    /// Shared state for a server.
    pub fn new(
        sim: Arc<SimHandle>,
        metrics: Metrics,
        tokens: ConnectTokens,
        streaming: Streaming,
        shutdown: watch::Receiver<Option<DisconnectReason>>,
        admin: Arc<AdminShared>,
    ) -> Self {
        Self {
            sim,
            metrics,
            tokens,
            streaming,
            shutdown,
            history: Mutex::new(BTreeMap::new()),
            history_len: 0,
            next_connection: AtomicU64::new(1),
            connected: Mutex::new(BTreeMap::new()),
            admin,
            served: Arc::default(),
            connection: ServerConnectionConfig::default(),
            game: String::new(),
        }
    }

    /// The same, for the game named `game` (its rules' name).
    pub fn with_game(mut self, game: &str) -> Self {
        self.game = game.to_string();
        self
    }

    /// The same, keeping the last `frames` frames by tick (see
    /// [`Self::record_history`]).
    pub fn with_frame_history(mut self, frames: usize) -> Self {
        self.history_len = frames;
        self
    }

    /// The same, with `config`'s deadlines for each game connection.
    pub fn with_connection_config(mut self, config: ServerConnectionConfig) -> Self {
        self.connection = config;
        self
    }

    /// The frame of `tick`, if still held.
    pub fn frame_at(&self, tick: u64) -> Option<Arc<Frame>> {
        self.history.lock().ok()?.get(&tick).cloned()
    }

    /// Records every new frame into the history until shutdown; returns
    /// at once when no history is kept.
    pub async fn record_history(self: Arc<Self>) {
        if self.history_len == 0 {
            return;
        }
        let mut frames = self.sim.subscribe();
        let mut shutdown = self.shutdown.clone();
        loop {
            let frame = frames.borrow_and_update().clone();
            if let Ok(mut h) = self.history.lock() {
                h.insert(frame.tick, frame);
                while h.len() > self.history_len {
                    h.pop_first();
                }
            }
            tokio::select! {
                changed = frames.changed() => if changed.is_err() { return },
                _ = shutdown.changed() => return,
            }
        }
    }
}

/// Longest a QUIC handshake may take before its state is dropped.
pub const HANDSHAKE_TIMEOUT: std::time::Duration = std::time::Duration::from_secs(5);

/// The `reason` label of a failed handshake.
fn handshake_failure(e: &quinn::ConnectionError) -> &'static str {
    match e {
        // TLS alerts (no common ALPN, a bad certificate) close the
        // connection at the transport level.
        quinn::ConnectionError::TransportError(_) | quinn::ConnectionError::ConnectionClosed(_) => {
            "tls"
        }
        quinn::ConnectionError::TimedOut => "handshake_timeout",
        _ => "handshake",
    }
}

/// The protocol a connection negotiated (its ALPN), if any.
pub fn negotiated_alpn(connection: &quinn::Connection) -> Option<Vec<u8>> {
    connection
        .handshake_data()?
        .downcast::<quinn::crypto::rustls::HandshakeData>()
        .ok()?
        .protocol
}

/// One handshake in flight, counted from [`InFlight::enter`] until
/// dropped.
struct InFlight(Arc<AtomicUsize>);

impl InFlight {
    fn enter(count: &Arc<AtomicUsize>) -> InFlight {
        count.fetch_add(1, Ordering::Relaxed);
        InFlight(count.clone())
    }
}

impl Drop for InFlight {
    fn drop(&mut self) {
        self.0.fetch_sub(1, Ordering::Relaxed);
    }
}

/// Stops every unidirectional stream the peer of a raw QUIC connection
/// opens, unread: its protocols have none, and the endpoint grants them
/// only for HTTP/3's sake ([`tls::server_transport`]). Ends with the
/// connection.
pub async fn refuse_uni_streams(connection: quinn::Connection) {
    while let Ok(mut stream) = connection.accept_uni().await {
        let _ = stream.stop(0u32.into());
    }
}

/// Finishes the QUIC handshake of one incoming connection and serves it
/// as the protocol it chose: the admin channel or a game client.
async fn route(incoming: quinn::Incoming, id: u64, shared: Arc<NetShared>, handshake: InFlight) {
    let remote = incoming.remote_address();
    let connection = match tokio::time::timeout(HANDSHAKE_TIMEOUT, incoming).await {
        Ok(Ok(c)) => c,
        Ok(Err(e)) => {
            debug!(connection = id, %remote, error = %e, "handshake failed");
            shared.metrics.refused(handshake_failure(&e));
            return;
        }
        Err(_) => {
            debug!(connection = id, %remote, "handshake timed out");
            shared.metrics.refused("handshake_timeout");
            return;
        }
    };
    drop(handshake);
    let alpn = negotiated_alpn(&connection);
    if alpn.as_deref() != Some(WEB_TRANSPORT_ALPN) {
        tokio::spawn(refuse_uni_streams(connection.clone()));
    }
    match alpn.as_deref() {
        Some(ADMIN_ALPN) => crate::admin::serve(connection, id, shared.admin.clone()).await,
        Some(WEB_TRANSPORT_ALPN) => web_transport::serve(connection, id, shared).await,
        _ => connection::serve(link::Link::Quic(connection), id, shared).await,
    }
}

/// Accepts connections on `endpoint` until shutdown, serving each on its
/// own task. After a simulation failure it goes on accepting until the
/// process stops, so a client that tries to join is told why it cannot.
pub async fn accept(endpoint: quinn::Endpoint, shared: Arc<NetShared>, gate: GateConfig) {
    let mut shutdown = shared.shutdown.clone();
    let mut gate = HandshakeGate::new(gate);
    let in_flight = Arc::new(AtomicUsize::new(0));
    loop {
        tokio::select! {
            incoming = endpoint.accept() => {
                let Some(incoming) = incoming else { break };
                let remote = incoming.remote_address();
                let admission = gate.admit(
                    std::time::Instant::now(),
                    incoming.remote_address_validated(),
                    in_flight.load(Ordering::Relaxed),
                );
                match admission {
                    Admission::Accept => {}
                    Admission::Retry => {
                        debug!(%remote, "unproven address: asking for address validation (Retry)");
                        shared.metrics.handshake_retries.inc();
                        if let Err(e) = incoming.retry() {
                            // Cannot retry (already validated): refuse.
                            e.into_incoming().refuse();
                        }
                        continue;
                    }
                    Admission::Refuse => {
                        debug!(%remote, "too many handshakes in flight: refused");
                        shared.metrics.refused("handshake_limit");
                        incoming.refuse();
                        continue;
                    }
                }
                let id = shared.next_connection.fetch_add(1, Ordering::Relaxed);
                debug!(connection = id, %remote, "incoming");
                tokio::spawn(route(incoming, id, shared.clone(), InFlight::enter(&in_flight)));
            }
            changed = shutdown.changed() => {
                let stopping = matches!(*shutdown.borrow(), Some(DisconnectReason::ServerShutdown));
                if changed.is_err() || stopping {
                    break;
                }
            }
        }
    }
    info!("no longer accepting connections");
}
