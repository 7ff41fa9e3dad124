//! The server's side of one game connection, from its first byte to its
//! close, free of I/O (see the [module docs](super) for the states).

use std::collections::VecDeque;
use std::time::Instant;

use crate::control::{
    close_code, encode_frame, ClientControl, DisconnectReason, FrameDecoder, Refusal, ServerControl,
};
use crate::input::PlayerInput;
use crate::input::{InputBuffer, InputDatagram, InputError};
use crate::message::{check_len, Delivery, MessageDatagram, MessageLimiter, MessageRefusal};
use crate::replay::{
    ReplayAnswer, ReplayAsk, ReplayDatagram, ReplayRefusal, ReplayRequest, REPLAY_REQUEST_LIMITS,
};

use super::last_words::LastWords;
use super::outbox::Outbox;
use super::ServerConnectionConfig;

/// Something the server must act on.
#[derive(Debug, Clone, PartialEq)]
pub enum ServerConnectionEvent {
    /// The client said hello: check its token and ask the world for room,
    /// then answer with [`ServerConnection::admit`] or
    /// [`ServerConnection::refuse`]. The connection waits for the answer
    /// without a deadline: the client's part is done.
    Hello {
        /// The client's protocol version.
        version: u16,
        /// Its connect token's bytes (checked by the server).
        token: Vec<u8>,
    },
    /// The welcome was written: the client is live, serve it snapshots and
    /// take its datagrams.
    Live,
    /// The connection is ending, for [`ServerConnection::end`]'s reason:
    /// a client that joined leaves the world now. Its last words (a
    /// refusal, a goodbye) may still be on their way until
    /// [`ServerConnection::is_closed`].
    Ending,
}

/// Why a game connection ended.
#[derive(Debug, Clone, PartialEq)]
pub enum ServerConnectionEnd {
    /// No whole hello came within the hello timeout, or the welcome was
    /// not taken within it.
    HelloTimeout,
    /// The client ended or reset its control stream before a whole hello.
    StreamEndedBeforeHello,
    /// The hello was refused.
    Refused(Refusal),
    /// The client said goodbye, or ended its control stream.
    Left,
    /// The client broke the protocol, or went silent, or stopped reading.
    Protocol(String),
    /// The server is stopping, and told the client why.
    Shutdown(DisconnectReason),
    /// An operator or the game removed the client.
    Kicked(String),
    /// The link failed under the connection (closed by the peer, timed
    /// out, reset).
    Lost(String),
}

impl ServerConnectionEnd {
    /// A short label for metrics and logs.
    pub fn label(&self) -> &'static str {
        match self {
            ServerConnectionEnd::HelloTimeout => "hello_timeout",
            ServerConnectionEnd::StreamEndedBeforeHello => "stream_ended_before_hello",
            ServerConnectionEnd::Refused(_) => "refused",
            ServerConnectionEnd::Left => "left",
            ServerConnectionEnd::Protocol(_) => "protocol_error",
            ServerConnectionEnd::Shutdown(_) => "shutdown",
            ServerConnectionEnd::Kicked(_) => "kicked",
            ServerConnectionEnd::Lost(_) => "lost",
        }
    }
}

/// The application close the server puts on the link as the connection
/// ends: a code of [`close_code`] and a text for people.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Close {
    /// The application close code.
    pub code: u32,
    /// The reason text.
    pub reason: String,
}

impl Close {
    fn new(code: u32, reason: impl Into<String>) -> Close {
        Close {
            code,
            reason: reason.into(),
        }
    }

    /// The close that says `reason` on its own (see
    /// [`DisconnectReason::to_close`]).
    fn saying(reason: &DisconnectReason) -> Close {
        let (code, reason) = reason.to_close();
        Close { code, reason }
    }
}

#[derive(Debug)]
enum ServerPhase {
    /// Waiting for the client's whole hello until `deadline` (its stream
    /// may not be open yet).
    Hello { deadline: Instant },
    /// The hello is with the server; nothing of the client's is awaited.
    Deciding,
    /// Admitted: the welcome waits in the outbox, to be written by
    /// `deadline`.
    Welcoming { deadline: Instant },
    /// Live: last heard from at `heard` (a datagram).
    Live { heard: Instant },
    /// Saying its last words, then closing with `close`.
    Closing { close: Close, phase: LastWords },
    /// Done: the link is closed with `close` (`None`: it is gone).
    Closed { close: Option<Close> },
}

/// The server's side of one game connection (see the [module
/// docs](super)).
#[derive(Debug)]
pub struct ServerConnection {
    config: ServerConnectionConfig,
    state: ServerPhase,
    outbox: Outbox,
    frames: FrameDecoder,
    /// The client ended its control stream: it will send nothing more.
    peer_finished: bool,
    /// The client's inputs, reordered and each once.
    inputs: InputBuffer,
    /// Why the inputs of the last datagram were refused while its
    /// acknowledgement was taken, until [`Self::poll_refused_inputs`].
    refused_inputs: Option<InputError>,
    /// How fast the client may send messages.
    limiter: MessageLimiter,
    /// The client's messages taken, and those refused, in arrival order,
    /// until [`Self::poll_message`]: the limiter bounds the first, what
    /// one push or datagram holds the second.
    messages: VecDeque<Result<ReceivedMessage, MessageRefusal>>,
    /// How fast the client may ask for replays.
    replay_limiter: MessageLimiter,
    /// What the client asked of replays, and the asks refused here (and
    /// answered), in arrival order, until [`Self::poll_replay`].
    replays: VecDeque<Result<ReplayAsk, ReplayRefusal>>,
    /// The replay snapshots the client acknowledged (replay, sequence),
    /// until [`Self::poll_replay_ack`]; at most [`MAX_REPLAY_ACKS`].
    replay_acks: VecDeque<(u16, u16)>,
    /// Why the connection ends, once it does.
    end: Option<ServerConnectionEnd>,
    events: VecDeque<ServerConnectionEvent>,
}

/// Replay acknowledgements a connection holds at most between two
/// looks; beyond, the oldest go (a newer one makes a better baseline).
pub const MAX_REPLAY_ACKS: usize = 64;

/// A game message a client sent, as its connection took it (within the
/// size and rate bounds; the game's decoder reads it on the tick thread).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ReceivedMessage {
    /// How it came.
    pub delivery: Delivery,
    /// The game's bytes.
    pub bytes: Vec<u8>,
}

impl ServerConnection {
    /// A connection whose QUIC handshake finished at `now`: the client
    /// has until `now + config.hello` to open its control stream and say
    /// hello.
    pub fn new(config: ServerConnectionConfig, now: Instant) -> ServerConnection {
        ServerConnection {
            config,
            state: ServerPhase::Hello {
                deadline: now + config.hello,
            },
            outbox: Outbox::new(now),
            frames: FrameDecoder::new(),
            inputs: InputBuffer::new(config.input_buffer.max(1)),
            refused_inputs: None,
            limiter: MessageLimiter::new(config.messages, now),
            messages: VecDeque::new(),
            replay_limiter: MessageLimiter::new(REPLAY_REQUEST_LIMITS, now),
            replays: VecDeque::new(),
            replay_acks: VecDeque::new(),
            peer_finished: false,
            end: None,
            events: VecDeque::new(),
        }
    }

    /// Its limits.
    pub fn config(&self) -> &ServerConnectionConfig {
        &self.config
    }

    /// Bytes of the client's control stream arrived at `now`.
    pub fn on_control_data(&mut self, bytes: &[u8], now: Instant) {
        if self.is_ending() {
            return;
        }
        if let Err(e) = self.frames.push(bytes) {
            match self.state {
                ServerPhase::Hello { .. } => self.refuse(Refusal::Malformed, now),
                _ => self.fail(e.to_string(), now),
            }
            return;
        }
        self.take_messages(now);
    }

    /// The client finished its control stream: it will send nothing more
    /// on it (it may still read).
    pub fn on_control_finished(&mut self) {
        self.peer_finished = true;
        match self.state {
            // Nothing can complete the hello now.
            ServerPhase::Hello { .. } => self.end_now(
                ServerConnectionEnd::StreamEndedBeforeHello,
                Some(hello_cut_short()),
            ),
            // The answer still goes out; a client admitted leaves once
            // welcomed.
            ServerPhase::Deciding | ServerPhase::Welcoming { .. } => {}
            ServerPhase::Live { .. } => {
                self.end_now(ServerConnectionEnd::Left, Some(goodbye_close()))
            }
            ServerPhase::Closing { .. } | ServerPhase::Closed { .. } => {}
        }
    }

    /// The client reset its control stream at `now` (the connection
    /// lives on): `why` is the stream's error.
    pub fn on_control_reset(&mut self, why: &str, now: Instant) {
        match self.state {
            ServerPhase::Hello { .. } => self.end_now(
                ServerConnectionEnd::StreamEndedBeforeHello,
                Some(hello_cut_short()),
            ),
            ServerPhase::Deciding | ServerPhase::Welcoming { .. } => self.peer_finished = true,
            ServerPhase::Live { .. } => self.fail(format!("control stream: {why}"), now),
            ServerPhase::Closing { .. } | ServerPhase::Closed { .. } => {}
        }
    }

    /// The control stream cannot be written at `now` (`why`), while the
    /// connection lives on.
    pub fn on_control_write_failed(&mut self, why: &str, now: Instant) {
        self.outbox.clear();
        match self.state {
            ServerPhase::Closing { .. } => self.close_now(),
            ServerPhase::Closed { .. } => {}
            _ => self.fail(format!("control stream: {why}"), now),
        }
    }

    /// The link failed under the connection (`why`): nothing more can be
    /// sent or received.
    pub fn on_lost(&mut self, why: &str) {
        if matches!(self.state, ServerPhase::Closed { .. }) {
            return;
        }
        if self.end.is_none() {
            self.end = Some(ServerConnectionEnd::Lost(why.to_string()));
            self.events.push_back(ServerConnectionEvent::Ending);
        }
        self.outbox.clear();
        self.state = ServerPhase::Closed { close: None };
    }

    /// A datagram came from the client at `now`: its inputs wait in
    /// order for [`Self::poll_input`], and the newest snapshot it
    /// acknowledges is returned for the client's session
    /// ([`crate::ServerSession::on_ack`]). Only a live connection takes
    /// datagrams (before and after, they are dropped: `Ok(None)`); any
    /// datagram, even one that does not decode, keeps it from going
    /// silent. One that does not decode changes nothing else. One whose
    /// inputs are not the game's size has them refused
    /// ([`Self::poll_refused_inputs`]) and its acknowledgement taken: the
    /// client's snapshots go on as they would.
    pub fn on_datagram(&mut self, bytes: &[u8], now: Instant) -> Result<Option<u16>, InputError> {
        let ServerPhase::Live { heard } = &mut self.state else {
            return Ok(None);
        };
        *heard = now;
        if MessageDatagram::is_one(bytes) {
            let taken = MessageDatagram::decode(bytes)
                .map(|m| m.to_vec())
                .and_then(|m| self.take_message(Delivery::Unreliable, m, now));
            self.messages.push_back(taken);
            return Ok(None);
        }
        if ReplayDatagram::is_one(bytes) {
            match ReplayDatagram::decode_ack(bytes) {
                Ok(ReplayDatagram::Ack { replay, sequence }) => {
                    if self.replay_acks.len() >= MAX_REPLAY_ACKS {
                        self.replay_acks.pop_front();
                    }
                    self.replay_acks.push_back((replay, sequence));
                    return Ok(None);
                }
                _ => return Err(InputError::ReplayAck),
            }
        }
        let datagram = InputDatagram::decode(bytes)?;
        match (self.config.input_bytes, datagram.inputs.first()) {
            (Some(expected), Some(input)) if input.payload.len() != expected => {
                self.refused_inputs = Some(InputError::WrongPayloadSize {
                    size: input.payload.len(),
                    expected,
                });
            }
            _ => self.inputs.push_datagram(&datagram),
        }
        Ok(datagram.ack)
    }

    /// Why the last datagram's inputs were refused, once: inputs of
    /// another size than the game's
    /// ([`InputError::WrongPayloadSize`]), for the server to count.
    pub fn poll_refused_inputs(&mut self) -> Option<InputError> {
        self.refused_inputs.take()
    }

    /// The client's next input in sequence order, each exactly once.
    pub fn poll_input(&mut self) -> Option<PlayerInput> {
        self.inputs.pop()
    }

    /// The client's next message in arrival order (reliable ones in the
    /// order sent), or why one was refused ([`MessageRefusal`]: too long,
    /// over the client's rate, a message datagram that is not one), for
    /// the server to count. A refused message changes nothing else.
    pub fn poll_message(&mut self) -> Option<Result<ReceivedMessage, MessageRefusal>> {
        self.messages.pop_front()
    }

    /// What the client asked of replays next, in arrival order: a
    /// request whose shape is sound and within the client's rate, or a
    /// cancel; or why a request was refused here (already answered on
    /// the control stream), for the server to count. Whether the server
    /// holds the stretch and has room to play it is the server's to
    /// answer ([`Self::answer_replay`]).
    pub fn poll_replay(&mut self) -> Option<Result<ReplayAsk, ReplayRefusal>> {
        self.replays.pop_front()
    }

    /// The next replay snapshot the client acknowledged: (replay,
    /// sequence), in arrival order.
    pub fn poll_replay_ack(&mut self) -> Option<(u16, u16)> {
        self.replay_acks.pop_front()
    }

    /// Tells the client `answer` about its replay, behind whatever waits
    /// on the control stream.
    pub fn answer_replay(&mut self, answer: ReplayAnswer, now: Instant) {
        if let Ok(frame) = encode_frame(&ServerControl::Replay(answer)) {
            self.queue_control(&frame, now);
        }
    }

    /// Takes a replay request at `now`, or refuses it (and says so).
    fn take_replay(&mut self, request: ReplayRequest, now: Instant) {
        let taken = request.check().and_then(|()| {
            self.replay_limiter
                .take(0, now)
                .map_err(|_| ReplayRefusal::RateLimited)
        });
        if let Err(why) = taken {
            self.answer_replay(ReplayAnswer::Refused(why), now);
        }
        self.replays
            .push_back(taken.map(|()| ReplayAsk::Play(request)));
    }

    /// Takes a message of the client's at `now`, or refuses it.
    fn take_message(
        &mut self,
        delivery: Delivery,
        bytes: Vec<u8>,
        now: Instant,
    ) -> Result<ReceivedMessage, MessageRefusal> {
        check_len(&bytes)?;
        self.limiter.take(bytes.len(), now)?;
        Ok(ReceivedMessage { delivery, bytes })
    }

    /// Admits the client whose hello was [`ServerConnectionEvent::Hello`], with
    /// `welcome`; the client has the hello timeout again to take it.
    pub fn admit(&mut self, welcome: &ServerControl, now: Instant) {
        if !matches!(self.state, ServerPhase::Deciding) {
            return;
        }
        if let Err(e) = self.outbox.push(welcome, now) {
            self.fail(format!("the welcome cannot be coded: {e}"), now);
            return;
        }
        self.state = ServerPhase::Welcoming {
            deadline: now + self.config.hello,
        };
    }

    /// Refuses the client's hello, telling it why, and closes.
    pub fn refuse(&mut self, refusal: Refusal, now: Instant) {
        if self.is_ending() {
            return;
        }
        let said = self
            .outbox
            .push(&ServerControl::Refused(refusal.clone()), now);
        let close = Close::new(close_code::REFUSED, "refused");
        if said.is_err() {
            self.end_now(ServerConnectionEnd::Refused(refusal), Some(close));
        } else {
            self.end_saying(ServerConnectionEnd::Refused(refusal), close, now);
        }
    }

    /// Queues control frames already coded (a snapshot slot's catalog
    /// changes and events) for a live client. A client more than
    /// [`ServerConnectionConfig::outbox_limit`] bytes behind is let go.
    pub fn queue_control(&mut self, frames: &[u8], now: Instant) {
        if !matches!(
            self.state,
            ServerPhase::Live { .. } | ServerPhase::Welcoming { .. }
        ) {
            return;
        }
        self.outbox.push_coded(frames, now);
        if self.outbox.len() > self.config.outbox_limit {
            let behind = self.outbox.len();
            self.fail(
                format!(
                    "{behind} bytes wait for the client, more than {}",
                    self.config.outbox_limit
                ),
                now,
            );
        }
    }

    /// Ends the connection at `now` as a protocol error of the client's
    /// (`what`), telling it so.
    pub fn fail(&mut self, what: String, now: Instant) {
        if self.is_ending() {
            return;
        }
        let reason = DisconnectReason::ProtocolError { what: what.clone() };
        self.say_goodbye(ServerConnectionEnd::Protocol(what), reason, now);
    }

    /// An operator or the game removes the client, telling it `reason`.
    pub fn kick(&mut self, reason: String, now: Instant) {
        if !matches!(
            self.state,
            ServerPhase::Live { .. } | ServerPhase::Welcoming { .. }
        ) {
            return;
        }
        let said = DisconnectReason::Kicked {
            reason: reason.clone(),
        };
        self.say_goodbye(ServerConnectionEnd::Kicked(reason), said, now);
    }

    /// The server is stopping: a joined client is told `reason`; one that
    /// has not said hello yet is left to its hello (its answer will be a
    /// refusal).
    pub fn shut_down(&mut self, reason: DisconnectReason, now: Instant) {
        if !matches!(
            self.state,
            ServerPhase::Live { .. } | ServerPhase::Welcoming { .. }
        ) {
            return;
        }
        self.say_goodbye(ServerConnectionEnd::Shutdown(reason.clone()), reason, now);
    }

    /// Acts on every deadline at or before `now`.
    pub fn handle_timeout(&mut self, now: Instant) {
        match self.state {
            ServerPhase::Hello { deadline } | ServerPhase::Welcoming { deadline }
                if now >= deadline =>
            {
                self.end_now(
                    ServerConnectionEnd::HelloTimeout,
                    Some(Close::new(close_code::REFUSED, "no hello in time")),
                );
            }
            ServerPhase::Live { heard } => {
                let silence = self.config.silence;
                if now >= heard + silence {
                    self.fail(
                        format!(
                            "silent: no acknowledgement or input for {} s",
                            silence.as_secs()
                        ),
                        now,
                    );
                } else if self
                    .outbox
                    .stall_deadline(self.config.control_stall)
                    .is_some_and(|d| now >= d)
                {
                    let what = format!(
                        "the control stream was not read for {} s ({} bytes waiting)",
                        self.config.control_stall.as_secs(),
                        self.outbox.len()
                    );
                    self.fail(what, now);
                }
            }
            ServerPhase::Closing { phase, .. } if now >= phase.deadline() => {
                if phase.is_flushing() {
                    self.start_finishing(now);
                } else {
                    self.close_now();
                }
            }
            _ => {}
        }
    }

    /// The next deadline, if any: call [`Self::handle_timeout`] then.
    pub fn poll_timeout(&self) -> Option<Instant> {
        match &self.state {
            ServerPhase::Hello { deadline } | ServerPhase::Welcoming { deadline } => {
                Some(*deadline)
            }
            ServerPhase::Deciding | ServerPhase::Closed { .. } => None,
            ServerPhase::Live { heard } => {
                let silent = *heard + self.config.silence;
                let stall = self.outbox.stall_deadline(self.config.control_stall);
                Some(stall.map_or(silent, |s| s.min(silent)))
            }
            ServerPhase::Closing { phase, .. } => Some(phase.deadline()),
        }
    }

    /// The next thing to act on.
    pub fn poll_event(&mut self) -> Option<ServerConnectionEvent> {
        self.events.pop_front()
    }

    /// The control-stream bytes to write now (as many as the stream
    /// takes; say how many with [`Self::control_written`]).
    pub fn pending_control(&self) -> &[u8] {
        // Empty once closed: every way there empties the outbox.
        self.outbox.pending()
    }

    /// `n` bytes of [`Self::pending_control`] were written at `now`.
    pub fn control_written(&mut self, n: usize, now: Instant) {
        self.outbox.advance(n, now);
        if !self.outbox.is_empty() {
            return;
        }
        match self.state {
            ServerPhase::Welcoming { .. } => {
                self.state = ServerPhase::Live { heard: now };
                self.events.push_back(ServerConnectionEvent::Live);
                if self.peer_finished {
                    self.end_now(ServerConnectionEnd::Left, Some(goodbye_close()));
                } else {
                    // What came behind the hello.
                    self.take_messages(now);
                }
            }
            ServerPhase::Closing { phase, .. } if phase.is_flushing() => self.start_finishing(now),
            _ => {}
        }
    }

    /// True when the control stream should be finished now (the last
    /// words are written); say so with [`Self::finish_sent`].
    pub fn wants_finish(&self) -> bool {
        matches!(&self.state, ServerPhase::Closing { phase, .. } if phase.wants_finish())
    }

    /// True while the finished stream waits to be taken by the client;
    /// say when it was with [`Self::on_finish_taken`].
    pub fn awaits_finish(&self) -> bool {
        matches!(&self.state, ServerPhase::Closing { phase, .. } if phase.awaits_finish())
    }

    /// The control stream was finished.
    pub fn finish_sent(&mut self) {
        if let ServerPhase::Closing { phase, .. } = &mut self.state {
            phase.finish_sent();
        }
    }

    /// The client took everything on the finished stream (or stopped it):
    /// the connection closes.
    pub fn on_finish_taken(&mut self) {
        if matches!(self.state, ServerPhase::Closing { .. }) {
            self.close_now();
        }
    }

    /// Why the connection ends, once it does.
    pub fn end(&self) -> Option<&ServerConnectionEnd> {
        self.end.as_ref()
    }

    /// True once the connection is done: close the link with
    /// [`Self::close_frame`].
    pub fn is_closed(&self) -> bool {
        matches!(self.state, ServerPhase::Closed { .. })
    }

    /// The close to put on the link once [`Self::is_closed`] (`None`
    /// before, or when the link is already gone).
    pub fn close_frame(&self) -> Option<&Close> {
        match &self.state {
            ServerPhase::Closed { close } => close.as_ref(),
            _ => None,
        }
    }

    /// True while the connection wants the client's control-stream bytes:
    /// before the hello, and once live. While the server decides and the
    /// welcome waits, the stream is left unread, so a client that writes
    /// on meets its flow-control window instead of the server's memory.
    pub fn reads_control(&self) -> bool {
        matches!(
            self.state,
            ServerPhase::Hello { .. } | ServerPhase::Live { .. }
        )
    }

    /// True while the client is live (welcomed, and not ending).
    pub fn is_live(&self) -> bool {
        matches!(self.state, ServerPhase::Live { .. })
    }

    fn is_ending(&self) -> bool {
        matches!(
            self.state,
            ServerPhase::Closing { .. } | ServerPhase::Closed { .. }
        )
    }

    /// Decodes what the client sent, as far as the state lets it. The
    /// hello ends its state, and so at most one message is taken before
    /// the welcome; a live client's game messages are taken until a
    /// message ends the connection.
    fn take_messages(&mut self, now: Instant) {
        match self.state {
            ServerPhase::Hello { .. } => match self.frames.next::<ClientControl>() {
                None => {}
                Some(Ok(ClientControl::Hello { version, token })) => {
                    self.state = ServerPhase::Deciding;
                    self.events
                        .push_back(ServerConnectionEvent::Hello { version, token });
                }
                // Anything but a hello first, or bytes that are no message.
                Some(Ok(
                    ClientControl::Goodbye
                    | ClientControl::Message(_)
                    | ClientControl::Replay(_)
                    | ClientControl::CancelReplay,
                ))
                | Some(Err(_)) => {
                    self.refuse(Refusal::Malformed, now);
                }
            },
            ServerPhase::Live { .. } => loop {
                match self.frames.next::<ClientControl>() {
                    None => break,
                    Some(Ok(ClientControl::Message(bytes))) => {
                        let taken = self.take_message(Delivery::Reliable, bytes, now);
                        self.messages.push_back(taken);
                    }
                    Some(Ok(ClientControl::Replay(request))) => self.take_replay(request, now),
                    Some(Ok(ClientControl::CancelReplay)) => {
                        self.replays.push_back(Ok(ReplayAsk::Cancel));
                    }
                    Some(Ok(ClientControl::Goodbye)) => {
                        self.end_now(ServerConnectionEnd::Left, Some(goodbye_close()));
                        break;
                    }
                    Some(Ok(ClientControl::Hello { .. })) => {
                        self.fail("a second hello".into(), now);
                        break;
                    }
                    Some(Err(e)) => {
                        self.fail(e.to_string(), now);
                        break;
                    }
                }
            },
            // Read once the client is live.
            ServerPhase::Deciding | ServerPhase::Welcoming { .. } => {}
            ServerPhase::Closing { .. } | ServerPhase::Closed { .. } => {}
        }
    }

    /// Ends with `end`, telling the client `reason` in a goodbye behind
    /// whatever waits, and closing with the close that says it too.
    fn say_goodbye(&mut self, end: ServerConnectionEnd, reason: DisconnectReason, now: Instant) {
        let close = Close::saying(&reason);
        match encode_frame(&ServerControl::Goodbye(reason)) {
            Ok(frame) => {
                self.outbox.push_coded(&frame, now);
                self.end_saying(end, close, now);
            }
            Err(_) => self.end_now(end, Some(close)),
        }
    }

    /// Ends with `end`: what waits (the last words included) is written,
    /// the stream finished, and the link closed with `close`.
    fn end_saying(&mut self, end: ServerConnectionEnd, close: Close, now: Instant) {
        self.set_end(end);
        self.state = ServerPhase::Closing {
            close,
            phase: LastWords::flushing(now, self.config.goodbye),
        };
        if self.outbox.is_empty() {
            self.start_finishing(now);
        }
    }

    /// Ends with `end` and closes with `close` at once.
    fn end_now(&mut self, end: ServerConnectionEnd, close: Option<Close>) {
        self.set_end(end);
        self.outbox.clear();
        self.state = ServerPhase::Closed { close };
    }

    fn set_end(&mut self, end: ServerConnectionEnd) {
        if self.end.is_none() {
            self.end = Some(end);
            self.events.push_back(ServerConnectionEvent::Ending);
        }
    }

    /// Finishes the stream: what could not be written by now is given up
    /// (a finished stream takes no more bytes).
    fn start_finishing(&mut self, now: Instant) {
        self.outbox.clear();
        if let ServerPhase::Closing { phase, .. } = &mut self.state {
            *phase = LastWords::finishing(now, self.config.finish);
        }
    }

    fn close_now(&mut self) {
        let state = std::mem::replace(&mut self.state, ServerPhase::Closed { close: None });
        self.outbox.clear();
        self.state = match state {
            ServerPhase::Closing { close, .. } => ServerPhase::Closed { close: Some(close) },
            other => other,
        };
    }
}

fn hello_cut_short() -> Close {
    Close::new(
        close_code::REFUSED,
        "the control stream ended before a whole hello",
    )
}

fn goodbye_close() -> Close {
    Close::new(close_code::GOODBYE, "goodbye")
}
