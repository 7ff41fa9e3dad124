//! The client's side of one game connection, from its hello to its close,
//! free of I/O (see the [module docs](super)).

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use crate::control::{
    close_code, encode_frame, ClientControl, DisconnectReason, FrameDecoder, Refusal, ServerControl,
};
use crate::message::{check_len, MessageRefusal};
use crate::snapshot::SnapshotConfig;

use super::last_words::LastWords;
use super::outbox::Outbox;
use super::server::Close;

/// How long the client waits for a welcome, from the start of the
/// connection (the QUIC handshake included).
pub const HANDSHAKE_TIMEOUT: Duration = Duration::from_secs(5);
/// Longest the client waits for the server to close the connection after
/// its goodbye, or after it ended its control stream, before closing it
/// itself.
pub const DRAIN_WAIT: Duration = Duration::from_secs(2);
/// Longest the client's goodbye waits for the server's window.
pub const CLIENT_GOODBYE_WAIT: Duration = Duration::from_secs(1);
/// Longest the client's finished stream waits to be taken.
pub const CLIENT_FINISH_WAIT: Duration = Duration::from_millis(200);

/// The deadlines of the client's side of a connection.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ClientConnectionConfig {
    /// For the welcome, from the start.
    pub handshake: Duration,
    /// For the server's close after its goodbye or the end of its stream.
    pub drain: Duration,
    /// For the client's goodbye to be written.
    pub goodbye: Duration,
    /// For the finished stream to be taken.
    pub finish: Duration,
}

impl Default for ClientConnectionConfig {
    fn default() -> Self {
        ClientConnectionConfig {
            handshake: HANDSHAKE_TIMEOUT,
            drain: DRAIN_WAIT,
            goodbye: CLIENT_GOODBYE_WAIT,
            finish: CLIENT_FINISH_WAIT,
        }
    }
}

/// What the server said about itself when it welcomed the client.
#[derive(Debug, Clone, PartialEq)]
pub struct ServerInfo {
    /// The client's id.
    pub client_id: u64,
    /// The server's tick when it welcomed the client.
    pub tick: u64,
    /// Physics ticks per second of simulation time, Hz (not zero).
    pub tick_hz: u32,
    /// Snapshots per second, Hz (not zero).
    pub snapshot_hz: u32,
    /// The snapshot coding the server uses.
    pub snapshot: SnapshotConfig,
    /// Bytes of every input's payload, the game's.
    pub input_bytes: usize,
    /// The server's build.
    pub server_version: String,
    /// The game's name, as its rules give it (empty when they give none):
    /// which controls and HUD a client offers.
    pub game: String,
    /// The game's properties, per entity and per match (give them to the
    /// session: [`crate::ClientSession::with_properties`]).
    pub properties: std::sync::Arc<crate::property::PropertySchema>,
}

/// Something the client must act on.
#[derive(Debug, Clone, PartialEq)]
pub enum ClientConnectionEvent {
    /// The server welcomed the client: make its session.
    Welcomed(ServerInfo),
    /// A control message for the game: a spawn, a despawn, a game
    /// message, a report on the inputs, or the server's goodbye (the connection then
    /// drains).
    Message(ServerControl),
}

/// Why the client's side of a connection ended.
#[derive(Debug, Clone, PartialEq)]
pub enum ClientConnectionEnd {
    /// The server refused the hello.
    Refused(Refusal),
    /// No welcome came within the handshake timeout.
    HandshakeTimeout,
    /// The server broke the protocol on the control stream.
    Protocol(String),
    /// The connection ended for this reason: the server's goodbye or
    /// close, a timeout, or the client leaving.
    Disconnected(DisconnectReason),
}

impl ClientConnectionEnd {
    /// The reason as a game sees a connection end.
    pub fn reason(&self) -> DisconnectReason {
        match self {
            ClientConnectionEnd::Refused(r) => DisconnectReason::ProtocolError {
                what: format!("refused: {r:?}"),
            },
            ClientConnectionEnd::HandshakeTimeout => DisconnectReason::Timeout,
            ClientConnectionEnd::Protocol(what) => {
                DisconnectReason::ProtocolError { what: what.clone() }
            }
            ClientConnectionEnd::Disconnected(reason) => reason.clone(),
        }
    }
}

#[derive(Debug)]
enum ClientPhase {
    /// The hello is on its way; the welcome is due by `deadline`.
    Hello { deadline: Instant },
    /// Welcomed.
    Live,
    /// Saying goodbye: writing until `deadline`, then finishing.
    Leaving { phase: LastWords },
    /// The server said goodbye or ended its stream: its close is due by
    /// `deadline`.
    Draining { deadline: Instant },
    /// Done: the link is closed with `close` (`None`: nothing to close).
    Closed { close: Option<Close> },
}

/// The client's side of one game connection (see the [module
/// docs](super)).
#[derive(Debug)]
pub struct ClientConnection {
    config: ClientConnectionConfig,
    state: ClientPhase,
    outbox: Outbox,
    frames: FrameDecoder,
    end: Option<ClientConnectionEnd>,
    events: VecDeque<ClientConnectionEvent>,
}

impl ClientConnection {
    /// A connection started at `now` that says hello with protocol
    /// `version` and the connect token's `token` bytes.
    pub fn new(
        version: u16,
        token: Vec<u8>,
        config: ClientConnectionConfig,
        now: Instant,
    ) -> ClientConnection {
        let mut outbox = Outbox::new(now);
        let mut end = None;
        let mut state = ClientPhase::Hello {
            deadline: now + config.handshake,
        };
        match encode_frame(&ClientControl::Hello { version, token }) {
            Ok(frame) => {
                outbox.push_coded(&frame, now);
            }
            Err(e) => {
                end = Some(ClientConnectionEnd::Protocol(format!(
                    "the hello cannot be coded: {e}"
                )));
                state = ClientPhase::Closed { close: None };
            }
        }
        ClientConnection {
            config,
            state,
            outbox,
            frames: FrameDecoder::new(),
            end,
            events: VecDeque::new(),
        }
    }

    /// Bytes of the server's control stream arrived at `now`.
    pub fn on_control_data(&mut self, bytes: &[u8], now: Instant) {
        if !self.reads_control() {
            return;
        }
        if let Err(e) = self.frames.push(bytes) {
            self.fail(e.to_string());
            return;
        }
        self.take_messages(now);
    }

    /// The server ended (or reset) its control stream at `now`: it will
    /// say nothing more, and closes the connection next.
    pub fn on_control_finished(&mut self, now: Instant) {
        match self.state {
            ClientPhase::Hello { .. } => self.end_now(
                ClientConnectionEnd::Protocol("control stream closed".into()),
                None,
            ),
            ClientPhase::Live => {
                self.state = ClientPhase::Draining {
                    deadline: now + self.config.drain,
                };
            }
            ClientPhase::Leaving { .. }
            | ClientPhase::Draining { .. }
            | ClientPhase::Closed { .. } => {}
        }
    }

    /// The connection closed under the client, for `reason` (the server's
    /// close as [`DisconnectReason::from_close`] reads it, a timeout, ...).
    pub fn on_lost(&mut self, reason: DisconnectReason) {
        if matches!(self.state, ClientPhase::Closed { .. }) {
            return;
        }
        self.set_end(ClientConnectionEnd::Disconnected(reason));
        self.outbox.clear();
        self.state = ClientPhase::Closed { close: None };
    }

    /// The game leaves at `now`: a goodbye, then the close.
    pub fn close(&mut self, now: Instant) {
        match self.state {
            ClientPhase::Live => match encode_frame(&ClientControl::Goodbye) {
                Ok(frame) => {
                    self.set_end(ClientConnectionEnd::Disconnected(
                        DisconnectReason::ClientLeft,
                    ));
                    self.outbox.push_coded(&frame, now);
                    self.state = ClientPhase::Leaving {
                        phase: LastWords::flushing(now, self.config.goodbye),
                    };
                }
                Err(_) => self.end_now(
                    ClientConnectionEnd::Disconnected(DisconnectReason::ClientLeft),
                    Some(left()),
                ),
            },
            ClientPhase::Hello { .. } | ClientPhase::Draining { .. } => self.end_now(
                ClientConnectionEnd::Disconnected(DisconnectReason::ClientLeft),
                Some(left()),
            ),
            ClientPhase::Leaving { .. } | ClientPhase::Closed { .. } => {}
        }
    }

    /// Queues a reliable game message at `now`, behind whatever waits on
    /// the control stream. Refused, changing nothing, past
    /// [`MAX_MESSAGE_BYTES`](crate::message::MAX_MESSAGE_BYTES) or while
    /// the connection is not live. (An unreliable message is a datagram:
    /// [`MessageDatagram::encode`](crate::message::MessageDatagram::encode).)
    pub fn send_message(&mut self, bytes: Vec<u8>, now: Instant) -> Result<(), MessageRefusal> {
        check_len(&bytes)?;
        if !self.is_live() {
            return Err(MessageRefusal::NotConnected);
        }
        let frame =
            encode_frame(&ClientControl::Message(bytes)).map_err(|_| MessageRefusal::Malformed)?;
        self.outbox.push_coded(&frame, now);
        Ok(())
    }

    /// Asks the server for a replay of the recent past (see
    /// [`crate::replay`]); it answers on the control stream. Refused
    /// before the welcome and once the connection is ending.
    pub fn ask_replay(
        &mut self,
        request: crate::replay::ReplayRequest,
        now: Instant,
    ) -> Result<(), crate::replay::ReplayRefusal> {
        self.send_control(&ClientControl::Replay(request), now)
    }

    /// Asks the server to stop the replay playing, if any.
    pub fn cancel_replay(&mut self, now: Instant) -> Result<(), crate::replay::ReplayRefusal> {
        self.send_control(&ClientControl::CancelReplay, now)
    }

    fn send_control(
        &mut self,
        message: &ClientControl,
        now: Instant,
    ) -> Result<(), crate::replay::ReplayRefusal> {
        if !self.is_live() {
            return Err(crate::replay::ReplayRefusal::NotJoined);
        }
        // Both always encode: nothing in them is bounded by the frame.
        if let Ok(frame) = encode_frame(message) {
            self.outbox.push_coded(&frame, now);
        }
        Ok(())
    }

    /// Acts on every deadline at or before `now`.
    pub fn handle_timeout(&mut self, now: Instant) {
        match self.state {
            ClientPhase::Hello { deadline } if now >= deadline => {
                self.end_now(ClientConnectionEnd::HandshakeTimeout, Some(left()));
            }
            ClientPhase::Draining { deadline } if now >= deadline => {
                // The server's goodbye (kept) or its silence: the client
                // closes.
                self.end_now(
                    ClientConnectionEnd::Protocol("the server did not close in time".into()),
                    Some(left()),
                );
            }
            ClientPhase::Leaving { phase } if now >= phase.deadline() => {
                if phase.is_flushing() {
                    self.start_finishing(now);
                } else {
                    self.end_now(
                        ClientConnectionEnd::Disconnected(DisconnectReason::ClientLeft),
                        Some(left()),
                    );
                }
            }
            _ => {}
        }
    }

    /// The next deadline, if any.
    pub fn poll_timeout(&self) -> Option<Instant> {
        match self.state {
            ClientPhase::Hello { deadline } | ClientPhase::Draining { deadline } => Some(deadline),
            ClientPhase::Leaving { phase } => Some(phase.deadline()),
            ClientPhase::Live | ClientPhase::Closed { .. } => None,
        }
    }

    /// The next thing to act on.
    pub fn poll_event(&mut self) -> Option<ClientConnectionEvent> {
        self.events.pop_front()
    }

    /// The control-stream bytes to write now.
    pub fn pending_control(&self) -> &[u8] {
        // Empty once closed: every way there empties the outbox.
        self.outbox.pending()
    }

    /// `n` bytes of [`Self::pending_control`] were written at `now`.
    pub fn control_written(&mut self, n: usize, now: Instant) {
        self.outbox.advance(n, now);
        if self.outbox.is_empty()
            && matches!(&self.state, ClientPhase::Leaving { phase } if phase.is_flushing())
        {
            self.start_finishing(now);
        }
    }

    /// True when the control stream should be finished now; say so with
    /// [`Self::finish_sent`].
    pub fn wants_finish(&self) -> bool {
        matches!(&self.state, ClientPhase::Leaving { phase } if phase.wants_finish())
    }

    /// The control stream was finished.
    pub fn finish_sent(&mut self) {
        if let ClientPhase::Leaving { phase } = &mut self.state {
            phase.finish_sent();
        }
    }

    /// True while the finished stream waits to be taken by the server.
    pub fn awaits_finish(&self) -> bool {
        matches!(&self.state, ClientPhase::Leaving { phase } if phase.awaits_finish())
    }

    /// The server took the finished stream: the connection closes.
    pub fn on_finish_taken(&mut self) {
        if matches!(self.state, ClientPhase::Leaving { .. }) {
            self.end_now(
                ClientConnectionEnd::Disconnected(DisconnectReason::ClientLeft),
                Some(left()),
            );
        }
    }

    /// True while the connection wants the server's control-stream bytes.
    pub fn reads_control(&self) -> bool {
        matches!(self.state, ClientPhase::Hello { .. } | ClientPhase::Live)
    }

    /// True once welcomed and not ending.
    pub fn is_live(&self) -> bool {
        matches!(self.state, ClientPhase::Live)
    }

    /// True once done: close the link with [`Self::close_frame`].
    pub fn is_closed(&self) -> bool {
        matches!(self.state, ClientPhase::Closed { .. })
    }

    /// The close to put on the link once [`Self::is_closed`] (`None`
    /// before, or when the link is already gone).
    pub fn close_frame(&self) -> Option<&Close> {
        match &self.state {
            ClientPhase::Closed { close } => close.as_ref(),
            _ => None,
        }
    }

    /// Why the connection ends, once it does.
    pub fn end(&self) -> Option<&ClientConnectionEnd> {
        self.end.as_ref()
    }

    fn take_messages(&mut self, now: Instant) {
        while self.reads_control() {
            let Some(msg) = self.frames.next::<ServerControl>() else {
                return;
            };
            let msg = match msg {
                Ok(msg) => msg,
                Err(e) => {
                    self.fail(e.to_string());
                    return;
                }
            };
            match (&self.state, msg) {
                (ClientPhase::Hello { .. }, ServerControl::Refused(refusal)) => {
                    self.end_now(ClientConnectionEnd::Refused(refusal), None);
                }
                (
                    ClientPhase::Hello { .. },
                    ServerControl::Welcome {
                        client_id,
                        tick,
                        tick_hz,
                        snapshot_hz,
                        position_resolution,
                        position_bound,
                        snapshot,
                        input_bytes,
                        server_version,
                        game,
                        properties,
                    },
                ) => {
                    let snapshot = snapshot.config(position_resolution, position_bound);
                    self.state = ClientPhase::Live;
                    self.events
                        .push_back(ClientConnectionEvent::Welcomed(ServerInfo {
                            client_id,
                            tick,
                            tick_hz,
                            snapshot_hz,
                            snapshot,
                            input_bytes: usize::from(input_bytes),
                            server_version,
                            game,
                            properties: std::sync::Arc::new(properties),
                        }));
                }
                (ClientPhase::Hello { .. }, other) => {
                    self.fail(format!("expected a welcome, got {other:?}"));
                }
                (ClientPhase::Live, ServerControl::Goodbye(reason)) => {
                    self.set_end(ClientConnectionEnd::Disconnected(reason.clone()));
                    self.events
                        .push_back(ClientConnectionEvent::Message(ServerControl::Goodbye(
                            reason,
                        )));
                    self.state = ClientPhase::Draining {
                        deadline: now + self.config.drain,
                    };
                }
                (
                    ClientPhase::Live,
                    other @ (ServerControl::Welcome { .. } | ServerControl::Refused(_)),
                ) => {
                    self.fail(format!("unexpected after the welcome: {other:?}"));
                }
                (ClientPhase::Live, msg) => {
                    self.events.push_back(ClientConnectionEvent::Message(msg))
                }
                _ => return,
            }
        }
    }

    /// The server broke the protocol: the client closes saying so.
    fn fail(&mut self, what: String) {
        let reason = DisconnectReason::ProtocolError { what: what.clone() };
        let (code, text) = reason.to_close();
        self.end_now(
            ClientConnectionEnd::Protocol(what),
            Some(Close { code, reason: text }),
        );
    }

    fn set_end(&mut self, end: ClientConnectionEnd) {
        if self.end.is_none() {
            self.end = Some(end);
        }
    }

    fn end_now(&mut self, end: ClientConnectionEnd, close: Option<Close>) {
        self.set_end(end);
        self.outbox.clear();
        self.state = ClientPhase::Closed { close };
    }

    /// Finishes the stream: what could not be written by now is given up.
    fn start_finishing(&mut self, now: Instant) {
        self.outbox.clear();
        self.state = ClientPhase::Leaving {
            phase: LastWords::finishing(now, self.config.finish),
        };
    }
}

/// The close of a client that leaves (or gives up).
fn left() -> Close {
    Close {
        code: close_code::GOODBYE,
        reason: "client left".into(),
    }
}
