//! The connection's background task: a thin shell that moves bytes
//! between quinn and the sans-IO types: the connection's life
//! ([`ClientConnection`]: control messages, the goodbye, every deadline)
//! and the [`ClientSession`] (snapshot datagrams in, input datagrams out
//! when the session says they are due), and obeys the
//! [`super::Client`]'s commands. Everything it learns goes into
//! [`ClientShared`], which the game reads under a short lock.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use inertia_protocol::connection::{ClientConnection, ClientConnectionEvent};
use inertia_protocol::control::{DisconnectReason, ServerControl};
use inertia_protocol::message::{Delivery, GameMessage, MessageDatagram, MessageDecodeError};
use inertia_protocol::replay::{ReplayAnswer, ReplayDatagram, ReplayRequest};
use inertia_protocol::{ClientSession, EntityId};
use tokio::sync::mpsc;

use crate::clock::{Discontinuity, SnapshotMeta};
use crate::entities::KnownEntities;
use crate::interp::{InterpEvent, InterpolationBuffer};
use crate::lead::InputLead;
use crate::predict::Predictor;
use crate::properties::{KnownProperties, PropertyChange};
use crate::replay::{ReplayEvent, ReplayView};
use crate::stats::{ClientStats, StatsRecorder};

use super::ServerInfo;

/// The most events kept for the game to poll; older ones are dropped.
const MAX_EVENTS: usize = 4096;

/// Something that happened on the connection, for the game to react to.
#[derive(Debug, Clone, PartialEq)]
pub enum ClientEvent {
    /// An entity was described to us (its description is in
    /// [`super::Client::entities`]).
    Spawned(EntityId),
    /// An entity left the world or our view.
    Despawned(EntityId),
    /// The replay the player asked for started, was refused or ended (see
    /// [`super::Client::replay`]).
    Replay(ReplayEvent),
    /// A message of the game's from the server's rules: how it came, and
    /// its bytes (read them with the game's type: [`ClientEvent::message`]).
    Message {
        /// How it came.
        delivery: Delivery,
        /// The game's bytes.
        bytes: Vec<u8>,
    },
    /// The game's properties changed: an entity's (`Some`), or the
    /// match's (`None`), as of `tick` (read them with
    /// [`super::Client::properties`] and [`super::Client::match_state`]).
    PropertiesChanged {
        /// The entity, or `None` for the match.
        entity: Option<EntityId>,
        /// The tick the snapshot that said so describes.
        tick: u64,
    },
    /// The server's timeline jumped (seek, rewind, replay): cut or fade.
    Discontinuity(Discontinuity),
    /// Rendering fell far behind after an outage and jumped forwards.
    Resync {
        /// Render tick before.
        from_tick: f64,
        /// Render tick after.
        to_tick: f64,
    },
    /// The connection ended.
    Disconnected(DisconnectReason),
}

impl ClientEvent {
    /// The game's message this event carries, read with the game's type
    /// `M`; `None` for any other event. A message `M` refuses is the
    /// server speaking another game (or another version of it).
    pub fn message<M: GameMessage>(&self) -> Option<Result<M, MessageDecodeError>> {
        match self {
            ClientEvent::Message { bytes, .. } => Some(M::decode(bytes)),
            _ => None,
        }
    }
}

/// What the connection knows, shared with the game.
#[derive(Debug)]
pub(crate) struct ClientShared {
    /// The session: decoder, acknowledgements, inputs and their pacing.
    pub session: ClientSession,
    pub interp: InterpolationBuffer,
    pub entities: KnownEntities,
    /// The newest snapshot decoded: its tick and sequence number.
    pub latest: Option<(u64, u16)>,
    /// The newest snapshot's timing header (tick, time scale, paused).
    pub latest_meta: Option<SnapshotMeta>,
    pub events: VecDeque<ClientEvent>,
    pub disconnected: Option<DisconnectReason>,
    pub stats: StatsRecorder,
    pub events_dropped: u64,
    /// How far ahead of the server inputs are stamped.
    pub lead: InputLead,
    /// The own avatar's prediction, when the game asked for it.
    pub predictor: Option<Predictor>,
    /// The game's properties as the snapshots said them.
    pub properties: KnownProperties,
    /// The replay the player asked for, apart from the live stream.
    pub replay: ReplayView,
}

impl ClientShared {
    pub fn new(info: &ServerInfo, session: ClientSession) -> Self {
        Self {
            session,
            interp: InterpolationBuffer::new(f64::from(info.tick_hz)),
            entities: KnownEntities::new(),
            latest: None,
            latest_meta: None,
            events: VecDeque::new(),
            disconnected: None,
            stats: StatsRecorder::new(),
            events_dropped: 0,
            lead: InputLead::default(),
            predictor: None,
            properties: KnownProperties::new(info.properties.clone()),
            replay: ReplayView::new(info.snapshot, info.tick_hz, info.properties.clone()),
        }
    }

    fn event(&mut self, e: ClientEvent) {
        if self.events.len() >= MAX_EVENTS {
            self.events.pop_front();
            self.events_dropped += 1;
        }
        self.events.push_back(e);
    }

    /// The statistics as of `now` (s since connecting), with QUIC's
    /// smoothed round trip `rtt` (s).
    pub fn stats_at(&mut self, now: f64, rtt: f64) -> ClientStats {
        self.stats.on_rtt(rtt);
        self.stats.on_interp(self.interp.stats());
        self.stats.on_jitter(self.interp.clock().jitter());
        self.stats.on_inputs(
            self.lead.report(),
            self.lead.margin(),
            self.session.stamped_tick(),
        );
        if let Some(p) = &self.predictor {
            self.stats.on_prediction(p.stats());
        }
        self.stats.stats(now)
    }

    /// The input datagram due at `now` (s), if one is, stamped with the
    /// tick it should be applied at (see [`crate::lead`]).
    pub fn poll_input(&mut self, now: f64, rtt: f64) -> Option<Vec<u8>> {
        self.interp.clock_mut().rtt_sample(rtt);
        let tick = self.lead.target_tick(self.interp.clock(), now);
        let before = self.session.stamped_tick();
        let bytes = self.session.poll_input(now, tick);
        if let Some(p) = &mut self.predictor {
            // The inputs this poll stamped, oldest first: each steps the
            // prediction one tick.
            let fresh: Vec<_> = self
                .session
                .sent()
                .filter(|i| before.is_none_or(|b| i.tick > b))
                .copied()
                .collect();
            for input in fresh.iter().rev() {
                p.on_input(input);
            }
        }
        let bytes = bytes?;
        self.stats.on_sent(now, bytes.len());
        Some(bytes)
    }

    /// A datagram from the server at `now` (s); returns the
    /// acknowledgement to send back for a replay snapshot.
    fn on_datagram(&mut self, now: f64, bytes: &[u8]) -> Option<Vec<u8>> {
        if ReplayDatagram::is_one(bytes) {
            let ack = self.replay.on_datagram(now, bytes);
            if ack.is_none() {
                self.stats.on_malformed();
            }
            return ack;
        }
        self.on_live_datagram(now, bytes);
        None
    }

    fn on_live_datagram(&mut self, now: f64, bytes: &[u8]) {
        if MessageDatagram::is_one(bytes) {
            match MessageDatagram::decode(bytes) {
                Ok(message) => self.event(ClientEvent::Message {
                    delivery: Delivery::Unreliable,
                    bytes: message.to_vec(),
                }),
                Err(_) => self.stats.on_malformed(),
            }
            return;
        }
        match self.session.on_datagram(bytes) {
            Ok(snap) => {
                self.stats.on_snapshot(now, snap.sequence, bytes.len());
                let meta = SnapshotMeta {
                    seq: Some(snap.sequence),
                    tick: snap.tick,
                    time_scale: snap.time_scale,
                    paused: snap.paused,
                };
                if snap.newest {
                    for &id in &snap.removed {
                        self.interp.remove(id);
                    }
                    self.entities.update_all(snap.tick, &snap.updated);
                    if let Some(p) = &mut self.predictor {
                        p.on_snapshot(snap.tick, &snap.updated, &self.entities);
                    }
                    self.latest = Some((snap.tick, snap.sequence));
                    self.latest_meta = Some(meta);
                }
                let (sequence, tick, newest) = (snap.sequence, snap.tick, snap.newest);
                // Only the states this snapshot carried: the rest of the
                // view is what earlier snapshots said, no news of this
                // tick (an entity not sent keeps its last state in the
                // buffer, extrapolated and then held).
                self.interp.push_states(now, meta, &snap.updated);
                while let Some(e) = self.interp.poll_event() {
                    let e = match e {
                        InterpEvent::Discontinuity(d) => {
                            self.lead.restart();
                            if let Some(p) = &mut self.predictor {
                                p.reset();
                            }
                            ClientEvent::Discontinuity(d)
                        }
                        InterpEvent::Resync { from_tick, to_tick } => {
                            ClientEvent::Resync { from_tick, to_tick }
                        }
                    };
                    self.event(e);
                }
                let changes = match self.session.decoder().view(sequence) {
                    Some(view) if newest && !self.properties.schema().is_empty() => {
                        self.properties.on_view(tick, view)
                    }
                    _ => Vec::new(),
                };
                for change in changes {
                    let e = match change {
                        PropertyChange::Entity(id) => ClientEvent::PropertiesChanged {
                            entity: Some(id),
                            tick,
                        },
                        PropertyChange::Match => {
                            ClientEvent::PropertiesChanged { entity: None, tick }
                        }
                    };
                    self.event(e);
                }
            }
            Err(_) => self.stats.on_malformed(),
        }
    }

    /// A control message after the welcome (the connection checks that
    /// none is a second welcome or a refusal).
    fn on_control(&mut self, msg: ServerControl) {
        match msg {
            ServerControl::Spawn(desc) => {
                let id = desc.id;
                self.entities.spawn(desc);
                self.event(ClientEvent::Spawned(id));
            }
            ServerControl::Despawn { id } => {
                self.entities.despawn(id);
                self.interp.remove(id);
                self.event(ClientEvent::Despawned(id));
            }
            ServerControl::Message(bytes) => self.event(ClientEvent::Message {
                delivery: Delivery::Reliable,
                bytes,
            }),
            ServerControl::InputTiming(report) => self.lead.on_report(report),
            ServerControl::Replay(answer) => {
                let e = self.replay.on_answer(answer);
                self.event(ClientEvent::Replay(e));
            }
            ServerControl::Goodbye(reason) => {
                self.disconnected = Some(reason.clone());
                self.event(ClientEvent::Disconnected(reason));
            }
            ServerControl::Welcome { .. } | ServerControl::Refused(_) => {}
        }
    }
}

/// What the [`super::Client`] asks of its task.
#[derive(Debug)]
pub(crate) enum DriverCommand {
    /// Send a reliable message of the game's (its size checked).
    Send(Vec<u8>),
    /// Ask for a replay of the recent past.
    Replay(ReplayRequest),
    /// Stop the replay playing.
    CancelReplay,
    /// Say goodbye and close.
    Close,
}

pub(crate) struct Driver {
    pub connection: quinn::Connection,
    /// The connection's life, past its welcome.
    pub conn: ClientConnection,
    pub send: quinn::SendStream,
    pub recv: quinn::RecvStream,
    pub state: Arc<Mutex<ClientShared>>,
    pub commands: mpsc::UnboundedReceiver<DriverCommand>,
    pub epoch: Instant,
}

impl Driver {
    fn lock(&self) -> std::sync::MutexGuard<'_, ClientShared> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// What the control stream's sending half did.
enum Sent {
    Wrote(usize),
    Failed,
    /// The finished stream was taken by the server.
    Taken,
}

/// Runs the connection until it ends.
pub(crate) async fn run(mut d: Driver) {
    let mut buf = vec![0u8; 16 * 1024];
    let mut commands_open = true;
    // When the next input is due: it moves only when one is sent.
    let mut due = input_due(&d);
    loop {
        // What came so far, the messages behind the welcome included.
        while let Some(event) = d.conn.poll_event() {
            if let ClientConnectionEvent::Message(msg) = event {
                d.lock().on_control(msg);
            }
        }
        if d.conn.is_closed() {
            break;
        }
        if d.conn.wants_finish() {
            let _ = d.send.finish();
            d.conn.finish_sent();
        }
        let deadline = d.conn.poll_timeout().map(tokio::time::Instant::from_std);
        let reads = d.conn.reads_control();
        let live = d.conn.is_live();
        tokio::select! {
            datagram = d.connection.read_datagram() => match datagram {
                Ok(bytes) => {
                    let now = d.epoch.elapsed().as_secs_f64();
                    let ack = d.lock().on_datagram(now, &bytes);
                    if let Some(ack) = ack {
                        let _ = d.connection.send_datagram(ack.into());
                    }
                }
                Err(e) => d.conn.on_lost(closed_reason(&e)),
            },
            read = d.recv.read(&mut buf), if reads => match read {
                Ok(Some(n)) => d.conn.on_control_data(&buf[..n], Instant::now()),
                // The server closes next, saying why.
                Ok(None) | Err(_) => d.conn.on_control_finished(Instant::now()),
            },
            sent = write_control(&mut d.send, d.conn.pending_control(), d.conn.awaits_finish()) => match sent {
                Sent::Wrote(n) => d.conn.control_written(n, Instant::now()),
                Sent::Taken => d.conn.on_finish_taken(),
                // The goodbye cannot go: closing says it too.
                Sent::Failed => d.conn.on_finish_taken(),
            },
            () = sleep_until(deadline) => d.conn.handle_timeout(Instant::now()),
            _ = tokio::time::sleep_until(due), if live => {
                let datagram = {
                    let now = d.epoch.elapsed().as_secs_f64();
                    let rtt = d.connection.rtt().as_secs_f64();
                    d.lock().poll_input(now, rtt)
                };
                if let Some(bytes) = datagram {
                    let _ = d.connection.send_datagram(bytes.into());
                }
                due = input_due(&d);
            },
            command = d.commands.recv(), if commands_open => match command {
                Some(DriverCommand::Send(bytes)) => {
                    // Refused only once the connection is ending: the
                    // message goes nowhere, as it would have.
                    let _ = d.conn.send_message(bytes, Instant::now());
                }
                Some(DriverCommand::Replay(request)) => {
                    if let Err(why) = d.conn.ask_replay(request, Instant::now()) {
                        let mut s = d.lock();
                        let e = s.replay.on_answer(ReplayAnswer::Refused(why));
                        s.event(ClientEvent::Replay(e));
                    }
                }
                Some(DriverCommand::CancelReplay) => {
                    let _ = d.conn.cancel_replay(Instant::now());
                }
                Some(DriverCommand::Close) => d.conn.close(Instant::now()),
                // A dropped client closes too.
                None => {
                    commands_open = false;
                    d.conn.close(Instant::now());
                }
            },
        }
    }
    if let Some(close) = d.conn.close_frame() {
        d.connection
            .close(close.code.into(), close.reason.as_bytes());
    }
    let reason = d
        .conn
        .end()
        .map_or(DisconnectReason::ClientLeft, |end| end.reason());
    let mut s = d.lock();
    if s.disconnected.is_none() {
        s.disconnected = Some(reason.clone());
        s.event(ClientEvent::Disconnected(reason));
    }
}

/// Writes `pending` to the control stream, or waits for the finished
/// stream to be taken; otherwise never ready.
async fn write_control(send: &mut quinn::SendStream, pending: &[u8], awaits_finish: bool) -> Sent {
    if !pending.is_empty() {
        match send.write(pending).await {
            Ok(n) => Sent::Wrote(n),
            Err(_) => Sent::Failed,
        }
    } else if awaits_finish {
        let _ = send.stopped().await;
        Sent::Taken
    } else {
        std::future::pending().await
    }
}

/// Sleeps until `deadline`, or forever without one.
pub(super) async fn sleep_until(deadline: Option<tokio::time::Instant>) {
    match deadline {
        Some(deadline) => tokio::time::sleep_until(deadline).await,
        None => std::future::pending().await,
    }
}

/// When the session's next input datagram is due, on tokio's clock.
fn input_due(d: &Driver) -> tokio::time::Instant {
    let at = d.lock().session.next_input_at();
    tokio::time::Instant::from_std(d.epoch) + Duration::from_secs_f64(at.max(0.0))
}

fn closed_reason(e: &quinn::ConnectionError) -> DisconnectReason {
    match e {
        quinn::ConnectionError::TimedOut => DisconnectReason::Timeout,
        quinn::ConnectionError::LocallyClosed => DisconnectReason::ClientLeft,
        quinn::ConnectionError::ApplicationClosed(close) => {
            DisconnectReason::from_close(close.error_code.into_inner(), &close.reason)
        }
        other => DisconnectReason::ProtocolError {
            what: other.to_string(),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use glam::{DQuat, DVec3};
    use inertia_protocol::snapshot::{SnapshotConfig, SnapshotEncoder};
    use inertia_protocol::{ClientConfig, EntityState, PriorityAccumulator};

    fn moving(id: EntityId, x: f64, asleep: bool) -> EntityState {
        EntityState {
            id,
            position: DVec3::new(x, 1.0, 0.0),
            rotation: DQuat::IDENTITY,
            linear_velocity: DVec3::new(3.0, 0.0, 0.0),
            angular_velocity: DVec3::ZERO,
            asleep,
        }
    }

    /// An entity the server left out of a snapshot (its budget was spent
    /// on others) was buffered at that snapshot's tick with the state the
    /// client already had: interpolation then froze it and jumped. Only
    /// what a snapshot carried may be buffered at its tick.
    #[test]
    fn issue_12_an_entity_left_out_is_not_buffered_at_the_new_tick() {
        let config = SnapshotConfig::default();
        let info = ServerInfo {
            client_id: 1,
            tick: 0,
            tick_hz: 60,
            snapshot_hz: 30,
            snapshot: config,
            input_bytes: 5,
            server_version: String::new(),
            game: String::new(),
            properties: Default::default(),
        };
        let session = ClientSession::new(
            ClientConfig {
                snapshot: config,
                input_hz: 30,
                input_redundancy: 4,
                properties: Default::default(),
            },
            0,
        )
        .unwrap();
        let mut state = ClientShared::new(&info, session);
        let mut encoder = SnapshotEncoder::new(config).unwrap();
        let mut priorities = PriorityAccumulator::default();
        // Both fit the first snapshot.
        let first = [moving(1, 0.0, false), moving(2, 10.0, false)];
        let bytes = encoder.encode(10, 1.0, false, &first, &mut priorities, 1200);
        state.on_datagram(0.0, &bytes);
        let (ack, bits) = state.session.decoder().ack_state();
        encoder.on_ack_state(ack, bits);
        // Both move; the budget of the second holds only the awake one
        // (the smallest budget that holds one, found on copies).
        let second = [moving(1, 0.1, false), moving(2, 10.1, true)];
        let budget = (8..64)
            .find(|&b| {
                let (mut e, mut p) = (encoder.clone(), priorities.clone());
                e.encode(12, 1.0, false, &second, &mut p, b);
                e.last_report().included == 1
            })
            .expect("some budget holds exactly one");
        let bytes = encoder.encode(12, 1.0, false, &second, &mut priorities, budget);
        let report = encoder.last_report();
        assert_eq!((report.included, report.deferred), (1, 1), "{report:?}");
        state.on_datagram(1.0 / 30.0, &bytes);

        let ticks = |id| state.interp.states(id).map(|(t, _)| t).collect::<Vec<_>>();
        assert_eq!(ticks(1), [10, 12], "the one sent is buffered at both ticks");
        assert_eq!(ticks(2), [10], "the one left out keeps its last real state");
        let (tick, _) = state.latest.expect("decoded");
        assert_eq!(tick, 12);
        // The whole view still holds it, as the first snapshot had it.
        let view = state
            .session
            .decoder()
            .entities(state.latest.unwrap().1)
            .unwrap();
        assert_eq!(view.len(), 2);
        assert!((view[1].position.x - 10.0).abs() < 1e-3);
    }
}
