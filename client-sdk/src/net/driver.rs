//! The connection's background task: one loop that reads snapshot
//! datagrams and control frames, sends inputs on a timer, and obeys the
//! [`super::Client`]'s commands. Everything it learns goes into [`State`],
//! which the game reads under a short lock.

use std::collections::VecDeque;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use inertia_protocol::control::{
    encode_frame, ClientControl, DisconnectReason, FrameDecoder, GameEvent, ServerControl,
};
use inertia_protocol::input::InputDatagram;
use inertia_protocol::snapshot::{SnapshotDecoder, ViewEntity};
use inertia_protocol::{EntityId, EntityState, PlayerInput};
use tokio::sync::mpsc;

use crate::clock::{Discontinuity, SnapshotMeta};
use crate::entities::EntityTable;
use crate::interp::{EntityView, InterpEvent, InterpolationBuffer, Snapshot};
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
    /// A game event from the server.
    Game(GameEvent),
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

/// What the connection knows, shared with the game.
#[derive(Debug)]
pub(crate) struct State {
    pub decoder: SnapshotDecoder,
    pub interp: InterpolationBuffer,
    pub entities: EntityTable,
    /// The newest snapshot decoded: its tick and sequence number.
    pub latest: Option<(u64, u16)>,
    pub events: VecDeque<ClientEvent>,
    pub input: PlayerInput,
    pub disconnected: Option<DisconnectReason>,
    pub stats: StatsRecorder,
    pub events_dropped: u64,
}

impl State {
    pub fn new(info: &ServerInfo, decoder: SnapshotDecoder) -> Self {
        Self {
            decoder,
            interp: InterpolationBuffer::new(f64::from(info.tick_hz)),
            entities: EntityTable::new(),
            latest: None,
            events: VecDeque::new(),
            input: PlayerInput {
                tick: info.tick,
                ..PlayerInput::default()
            },
            disconnected: None,
            stats: StatsRecorder::new(),
            events_dropped: 0,
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
        self.stats.stats(now)
    }

    fn on_datagram(&mut self, now: f64, bytes: &[u8]) {
        match self.decoder.decode(bytes) {
            Ok(snap) => {
                self.stats.on_snapshot(now, snap.sequence, bytes.len());
                let meta = SnapshotMeta {
                    seq: Some(snap.sequence),
                    tick: snap.tick,
                    time_scale: snap.time_scale,
                    paused: snap.paused,
                };
                // Only the states this snapshot carried: the rest of the
                // view is what earlier snapshots said, no news of this
                // tick (an entity not sent keeps its last state in the
                // buffer, extrapolated and then held).
                let entities = snap.updated.iter().map(view_of).collect();
                if snap.newest {
                    for &id in &snap.removed {
                        self.interp.remove(id);
                    }
                    for e in &snap.updated {
                        self.entities.update(snap.tick, state_of(e));
                    }
                    self.latest = Some((snap.tick, snap.sequence));
                }
                self.interp.push(now, Snapshot { meta, entities });
                while let Some(e) = self.interp.poll_event() {
                    let e = match e {
                        InterpEvent::Discontinuity(d) => ClientEvent::Discontinuity(d),
                        InterpEvent::Resync { from_tick, to_tick } => {
                            ClientEvent::Resync { from_tick, to_tick }
                        }
                    };
                    self.event(e);
                }
            }
            Err(_) => self.stats.on_malformed(),
        }
    }

    fn on_control(&mut self, msg: ServerControl) -> Result<(), String> {
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
            ServerControl::Event(e) => self.event(ClientEvent::Game(e)),
            ServerControl::Goodbye(reason) => {
                self.disconnected = Some(reason.clone());
                self.event(ClientEvent::Disconnected(reason));
            }
            other @ (ServerControl::Welcome { .. } | ServerControl::Refused(_)) => {
                return Err(format!("unexpected after the welcome: {other:?}"));
            }
        }
        Ok(())
    }
}

fn state_of(e: &ViewEntity) -> EntityState {
    EntityState {
        id: e.id,
        position: e.position,
        rotation: e.rotation,
        linear_velocity: e.velocity.unwrap_or_default(),
        angular_velocity: glam::DVec3::ZERO,
        asleep: e.at_rest,
    }
}

fn view_of(e: &ViewEntity) -> EntityView {
    EntityView {
        id: e.id,
        position: e.position,
        rotation: e.rotation,
        linear_velocity: e.velocity,
        angular_velocity: None,
        at_rest: e.at_rest,
    }
}

/// What the [`super::Client`] asks of its task.
#[derive(Debug)]
pub(crate) enum Command {
    /// Say goodbye and close.
    Close,
}

pub(crate) struct Driver {
    pub connection: quinn::Connection,
    pub send: quinn::SendStream,
    pub recv: quinn::RecvStream,
    pub frames: FrameDecoder,
    pub state: Arc<Mutex<State>>,
    pub commands: mpsc::UnboundedReceiver<Command>,
    pub epoch: Instant,
    pub input_hz: u32,
    /// Inputs per datagram, 1 to
    /// [`inertia_protocol::input::MAX_REDUNDANT_INPUTS`].
    pub input_redundancy: usize,
}

impl Driver {
    fn lock(&self) -> std::sync::MutexGuard<'_, State> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }
}

/// Hands every whole control frame received so far to the state.
fn take_frames(d: &mut Driver) -> Result<(), String> {
    while let Some(msg) = d.frames.next::<ServerControl>() {
        msg.map_err(|e| e.to_string())
            .and_then(|m| d.lock().on_control(m))?;
    }
    Ok(())
}

/// Runs the connection until it ends.
pub(crate) async fn run(mut d: Driver) {
    let mut timer = tokio::time::interval(Duration::from_secs_f64(1.0 / f64::from(d.input_hz)));
    timer.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
    let mut history: VecDeque<PlayerInput> = VecDeque::new();
    let mut sequence: u32 = 0;
    let mut buf = vec![0u8; 16 * 1024];
    // The read that brought the welcome may have brought what followed it
    // too (the catalog, when the two arrive together): it is not left
    // waiting for the next read, which may never come.
    let reason = 'run: {
        if let Err(e) = take_frames(&mut d) {
            break 'run protocol_error(&d.connection, e);
        }
        loop {
            tokio::select! {
                datagram = d.connection.read_datagram() => match datagram {
                    Ok(bytes) => {
                        let now = d.epoch.elapsed().as_secs_f64();
                        d.lock().on_datagram(now, &bytes);
                    }
                    Err(e) => break closed_reason(&e),
                },
                read = d.recv.read(&mut buf) => match read {
                    Ok(Some(n)) => {
                        if let Err(e) = d.frames.push(&buf[..n]) {
                            break protocol_error(&d.connection, e.to_string());
                        }
                        if let Err(e) = take_frames(&mut d) {
                            break protocol_error(&d.connection, e);
                        }
                    }
                    Ok(None) | Err(_) => {
                        let e = d.connection.closed().await;
                        break closed_reason(&e);
                    }
                },
                _ = timer.tick() => {
                    let (datagram, _) = {
                        let mut s = d.lock();
                        let now = d.epoch.elapsed().as_secs_f64();
                        sequence = sequence.wrapping_add(1);
                        let rtt = d.connection.rtt().as_secs_f64();
                        s.interp.clock_mut().rtt_sample(rtt);
                        let tick = s.interp.clock().estimated_tick(now).map_or(s.input.tick, |t| t.max(0.0) as u64);
                        let input = PlayerInput { sequence, tick, ..s.input };
                        history.push_front(input);
                        history.truncate(d.input_redundancy);
                        let (ack, ack_bits) = s.decoder.ack_state();
                        (InputDatagram { ack, ack_bits, inputs: history.iter().copied().collect() }, ())
                    };
                    if let Ok(bytes) = datagram.encode() {
                        let _ = d.connection.send_datagram(bytes.into());
                    }
                },
                command = d.commands.recv() => {
                    // A dropped client closes too.
                    let _ = command;
                    if let Ok(bytes) = encode_frame(&ClientControl::Goodbye) {
                        let _ = d.send.write_all(&bytes).await;
                    }
                    let _ = d.send.finish();
                    // Give the goodbye a moment to arrive before closing.
                    let _ = tokio::time::timeout(Duration::from_millis(200), d.send.stopped()).await;
                    d.connection.close(0u32.into(), b"client left");
                    break DisconnectReason::ClientLeft;
                },
            }
        }
    };
    let mut s = d.lock();
    if s.disconnected.is_none() {
        s.disconnected = Some(reason.clone());
        s.event(ClientEvent::Disconnected(reason));
    }
}

fn protocol_error(connection: &quinn::Connection, what: String) -> DisconnectReason {
    connection.close(2u32.into(), b"protocol error");
    DisconnectReason::ProtocolError { what }
}

fn closed_reason(e: &quinn::ConnectionError) -> DisconnectReason {
    match e {
        quinn::ConnectionError::TimedOut => DisconnectReason::Timeout,
        quinn::ConnectionError::LocallyClosed => DisconnectReason::ClientLeft,
        quinn::ConnectionError::ApplicationClosed(close) => {
            let text = String::from_utf8_lossy(&close.reason).into_owned();
            if let Some(reason) = text.strip_prefix("simulation stopped: ") {
                DisconnectReason::SimulationStopped {
                    reason: reason.to_string(),
                }
            } else if text.contains("shut") {
                DisconnectReason::ServerShutdown
            } else {
                DisconnectReason::Kicked { reason: text }
            }
        }
        other => DisconnectReason::ProtocolError {
            what: other.to_string(),
        },
    }
}
