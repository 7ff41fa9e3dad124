//! One client's connection: the hello and token check, then a single loop
//! that sends what the snapshot stage ([`super::snapshots`]) made at the
//! client's slots that had control messages (its catalog changes and
//! events on the reliable control stream, then its snapshot datagram, so
//! that both leave in one packet; the stage queues a snapshot without
//! them itself), feeds the client's datagrams (acks and inputs) into its
//! [`ServerSession`], which it shares with the stage, and the inputs on
//! to the simulation, and says goodbye on shutdown.
//!
//! Nothing here waits on a client without a deadline. The client has
//! [`HELLO_TIMEOUT`] to say hello and as long again to take its welcome;
//! a client that does not is let go, and leaves the world if it had
//! joined. After the welcome, control messages go through an [`Outbox`]
//! that the loop writes from as the client's flow-control window allows,
//! so a client that stops reading still gets snapshots, is still read,
//! kicked and told of a shutdown, and is dropped once its control stream
//! has not moved for [`CONTROL_STALL`] (or more than [`OUTBOX_LIMIT`]
//! bytes wait for it). A joined client that sends no datagram for
//! [`SILENT_TIMEOUT`] is let go too. Goodbyes wait at most
//! [`GOODBYE_WAIT`].

use std::future::Future;
use std::sync::Arc;
use std::time::{Duration, SystemTime, UNIX_EPOCH};

use glam::DVec3;
use inertia_protocol::control::{
    encode_frame, handshake, truncate_utf8, ClientControl, DisconnectReason, FrameDecoder, Refusal,
    ServerControl, SnapshotParams, TokenRefusal, MAX_REASON_BYTES,
};
use inertia_protocol::{EntityId, EntityKind, ServerSession, SessionConfig};
use tracing::{debug, info, info_span, warn, Instrument};

use super::link::{Link, LinkError, LinkRecv, LinkSend};
use super::snapshots::Served;
use super::NetShared;
use crate::rules;
use crate::sim::{CommandError, Frame, SimExit};

/// How long a client has to open its control stream and say hello, and
/// then again to take the answer.
pub const HELLO_TIMEOUT: Duration = Duration::from_secs(5);
/// Longest a client may leave its control stream unread while the server
/// has something for it (the connection's idle timeout).
pub const CONTROL_STALL: Duration = super::tls::IDLE_TIMEOUT;
/// Most control-stream bytes that may wait for a client; beyond, it is
/// dropped as too far behind (a full catalog of `--max-bodies` bodies is
/// well under this).
pub const OUTBOX_LIMIT: usize = 16 << 20;
/// Longest a joined client may send no datagram (its acknowledgements
/// and inputs, which the SDK sends at its input rate whatever the player
/// does) before it is let go. QUIC keep-alives alone do not count: a
/// client that stops playing but keeps its connection open would hold a
/// slot, an avatar and full snapshots without a baseline forever.
pub const SILENT_TIMEOUT: Duration = super::tls::IDLE_TIMEOUT;
/// Longest a goodbye (and what is queued before it) waits for the
/// client's window.
pub const GOODBYE_WAIT: Duration = Duration::from_secs(1);

/// QUIC close codes the server uses (the protocol's).
pub use inertia_protocol::control::close_code;

pub(crate) fn unix_now() -> u64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_secs())
}

/// Why serving a client stopped.
#[derive(Debug)]
enum End {
    /// The connection closed or failed.
    Closed(String),
    /// The client said goodbye.
    Goodbye,
    /// The client broke the protocol on the control stream.
    Protocol(String),
    /// The server is stopping, for this reason.
    Shutdown(DisconnectReason),
    /// An operator kicked the client.
    Kicked(String),
}

async fn write(send: &mut LinkSend, msg: &ServerControl) -> Result<usize, String> {
    let bytes = encode_frame(msg).map_err(|e| e.to_string())?;
    send.write_all(&bytes).await.map_err(|e| e.to_string())?;
    Ok(bytes.len())
}

/// The `reason` label of a refused hello.
fn refusal_reason(refusal: &Refusal) -> &'static str {
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
fn join_refusal(client: u64, refusal: rules::Refusal) -> Refusal {
    match refusal {
        rules::Refusal::Full { .. } => Refusal::ServerFull,
        rules::Refusal::AlreadyJoined(_) => Refusal::AlreadyConnected,
        rules::Refusal::Unavailable => Refusal::Busy,
        refusal @ (rules::Refusal::NoRoom | rules::Refusal::Rules(_)) => {
            info!(client, reason = %refusal, "join refused by the rules");
            let mut reason = refusal.to_string();
            truncate_utf8(&mut reason, MAX_REASON_BYTES);
            Refusal::Rejected { reason }
        }
    }
}

/// Asks the tick thread to let `client` join: its avatar, or the real
/// reason it cannot.
async fn join(shared: &NetShared, client: u64) -> Result<(u64, EntityId), Refusal> {
    let stopped = || not_running(shared).unwrap_or(Refusal::ShuttingDown);
    match shared.sim.request_join(client) {
        Ok(rx) => match rx.await {
            Ok(Ok(avatar)) => Ok((client, avatar)),
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

/// Serves one game connection to its end.
pub async fn serve(connection: Link, id: u64, shared: Arc<NetShared>) {
    let span = info_span!("connection", id, remote = %connection.remote_address(), web = connection.is_web_transport(), client = tracing::field::Empty);
    async move {
        if let Some(admitted) = hello(&connection, id, &shared).await {
            run(connection, admitted, &shared).await
        }
    }
    .instrument(span)
    .await
}

/// Lets go of a client that did not say hello, or take the answer, in
/// time.
fn too_slow(connection: &Link, shared: &NetShared) {
    debug!("no hello in time");
    shared.metrics.refused("hello_timeout");
    connection.close(close_code::REFUSED, b"no hello in time");
}

/// A client past its hello.
struct Admitted {
    client: u64,
    avatar: EntityId,
    send: LinkSend,
    recv: LinkRecv,
    frames: FrameDecoder,
}

/// Reads the hello and answers it; `None` when the client was refused,
/// too slow or vanished. The client's part (opening the stream, the
/// hello, taking the answer) is bounded by [`HELLO_TIMEOUT`]; the join,
/// the tick thread's part, is not. A client that joined but did not take
/// its welcome leaves again.
async fn hello(connection: &Link, id: u64, shared: &NetShared) -> Option<Admitted> {
    let read = async {
        let (send, mut recv) = connection.accept_bi().await.ok()?;
        let mut frames = FrameDecoder::new();
        let mut buf = [0u8; 2048];
        let msg = loop {
            if let Some(msg) = frames.next::<ClientControl>() {
                break msg.map_err(|e| e.to_string());
            }
            match recv.read(&mut buf).await {
                Ok(Some(n)) => {
                    if let Err(e) = frames.push(&buf[..n]) {
                        break Err(e.to_string());
                    }
                }
                _ => return None,
            }
        };
        Some((send, recv, frames, msg))
    };
    let (mut send, recv, frames, msg) = match tokio::time::timeout(HELLO_TIMEOUT, read).await {
        Ok(Some(read)) => read,
        Ok(None) => return None,
        Err(_) => {
            too_slow(connection, shared);
            return None;
        }
    };
    let result = match msg {
        Ok(hello) => {
            let now = unix_now();
            let keys = shared.token_keys.read().unwrap_or_else(|e| e.into_inner());
            let mut guard = shared.guard.lock().unwrap_or_else(|e| e.into_inner());
            // The current key, then a replaced one still in its grace
            // period: a token only one of them seals is forged under the
            // other.
            let mut result = Err(Refusal::Token(TokenRefusal::Forged));
            for key in keys.at(now) {
                result = handshake(&hello, now, key, &shared.public_addr, id, &mut guard);
                if !matches!(result, Err(Refusal::Token(TokenRefusal::Forged))) {
                    break;
                }
            }
            result
        }
        Err(e) => {
            debug!(error = %e, "malformed hello");
            Err(Refusal::Malformed)
        }
    };
    let result = match result {
        Ok(token) => match not_running(shared) {
            Some(refusal) => Err(refusal),
            None => join(shared, token.client_id).await,
        },
        Err(r) => Err(r),
    };
    match result {
        Ok((client, avatar)) => {
            tracing::Span::current().record("client", client);
            let frame = shared.sim.frame();
            let welcome = ServerControl::Welcome {
                client_id: client,
                tick: frame.tick,
                tick_hz: shared.tick_hz,
                snapshot_hz: shared.snapshot_hz,
                position_resolution: shared.snapshot.grid.resolution,
                position_bound: shared.snapshot.grid.bound,
                snapshot: SnapshotParams::from_config(&shared.snapshot),
                server_version: env!("CARGO_PKG_VERSION").to_string(),
            };
            match tokio::time::timeout(HELLO_TIMEOUT, write(&mut send, &welcome)).await {
                Ok(Ok(_)) => {}
                Ok(Err(_)) => {
                    let _ = shared.sim.leave(client);
                    return None;
                }
                Err(_) => {
                    // Joined, but the welcome never went: the avatar goes.
                    let _ = shared.sim.leave(client);
                    too_slow(connection, shared);
                    return None;
                }
            }
            info!(client, avatar, "client joined");
            Some(Admitted {
                client,
                avatar,
                send,
                recv,
                frames,
            })
        }
        Err(refusal) => {
            info!(?refusal, "hello refused");
            shared.metrics.refused(refusal_reason(&refusal));
            let refused = ServerControl::Refused(refusal);
            let _ = tokio::time::timeout(GOODBYE_WAIT, write(&mut send, &refused)).await;
            send.finish();
            let _ = tokio::time::timeout(Duration::from_millis(500), send.stopped()).await;
            connection.close(close_code::REFUSED, b"refused");
            None
        }
    }
}

/// Control messages on their way to a client, whole frames in order,
/// written as its flow-control window allows (see the module docs).
#[derive(Debug)]
struct Outbox {
    bytes: Vec<u8>,
    /// Where the unwritten bytes start.
    start: usize,
    /// When the stream last moved, or the first bytes came to wait.
    moved: tokio::time::Instant,
}

impl Outbox {
    fn new() -> Outbox {
        Outbox {
            bytes: Vec::new(),
            start: 0,
            moved: tokio::time::Instant::now(),
        }
    }

    /// Queues `msg`; its framed length.
    fn push(&mut self, msg: &ServerControl) -> Result<usize, String> {
        let frame = encode_frame(msg).map_err(|e| e.to_string())?;
        Ok(self.push_coded(&frame))
    }

    /// Queues a message already coded as a control frame.
    fn push_coded(&mut self, frame: &[u8]) -> usize {
        if self.is_empty() {
            self.moved = tokio::time::Instant::now();
        }
        self.bytes.extend_from_slice(frame);
        frame.len()
    }

    /// The bytes still to write.
    fn pending(&self) -> &[u8] {
        &self.bytes[self.start..]
    }

    fn len(&self) -> usize {
        self.bytes.len() - self.start
    }

    fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// `n` bytes were written.
    fn advance(&mut self, n: usize) {
        self.start += n;
        if self.start == self.bytes.len() {
            self.bytes.clear();
            self.start = 0;
        } else if self.start > (64 << 10) && self.start * 2 > self.bytes.len() {
            self.bytes.drain(..self.start);
            self.start = 0;
        }
        self.moved = tokio::time::Instant::now();
    }

    /// When the client will have left its stream unread too long, while
    /// something waits for it.
    fn stall_deadline(&self) -> Option<tokio::time::Instant> {
        (!self.is_empty()).then(|| self.moved + CONTROL_STALL)
    }

    /// Writes what the client's flow-control window takes now, without
    /// waiting for it to open (the connection loop writes the rest).
    fn write_now(&mut self, send: &mut LinkSend) -> Result<(), LinkError> {
        let waker = std::task::Waker::noop();
        let mut cx = std::task::Context::from_waker(waker);
        while !self.is_empty() {
            let written = {
                let write = std::pin::pin!(send.write(self.pending()));
                write.poll(&mut cx)
            };
            match written {
                std::task::Poll::Ready(Ok(n)) => self.advance(n),
                std::task::Poll::Ready(Err(e)) => return Err(e),
                std::task::Poll::Pending => break,
            }
        }
        Ok(())
    }

    /// Writes everything queued; false when the stream failed.
    async fn flush(&mut self, send: &mut LinkSend) -> bool {
        while !self.is_empty() {
            match send.write(self.pending()).await {
                Ok(n) => self.advance(n),
                Err(_) => return false,
            }
        }
        true
    }

    /// Queues `msg` and writes it out behind whatever waits, within
    /// [`GOODBYE_WAIT`]; whether it all went.
    async fn say_last(&mut self, send: &mut LinkSend, msg: &ServerControl) -> bool {
        if self.push(msg).is_err() {
            return false;
        }
        matches!(
            tokio::time::timeout(GOODBYE_WAIT, self.flush(send)).await,
            Ok(true)
        )
    }
}

async fn run(connection: Link, admitted: Admitted, shared: &NetShared) {
    let Admitted {
        client,
        avatar,
        mut send,
        mut recv,
        mut frames,
    } = admitted;
    let previous = shared
        .connected
        .lock()
        .map(|mut c| c.insert(client, connection.stable_id() as u64))
        .ok()
        .flatten();
    if previous.is_some() {
        warn!(client, "client id connected twice");
    }
    let (kick_tx, kick_rx) = tokio::sync::oneshot::channel();
    if let Ok(mut k) = shared.kicks.lock() {
        k.insert(client, (connection.stable_id() as u64, kick_tx));
    }
    let mut outbox = Outbox::new();
    let end = session(
        &connection,
        client,
        avatar,
        &mut send,
        &mut outbox,
        &mut recv,
        &mut frames,
        kick_rx,
        shared,
    )
    .await;
    if let Ok(mut k) = shared.kicks.lock() {
        if k.get(&client).map(|(c, _)| *c) == Some(connection.stable_id() as u64) {
            k.remove(&client);
        }
    }
    let _ = shared.sim.leave(client);
    match end {
        End::Shutdown(reason) => {
            let goodbye = ServerControl::Goodbye(reason.clone());
            outbox.say_last(&mut send, &goodbye).await;
            send.finish();
            let _ = tokio::time::timeout(Duration::from_millis(500), send.stopped()).await;
            close_saying(&connection, &reason);
            info!(client, "client told of shutdown");
        }
        End::Goodbye => {
            connection.close(close_code::GOODBYE, b"goodbye");
            info!(client, "client left");
        }
        End::Protocol(what) => {
            warn!(client, %what, "protocol error");
            let reason = DisconnectReason::ProtocolError { what };
            outbox
                .say_last(&mut send, &ServerControl::Goodbye(reason.clone()))
                .await;
            // Closing at once would drop the goodbye in flight.
            send.finish();
            let _ = tokio::time::timeout(Duration::from_millis(500), send.stopped()).await;
            close_saying(&connection, &reason);
        }
        End::Kicked(reason) => {
            let said = DisconnectReason::Kicked {
                reason: reason.clone(),
            };
            outbox
                .say_last(&mut send, &ServerControl::Goodbye(said.clone()))
                .await;
            send.finish();
            let _ = tokio::time::timeout(Duration::from_millis(500), send.stopped()).await;
            close_saying(&connection, &said);
            info!(client, %reason, "client kicked");
        }
        End::Closed(e) => info!(client, reason = %e, "connection closed"),
    }
    // Connected until told why it ends: a shutdown drains clients by
    // waiting for this, so the goodbye is on its way before the endpoint
    // closes under it.
    if let Ok(mut c) = shared.connected.lock() {
        if c.get(&client) == Some(&(connection.stable_id() as u64)) {
            c.remove(&client);
        }
    }
}

/// Closes `connection` with a code and text that say `reason` on their
/// own: a client that sees the close before the goodbye (a close discards
/// what is still in flight) learns the same reason from it.
fn close_saying(connection: &Link, reason: &DisconnectReason) {
    let (code, text) = reason.to_close();
    connection.close(code, text.as_bytes());
}

#[allow(clippy::too_many_arguments)]
async fn session(
    connection: &Link,
    client: u64,
    avatar: EntityId,
    send: &mut LinkSend,
    outbox: &mut Outbox,
    recv: &mut LinkRecv,
    frames: &mut FrameDecoder,
    mut kick: tokio::sync::oneshot::Receiver<String>,
    shared: &NetShared,
) -> End {
    let budget = (shared.budget_bytes_per_sec / u64::from(shared.snapshot_hz.max(1))) as usize;
    let config = SessionConfig::new(shared.snapshot, budget);
    let mut game_session = ServerSession::new(config).expect("validated at start-up");
    game_session.set_avatar(avatar);
    // The snapshot stage serves this client's slots from here on.
    let served = Arc::new(Served::new(
        connection.clone(),
        client,
        game_session,
        &shared.sim.frame(),
    ));
    let _serving = shared
        .served
        .add(connection.stable_id() as u64, served.clone());
    let mut shutdown = shared.shutdown.clone();
    let mut buf = vec![0u8; 4096];
    let mut kick_open = true;
    let mut heard = tokio::time::Instant::now();
    // One timer for the silence, moved on only when it fires: a timer made
    // afresh on each turn of the loop would be registered and dropped twice
    // a slot for every client.
    let silence = tokio::time::sleep_until(heard + SILENT_TIMEOUT);
    tokio::pin!(silence);
    loop {
        let stall = outbox.stall_deadline();
        tokio::select! {
            () = served.ready.notified() => {
                if let Err(e) = send_slot(&served, outbox, send, shared) {
                    return e;
                }
            }
            datagram = connection.read_datagram() => match datagram {
                Ok(bytes) => {
                    heard = tokio::time::Instant::now();
                    shared.metrics.bytes_received.inc_by(bytes.len() as u64);
                    shared.metrics.packets_received.inc();
                    let Ok(mut session) = served.session.lock() else {
                        return End::Protocol("session state lost".into());
                    };
                    match session.on_datagram(&bytes) {
                        Ok(()) => {
                            while let Some(input) = session.poll_input() {
                                if shared.sim.input(client, input).is_err() {
                                    shared.metrics.inputs_rejected.inc();
                                }
                            }
                        }
                        Err(e) => {
                            debug!(client, error = %e, "malformed datagram dropped");
                            shared.metrics.malformed_datagrams.inc();
                        }
                    }
                }
                Err(e) => return End::Closed(e.to_string()),
            },
            read = recv.read(&mut buf) => match read {
                Ok(Some(n)) => {
                    if let Err(e) = frames.push(&buf[..n]) {
                        return End::Protocol(e.to_string());
                    }
                    // Every message a client may send after its hello ends
                    // the session.
                    if let Some(msg) = frames.next::<ClientControl>() {
                        match msg {
                            Ok(ClientControl::Goodbye) => return End::Goodbye,
                            Ok(ClientControl::Hello { .. }) => {
                                return End::Protocol("a second hello".into())
                            }
                            Err(e) => return End::Protocol(e.to_string()),
                        }
                    }
                }
                // The client will send nothing more, not even a goodbye:
                // it has left.
                Ok(None) => return End::Goodbye,
                Err(LinkError::Lost(e)) => return End::Closed(e),
                Err(e) => return End::Protocol(format!("control stream: {e}")),
            },
            written = send.write(outbox.pending()), if !outbox.is_empty() => match written {
                Ok(n) => outbox.advance(n),
                Err(LinkError::Lost(e)) => return End::Closed(e),
                Err(e) => return End::Protocol(format!("control stream: {e}")),
            },
            _ = tokio::time::sleep_until(stall.unwrap_or_else(tokio::time::Instant::now)), if stall.is_some() => {
                return End::Protocol(format!(
                    "the control stream was not read for {} s ({} bytes waiting)",
                    CONTROL_STALL.as_secs(),
                    outbox.len()
                ));
            }
            () = &mut silence => {
                if heard + SILENT_TIMEOUT > tokio::time::Instant::now() {
                    silence.as_mut().reset(heard + SILENT_TIMEOUT);
                    continue;
                }
                return End::Protocol(format!(
                    "silent: no acknowledgement or input for {} s",
                    SILENT_TIMEOUT.as_secs()
                ));
            }
            _ = shutdown.changed() => {
                let reason = shutdown
                    .borrow()
                    .clone()
                    .unwrap_or(DisconnectReason::ServerShutdown);
                return End::Shutdown(reason);
            }
            reason = &mut kick, if kick_open => match reason {
                Ok(reason) => return End::Kicked(reason),
                // Another connection of the same client took the kick.
                Err(_) => kick_open = false,
            },
        }
    }
}

/// Sends what the snapshot stage made for the client at its last slot
/// (see [`SlotOutput`]): its control messages first, written at once as far
/// as the client's window allows (the rest as it opens), then its snapshot
/// datagram, so that quinn puts them in one packet. Refuses a client more
/// than [`OUTBOX_LIMIT`] bytes behind.
///
/// [`SlotOutput`]: super::snapshots::SlotOutput
fn send_slot(
    served: &Served,
    outbox: &mut Outbox,
    send: &mut LinkSend,
    shared: &NetShared,
) -> Result<(), End> {
    let datagram = {
        let Ok(mut out) = served.out.lock() else {
            return Err(End::Protocol("slot output lost".into()));
        };
        if let Some(e) = out.error.take() {
            return Err(End::Protocol(format!("control stream: {e}")));
        }
        outbox.push_coded(&out.control);
        out.control.clear();
        out.datagram.take()
    };
    if outbox.len() > OUTBOX_LIMIT {
        return Err(End::Protocol(format!(
            "{} bytes wait for the client, more than {OUTBOX_LIMIT}",
            outbox.len()
        )));
    }
    outbox.write_now(send).map_err(|e| match e {
        LinkError::Lost(e) => End::Closed(e),
        e => End::Protocol(format!("control stream: {e}")),
    })?;
    if let Some(bytes) = datagram {
        super::snapshots::send_datagram(&served.connection, bytes, shared);
    }
    Ok(())
}

/// The avatar a client owns in a frame's catalog, if any.
pub fn avatar_of(frame: &Frame, client: u64) -> Option<EntityId> {
    frame
        .catalog
        .iter()
        .find(|(_, d)| d.kind == EntityKind::Avatar && d.owner == Some(client))
        .map(|(&id, _)| id)
}

/// The point of interest of a client: its avatar's position, if known.
pub fn interest_point(frame: &Frame, avatar: EntityId) -> Option<DVec3> {
    frame
        .entities
        .binary_search_by_key(&avatar, |e| e.id)
        .ok()
        .map(|i| frame.entities[i].position)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn despawn(id: EntityId) -> ServerControl {
        ServerControl::Despawn { id }
    }

    #[test]
    fn the_outbox_keeps_frames_in_order_and_knows_when_it_stalled() {
        let mut outbox = Outbox::new();
        assert!(outbox.is_empty());
        assert_eq!(outbox.stall_deadline(), None, "nothing waits: no stall");
        let mut expected = Vec::new();
        for id in 0..20_000 {
            let n = outbox.push(&despawn(id)).expect("encodes");
            expected.extend(encode_frame(&despawn(id)).expect("encodes"));
            assert!(n > 4);
        }
        let queued_at = tokio::time::Instant::now();
        let deadline = outbox.stall_deadline().expect("bytes wait");
        assert!(deadline <= queued_at + CONTROL_STALL);
        assert!(deadline + Duration::from_secs(1) > queued_at + CONTROL_STALL);
        // Written a little at a time, compacted on the way: the same
        // bytes in the same order.
        let mut written = Vec::new();
        while !outbox.is_empty() {
            let n = outbox.pending().len().min(7_001);
            written.extend_from_slice(&outbox.pending()[..n]);
            outbox.advance(n);
            if !outbox.is_empty() {
                assert!(outbox.stall_deadline().expect("waits") >= deadline);
            }
        }
        assert_eq!(written, expected);
        assert_eq!(outbox.stall_deadline(), None);
        assert!(outbox.bytes.is_empty(), "nothing kept once written");
    }
}
