//! One client's connection: a thin shell that moves bytes and timers
//! between the link (raw QUIC or WebTransport, [`super::link`]) and the
//! connection's state machine ([`ServerConnection`], in the protocol
//! crate, where every state and deadline of its life is decided and
//! tested on a virtual clock).
//!
//! The shell does what needs the server: it has a hello's token checked
//! and the tick thread asked for room ([`super::admission`], on
//! [`ServerConnectionEvent::Hello`]); once the client
//! is live it hands it to the snapshot stage ([`super::snapshots`]), which
//! owns its session; its datagrams go to the connection, which keeps the
//! inputs (passed on to the simulation) and hands each acknowledgement to
//! the stage's mailbox for the client; and writes what the stage made at the client's
//! slots (its control messages first, then its snapshot datagram, so that
//! both leave in one packet); when the connection ends it takes the
//! client out of the world ([`ServerConnectionEvent::Ending`]) and closes the link
//! as the state machine says.

use std::future::Future;
use std::sync::Arc;
use std::time::Instant;

use inertia_protocol::connection::{ServerConnection, ServerConnectionEnd, ServerConnectionEvent};
use inertia_protocol::control::{ClientControl, DisconnectReason};
use inertia_protocol::message::MessageRefusal;
use tokio::sync::oneshot;
use tracing::{debug, info, info_span, warn, Instrument};

use super::admission::{admit, refusal_reason, Joined};
use super::link::{Link, LinkError, LinkRecv, LinkSend};
use super::snapshots::{Served, ServedGuard};
use super::NetShared;

/// The deadlines of a connection's life (the protocol's; the control
/// stall and the silence match the QUIC idle timeout,
/// [`super::tls::IDLE_TIMEOUT`]).
pub use inertia_protocol::connection::{
    CONTROL_STALL, GOODBYE_WAIT, HELLO_TIMEOUT, OUTBOX_LIMIT, SILENT_TIMEOUT,
};

/// QUIC close codes the server uses (the protocol's).
pub use inertia_protocol::control::close_code;

/// Serves one game connection to its end.
pub async fn serve(link: Link, id: u64, shared: Arc<NetShared>) {
    let span = info_span!("connection", id, remote = %link.remote_address(), web = link.is_web_transport(), client = tracing::field::Empty);
    let shell = Shell {
        conn: ServerConnection::new(shared.connection, Instant::now()),
        link,
        id,
        shared,
        send: None,
        recv: None,
        joined: None,
        served: None,
        kick: None,
    };
    shell.run().instrument(span).await
}

/// What the task holds around the connection's state machine.
struct Shell {
    conn: ServerConnection,
    link: Link,
    /// The connection's number.
    id: u64,
    shared: Arc<NetShared>,
    /// The control stream's halves, once the client opened it (`send`
    /// from then on, `recv` until it ends).
    send: Option<LinkSend>,
    recv: Option<LinkRecv>,
    /// The client, once the world let it in (until it leaves).
    joined: Option<Joined>,
    /// Its place in the snapshot stage, while live.
    served: Option<(Arc<Served>, ServedGuard)>,
    /// Where an operator's kick comes from, while live.
    kick: Option<oneshot::Receiver<String>>,
}

/// What the control stream's sending half did.
enum Sent {
    Wrote(usize),
    Failed(LinkError),
    /// The finished stream was taken by the client.
    Taken,
}

impl Shell {
    async fn run(mut self) {
        let mut shutdown = self.shared.shutdown.clone();
        let mut shutdown_open = true;
        let mut buf = vec![0u8; 4096];
        // One timer, moved only when the connection's deadline comes
        // earlier than it is set for: a live client's silence deadline
        // moves on with every datagram, and a timer set afresh each time
        // would be registered and dropped several times a slot for every
        // client. A timer that fires early finds nothing due and is set
        // again.
        let timer = tokio::time::sleep(std::time::Duration::from_secs(3600));
        tokio::pin!(timer);
        let mut armed: Option<tokio::time::Instant> = None;
        loop {
            self.act().await;
            if self.conn.is_closed() {
                break;
            }
            if self.conn.wants_finish() {
                if let Some(send) = &mut self.send {
                    send.finish();
                }
                self.conn.finish_sent();
            }
            let deadline = self.conn.poll_timeout().map(tokio::time::Instant::from_std);
            if let Some(deadline) = deadline {
                if armed.is_none_or(|at| deadline < at) {
                    timer.as_mut().reset(deadline);
                    armed = Some(deadline);
                }
            }
            let reads = self.conn.reads_control();
            tokio::select! {
                opened = self.link.accept_bi(), if self.send.is_none() => match opened {
                    Ok((send, recv)) => {
                        self.send = Some(send);
                        self.recv = Some(recv);
                    }
                    Err(e) => self.conn.on_lost(&e.to_string()),
                },
                datagram = self.link.read_datagram() => match datagram {
                    Ok(bytes) => self.on_datagram(&bytes),
                    Err(e) => self.conn.on_lost(&e.to_string()),
                },
                read = read_control(self.recv.as_mut(), &mut buf), if reads => {
                    let now = Instant::now();
                    match read {
                        Ok(Some(n)) => {
                            self.conn.on_control_data(&buf[..n], now);
                            self.forward_messages();
                            self.forward_replays();
                        }
                        Ok(None) => {
                            self.recv = None;
                            self.conn.on_control_finished();
                        }
                        Err(LinkError::Lost(e)) => self.conn.on_lost(&e),
                        Err(LinkError::Stream(e)) => {
                            self.recv = None;
                            self.conn.on_control_reset(&e, now);
                        }
                    }
                }
                sent = write_control(self.send.as_mut(), self.conn.pending_control(), self.conn.awaits_finish()) => match sent {
                    Sent::Wrote(n) => self.conn.control_written(n, Instant::now()),
                    Sent::Taken => self.conn.on_finish_taken(),
                    Sent::Failed(LinkError::Lost(e)) => self.conn.on_lost(&e),
                    Sent::Failed(LinkError::Stream(e)) => self.conn.on_control_write_failed(&e, Instant::now()),
                },
                () = &mut timer, if armed.is_some() => {
                    armed = None;
                    self.conn.handle_timeout(Instant::now());
                }
                changed = shutdown.changed(), if shutdown_open => {
                    shutdown_open = changed.is_ok();
                    let reason = shutdown.borrow().clone().unwrap_or(DisconnectReason::ServerShutdown);
                    self.conn.shut_down(reason, Instant::now());
                }
                kicked = kicked(self.kick.as_mut()) => match kicked {
                    Some(reason) => self.conn.kick(reason, Instant::now()),
                    // Another connection of the same client took the kick.
                    None => self.kick = None,
                },
                () = slot_ready(self.served.as_ref()) => self.send_slot(),
            }
        }
        self.closed();
    }

    /// Acts on what the connection asks of the server.
    async fn act(&mut self) {
        while let Some(event) = self.conn.poll_event() {
            match event {
                ServerConnectionEvent::Hello { version, token } => {
                    let hello = ClientControl::Hello { version, token };
                    match admit(&self.shared, self.id, &hello).await {
                        Ok((joined, welcome)) => {
                            tracing::Span::current().record("client", joined.client);
                            self.joined = Some(joined);
                            self.conn.admit(&welcome, Instant::now());
                        }
                        Err(refusal) => {
                            info!(?refusal, "hello refused");
                            self.conn.refuse(refusal, Instant::now());
                        }
                    }
                }
                ServerConnectionEvent::Live => self.start_serving(),
                ServerConnectionEvent::Ending => self.stop_serving(),
            }
        }
    }

    /// The welcome went: the client is counted as connected, can be
    /// kicked, and is served snapshots.
    fn start_serving(&mut self) {
        let Some(Joined {
            client,
            avatar,
            first_message,
        }) = self.joined
        else {
            return;
        };
        info!(client, avatar, "client joined");
        let shared = &self.shared;
        let stable = self.link.stable_id() as u64;
        let previous = shared
            .connected
            .lock()
            .map(|mut c| c.insert(client, stable))
            .ok()
            .flatten();
        if previous.is_some() {
            warn!(client, "client id connected twice");
        }
        self.kick = Some(shared.admin.kicks.admit(client, stable));
        let served = Arc::new(Served::new(
            self.link.clone(),
            client,
            avatar,
            first_message,
        ));
        let guard = shared.served.add(stable, served.clone());
        self.served = Some((served, guard));
        // A shutdown while the client said hello is told to it now.
        if let Some(reason) = shared.shutdown.borrow().clone() {
            self.conn.shut_down(reason, Instant::now());
        }
    }

    /// The connection is ending: the client leaves the world and is no
    /// longer served; its last words may still be on their way.
    fn stop_serving(&mut self) {
        let shared = &self.shared;
        let stable = self.link.stable_id() as u64;
        self.served = None;
        self.kick = None;
        if let Some(Joined { client, .. }) = self.joined {
            shared.admin.kicks.forget(client, stable);
            let _ = shared.sim.leave(client);
        }
        let client = self.joined.map(|j| j.client);
        match self.conn.end() {
            Some(ServerConnectionEnd::HelloTimeout) => {
                debug!("no hello (or no welcome taken) in time");
                shared.metrics.refused("hello_timeout");
            }
            Some(ServerConnectionEnd::StreamEndedBeforeHello) => {
                debug!("the control stream ended before a whole hello");
                shared.metrics.refused("stream_ended_before_hello");
            }
            Some(ServerConnectionEnd::Refused(refusal)) => {
                shared.metrics.refused(refusal_reason(refusal))
            }
            Some(ServerConnectionEnd::Left) => info!(?client, "client left"),
            Some(ServerConnectionEnd::Protocol(what)) => warn!(?client, %what, "protocol error"),
            Some(ServerConnectionEnd::Shutdown(_)) => info!(?client, "client told of shutdown"),
            Some(ServerConnectionEnd::Kicked(reason)) => info!(?client, %reason, "client kicked"),
            Some(ServerConnectionEnd::Lost(e)) => info!(?client, reason = %e, "connection closed"),
            None => {}
        }
    }

    /// Closes the link as the connection says; the client is no longer
    /// connected (a shutdown drains clients by waiting for this, so the
    /// goodbye is on its way before the endpoint closes under it).
    fn closed(self) {
        if let Some(close) = self.conn.close_frame() {
            self.link.close(close.code, close.reason.as_bytes());
        }
        if let Some(Joined { client, .. }) = self.joined {
            if let Ok(mut c) = self.shared.connected.lock() {
                if c.get(&client) == Some(&(self.link.stable_id() as u64)) {
                    c.remove(&client);
                }
            }
        }
    }

    /// A datagram from the client: its acknowledgements and inputs, when
    /// live.
    fn on_datagram(&mut self, bytes: &[u8]) {
        let shared = &self.shared;
        shared.metrics.bytes_received.inc_by(bytes.len() as u64);
        shared.metrics.packets_received.inc();
        let client = self.joined.map(|j| j.client);
        match self.conn.on_datagram(bytes, Instant::now()) {
            Ok(ack) => {
                if let (Some(ack), Some((served, _))) = (ack, &self.served) {
                    served.push_ack(ack);
                }
            }
            Err(e) => {
                debug!(?client, error = %e, "malformed datagram dropped");
                shared.metrics.malformed_datagrams.inc();
            }
        }
        if let Some(e) = self.conn.poll_refused_inputs() {
            debug!(?client, error = %e, "inputs refused");
            if let Some(client) = client {
                shared.metrics.input_refused(client, "wrong_size");
            }
        }
        if let Some(client) = client {
            while let Some(input) = self.conn.poll_input() {
                // The tick thread counts what it refuses, by client and
                // reason; an input the full channel drops is counted here.
                if shared.sim.input(client, input).is_err() {
                    shared.metrics.inputs_rejected.inc();
                }
            }
        }
        self.forward_messages();
        self.forward_replays();
    }

    /// Hands what the client asked of replays, and its acknowledgements
    /// of replay snapshots, to the snapshot stage, and counts the
    /// requests its connection refused (and answered).
    fn forward_replays(&mut self) {
        let served = self.served.as_ref().map(|(s, _)| s.clone());
        while let Some(asked) = self.conn.poll_replay() {
            match (asked, &served) {
                (Ok(ask), Some(served)) => served.replays.ask(ask),
                (Ok(_), None) => {}
                (Err(why), _) => self.shared.metrics.replay_outcome(why.reason()),
            }
        }
        while let Some((replay, sequence)) = self.conn.poll_replay_ack() {
            if let Some(served) = &served {
                served.replays.ack(replay, sequence);
            }
        }
    }

    /// Hands the client's messages its connection took to the tick
    /// thread, and counts those it refused (too long, over the rate,
    /// malformed) per client and reason. One the full channel drops is
    /// counted as a backlog.
    fn forward_messages(&mut self) {
        let shared = &self.shared;
        let client = self.joined.map(|j| j.client);
        while let Some(taken) = self.conn.poll_message() {
            let Some(client) = client else { continue };
            let refusal = match taken {
                Ok(message) => match shared.sim.message(client, message) {
                    Ok(()) => continue,
                    Err(_) => MessageRefusal::Backlog {
                        max: shared.sim.input_capacity(),
                    },
                },
                Err(refusal) => refusal,
            };
            debug!(client, error = %refusal, "message refused");
            shared.metrics.message_refused(client, refusal.reason());
        }
    }

    /// Sends what the snapshot stage made for the client at its last slot
    /// (see [`SlotOutput`]): its control messages first, written at once
    /// as far as the client's window allows (the rest as it opens), then
    /// its snapshot datagram, so that quinn puts them in one packet.
    ///
    /// [`SlotOutput`]: super::snapshots::SlotOutput
    fn send_slot(&mut self) {
        let Some((served, _)) = &self.served else {
            return;
        };
        let served = served.clone();
        let now = Instant::now();
        let datagram = {
            let Ok(mut out) = served.out.lock() else {
                self.conn.fail("slot output lost".into(), now);
                return;
            };
            if let Some(e) = out.error.take() {
                self.conn.fail(format!("control stream: {e}"), now);
                return;
            }
            self.conn.queue_control(&out.control, now);
            out.control.clear();
            out.datagram.take()
        };
        if let Some(send) = &mut self.send {
            if let Err(e) = write_now(send, &mut self.conn) {
                match e {
                    LinkError::Lost(e) => self.conn.on_lost(&e),
                    LinkError::Stream(e) => self.conn.on_control_write_failed(&e, now),
                }
                return;
            }
        }
        if let Some(bytes) = datagram {
            if self.conn.is_live() {
                super::snapshots::send_datagram(&served.connection, bytes, &self.shared);
            }
        }
    }
}

/// Writes what the connection has for the client as far as its
/// flow-control window takes it now, without waiting for it to open (the
/// connection loop writes the rest).
fn write_now(send: &mut LinkSend, conn: &mut ServerConnection) -> Result<(), LinkError> {
    let waker = std::task::Waker::noop();
    let mut cx = std::task::Context::from_waker(waker);
    while !conn.pending_control().is_empty() {
        let written = {
            let write = std::pin::pin!(send.write(conn.pending_control()));
            write.poll(&mut cx)
        };
        match written {
            std::task::Poll::Ready(Ok(n)) => conn.control_written(n, Instant::now()),
            std::task::Poll::Ready(Err(e)) => return Err(e),
            std::task::Poll::Pending => break,
        }
    }
    Ok(())
}

/// Reads the control stream, once there is one to read.
async fn read_control(
    recv: Option<&mut LinkRecv>,
    buf: &mut [u8],
) -> Result<Option<usize>, LinkError> {
    match recv {
        Some(recv) => recv.read(buf).await,
        None => std::future::pending().await,
    }
}

/// Writes `pending` to the control stream, or waits for the finished
/// stream to be taken; otherwise never ready.
async fn write_control(send: Option<&mut LinkSend>, pending: &[u8], awaits_finish: bool) -> Sent {
    match send {
        Some(send) if !pending.is_empty() => match send.write(pending).await {
            Ok(n) => Sent::Wrote(n),
            Err(e) => Sent::Failed(e),
        },
        Some(send) if awaits_finish => {
            send.stopped().await;
            Sent::Taken
        }
        _ => std::future::pending().await,
    }
}

/// An operator's kick, while one can come: `None` when the sender is
/// gone.
async fn kicked(kick: Option<&mut oneshot::Receiver<String>>) -> Option<String> {
    match kick {
        Some(kick) => kick.await.ok(),
        None => std::future::pending().await,
    }
}

/// The snapshot stage left something for the client, while it is served.
async fn slot_ready(served: Option<&(Arc<Served>, ServedGuard)>) {
    match served {
        Some((served, _)) => served.ready.notified().await,
        None => std::future::pending().await,
    }
}
