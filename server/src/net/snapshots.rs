//! The snapshot stage: one task codes the snapshots of every client, on
//! published frames, in the server's snapshot slots.
//!
//! A slot opens every `1 / snapshot_hz` s of wall time. It is served on
//! the first frame the tick thread publishes after it opens, so snapshots
//! are aligned with ticks and every client of a slot is served the same
//! frame: quantized once ([`Frame::quantized`]), with each entity's delta
//! coded once per baseline state and shared by every client that needs it
//! ([`SharedDeltas`]). While no frame comes (the clock is paused), a slot
//! is served from the latest frame half a period after it opened, so
//! deferred entities still arrive and clients keep acknowledging.
//!
//! The stage has its own thread ([`spawn`]), below the tick thread's
//! priority ([`crate::priority`]), so that on a machine short of cores
//! the encoders wait for the tick, never the tick for the encoders; with
//! a real-time tick it runs real-time too, below the tick and above the
//! network workers.
//!
//! The stage owns every client's [`ServerSession`] (its encoder,
//! priorities and interest) and is the only one to touch it. The client's
//! connection task takes its datagrams: it keeps the inputs and leaves
//! each acknowledgement in the client's mailbox ([`Served::push_ack`]),
//! which the stage empties into the session, in arrival order, before it
//! codes the client's next snapshot.
//!
//! A slot's control messages (the catalog's changes, the events since the
//! client's last slot: [`Told`]) and its snapshot leave together. The
//! stage brings what the client has been told up to date, codes the
//! snapshot in the room those messages and an acknowledgement leave in
//! one packet ([`room_beside`]), and hands both to the client's
//! connection task ([`SlotOutput`]), which writes the messages to the
//! control stream and then queues the datagram. quinn can then send one
//! packet where there were up to three (the snapshot, the control
//! messages, an acknowledgement of the client's inputs): 1.3–1.4 packets
//! a snapshot at 150 clients, from 1.9. A slot with no control message
//! (most slots) queues its datagram with quinn itself, and the
//! connection task is not woken for it.
//!
//! When serving a slot takes too much of the period, or the tick nears its
//! budget, the stage lowers some clients' rates by the policy of
//! [`super::governor`], and counts it in `/metrics`.
//!
//! [`Frame::quantized`]: crate::sim::Frame::quantized

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use inertia_protocol::admin::TimeMode;
use inertia_protocol::control::{encode_frame, InputReport, ServerControl};
use inertia_protocol::replay::ReplayAnswer;
use inertia_protocol::snapshot::{QuantizedFrame, SharedDeltas};
use inertia_protocol::{EntityId, ServerSession, SessionConfig};

use super::catalog::Told;
use super::governor::{degrade_rank, rate_for, Candidate, Decision, RateGovernor};
use super::replays::{DeskOutput, ReplayDesk, ReplayMailbox, ReplayWindow};
use super::NetShared;
use crate::sim::Frame;

/// Acknowledgements a client's mailbox holds at most between two of its
/// snapshots; beyond, the oldest go (a newer one makes a better
/// baseline anyway).
pub const MAX_PENDING_ACKS: usize = 64;

/// One connected client as the stage serves it: what its connection task
/// and the stage share.
#[derive(Debug)]
pub struct Served {
    /// Its connection, for the path's datagram size.
    pub connection: super::link::Link,
    /// Its client id.
    pub client: u64,
    /// The avatar it joined with (its session follows it after).
    pub avatar: EntityId,
    /// The snapshots it acknowledged since its last one was coded, in
    /// arrival order (at most [`MAX_PENDING_ACKS`]).
    acks: Mutex<Vec<u16>>,
    /// What its slots made, for its connection task to send.
    pub out: Mutex<SlotOutput>,
    /// Wakes its connection task when `out` has something.
    pub ready: tokio::sync::Notify,
    /// What it asked of replays, for the stage.
    pub replays: ReplayMailbox,
}

impl Served {
    /// A client joined with `avatar`; the rules' messages from
    /// `first_message` on are news to it ([`crate::sim::JoinedAt`]).
    pub fn new(
        connection: super::link::Link,
        client: u64,
        avatar: EntityId,
        first_message: u64,
    ) -> Self {
        Self {
            connection,
            client,
            avatar,
            acks: Mutex::new(Vec::new()),
            out: Mutex::new(SlotOutput {
                told: Told::new(client, first_message),
                inputs_told: None,
                control: Vec::new(),
                datagram: None,
                error: None,
            }),
            ready: tokio::sync::Notify::new(),
            replays: ReplayMailbox::default(),
        }
    }
}

impl Served {
    /// The client acknowledged snapshot `sequence` (its connection read
    /// it from a datagram): the stage's session takes it before the next
    /// snapshot.
    pub fn push_ack(&self, sequence: u16) {
        if let Ok(mut acks) = self.acks.lock() {
            if acks.len() >= MAX_PENDING_ACKS {
                acks.remove(0);
            }
            acks.push(sequence);
        }
    }

    /// Hands the acknowledgements waiting to `session`, in arrival order.
    fn take_acks(&self, session: &mut ServerSession) {
        if let Ok(mut acks) = self.acks.lock() {
            for &sequence in acks.iter() {
                session.on_ack(sequence);
            }
            acks.clear();
        }
    }
}

/// What a client's slots made for its connection task to send: the
/// control messages first, then the snapshot, so that both leave in one
/// packet when they fit in it.
#[derive(Debug)]
pub struct SlotOutput {
    /// What the client has been told of the catalog and the rules'
    /// messages.
    told: Told,
    /// The last report on its inputs it was sent, and the live tick then.
    inputs_told: Option<(u64, InputReport)>,
    /// Control frames waiting to be written to the control stream.
    pub control: Vec<u8>,
    /// The newest snapshot datagram, unsent (a newer one replaces it).
    pub datagram: Option<Vec<u8>>,
    /// Why the client cannot be told what it must be (a control message
    /// that cannot be coded): its connection ends.
    pub error: Option<String>,
}

/// Room a snapshot leaves in its packet for an acknowledgement of the
/// client's inputs, bytes: quinn bundles a pending ACK frame (about 10
/// bytes with a few ranges) after the other frames when it fits, which
/// saves an ACK-only packet.
pub const ACK_ROOM: usize = 24;

/// The most control-message bytes that share a packet with the snapshot;
/// more go in packets of their own, beside a full snapshot.
pub const MAX_CONTROL_BESIDE: usize = 480;

/// A STREAM frame's own bytes beyond its data, at most: type, stream id,
/// offset and length.
const STREAM_FRAME_OVERHEAD: usize = 1 + 8 + 8 + 2;

/// The room a snapshot leaves in its packet for what travels with it:
/// an acknowledgement, and `control` bytes of control messages when they
/// are few.
pub fn room_beside(control: usize) -> usize {
    ACK_ROOM
        + if control > 0 && control <= MAX_CONTROL_BESIDE {
            control + STREAM_FRAME_OVERHEAD
        } else {
            0
        }
}

/// The clients the stage serves, by connection number.
#[derive(Debug, Default)]
pub struct ServedClients {
    clients: Mutex<BTreeMap<u64, Arc<Served>>>,
}

impl ServedClients {
    /// Serves `served` as connection `id` until the returned guard drops.
    pub fn add(self: &Arc<Self>, id: u64, served: Arc<Served>) -> ServedGuard {
        if let Ok(mut c) = self.clients.lock() {
            c.insert(id, served);
        }
        ServedGuard {
            clients: self.clone(),
            id,
        }
    }

    /// Puts every client served now into `out` (emptied first), with its
    /// connection number, in connection order.
    fn snapshot_into(&self, out: &mut Vec<(u64, Arc<Served>)>) {
        out.clear();
        if let Ok(c) = self.clients.lock() {
            out.extend(c.iter().map(|(&id, s)| (id, s.clone())));
        }
    }
}

/// Stops serving a client when dropped.
#[derive(Debug)]
pub struct ServedGuard {
    clients: Arc<ServedClients>,
    id: u64,
}

impl Drop for ServedGuard {
    fn drop(&mut self) {
        if let Ok(mut c) = self.clients.clients.lock() {
            c.remove(&self.id);
        }
    }
}

/// Starts the stage on its own thread, named `inertia-snapshots`, with its
/// own single-threaded runtime, real-time below the tick when `realtime`
/// and allowed, else at the process's priority (see [`crate::priority`]);
/// it ends when [`run`] does.
pub fn spawn(
    shared: Arc<NetShared>,
    realtime: bool,
) -> std::io::Result<std::thread::JoinHandle<()>> {
    std::thread::Builder::new()
        .name("inertia-snapshots".into())
        .spawn(move || {
            crate::priority::raise_stage_thread(realtime);
            match tokio::runtime::Builder::new_current_thread()
                .enable_time()
                .build()
            {
                Ok(runtime) => runtime.block_on(run(shared)),
                Err(e) => tracing::error!(error = %e, "the snapshot stage could not start"),
            }
        })
}

/// Runs the stage until shutdown or until the simulation is gone.
pub async fn run(shared: Arc<NetShared>) {
    let mut frames = shared.sim.subscribe();
    let mut shutdown = shared.shutdown.clone();
    let period = Duration::from_secs_f64(1.0 / f64::from(shared.streaming.snapshot_hz.max(1)));
    let mut opens = tokio::time::Instant::now();
    let mut slot: u64 = 0;
    let mut deltas = SharedDeltas::new();
    let mut clients = Vec::new();
    let mut governor = RateGovernor::new(shared.streaming.snapshot_hz, shared.streaming.tick_hz);
    let mut handed_out = RatesHandedOut::default();
    // Every client's session, by connection number: the stage's alone.
    let mut sessions: BTreeMap<u64, ServerSession> = BTreeMap::new();
    let session_config = shared.streaming.session_config();
    // The live frames served lately, and the players' replays of them.
    let mut window = shared.streaming.replay_window();
    let mut desk = shared.streaming.replay_desk();
    let mut replayed = Vec::new();
    loop {
        tokio::select! {
            changed = frames.changed() => if changed.is_err() { return },
            _ = tokio::time::sleep_until(opens + period / 2) => {}
            _ = shutdown.changed() => return,
        }
        // Marks the frame seen whichever branch woke the stage.
        let frame = frames.borrow_and_update().clone();
        let now = tokio::time::Instant::now();
        if now < opens {
            continue;
        }
        shared.served.snapshot_into(&mut clients);
        follow_clients(&mut sessions, &clients, &session_config);
        if !clients.is_empty() {
            let serving = Instant::now();
            let degraded = governor.degraded();
            if handed_out.stale(degraded, &clients) {
                set_rates(&clients, &mut sessions, degraded);
                handed_out.record(degraded, &clients);
            }
            let quantized = frame.quantized(&shared.streaming.snapshot);
            for (id, served) in &clients {
                if let Some(session) = sessions.get_mut(id) {
                    let slot_of = Slot {
                        frame: &frame,
                        quantized,
                        number: slot,
                    };
                    serve(served, session, &slot_of, &mut deltas, &shared);
                }
            }
            let live = serving.elapsed();
            if frame.mode == TimeMode::Live {
                window.push(quantized);
            }
            let replays = Replays {
                desk: &mut desk,
                window: &window,
                until: serving + period.mul_f64(REPLAY_SLOT_SHARE),
            };
            replays.serve(&clients, &sessions, &shared, &mut replayed);
            let decision = governor.after_slot(live, frame.tick_duration, clients.len());
            let direction = match decision {
                Decision::Hold => None,
                Decision::Degrade => Some("degrade"),
                Decision::Restore => Some("restore"),
            };
            if let Some(direction) = direction {
                shared
                    .metrics
                    .snapshot_rate_steps
                    .get_or_create(&[("direction", direction)])
                    .inc();
                tracing::debug!(
                    direction,
                    degraded = governor.degraded(),
                    clients = clients.len(),
                    "snapshot rates"
                );
            }
            shared
                .metrics
                .snapshot_clients_degraded
                .set(governor.degraded() as i64);
            clients.clear();
        }
        shared
            .metrics
            .seek_memory
            .get_or_create(&[("part", "replay_window")])
            .set(window.bytes() as i64);
        slot += 1;
        opens += period;
        // Slots missed while the stage was behind are skipped, not run in
        // a burst.
        if opens <= now {
            opens = now + period;
        }
    }
}

/// Makes a session for each client new to the stage (with its avatar)
/// and drops those of clients it no longer serves.
fn follow_clients(
    sessions: &mut BTreeMap<u64, ServerSession>,
    clients: &[(u64, Arc<Served>)],
    config: &SessionConfig,
) {
    sessions.retain(|id, _| clients.binary_search_by_key(id, |(c, _)| *c).is_ok());
    for (id, served) in clients {
        sessions.entry(*id).or_insert_with(|| {
            let mut session = ServerSession::new(config.clone()).expect("validated at start-up");
            session.set_avatar(served.avatar);
            session
        });
    }
}

/// How far into a slot's period replays may still be served: the live
/// clients go first, and replays take what is left of the first 60 % of
/// the period (the rest is the tick's and the network's).
const REPLAY_SLOT_SHARE: f64 = 0.6;

/// The players' replays in one slot: the desk that plays them, the frames
/// they show, and until when the slot has time for them.
struct Replays<'a> {
    desk: &'a mut ReplayDesk,
    window: &'a ReplayWindow,
    until: Instant,
}

impl Replays<'_> {
    /// Takes what every client asked of replays since the last slot, plays
    /// each replay its next frame while the slot has time, and hands the
    /// clients what that made: answers on their control streams, replay
    /// datagrams sent from here.
    fn serve(
        self,
        clients: &[(u64, Arc<Served>)],
        sessions: &BTreeMap<u64, ServerSession>,
        shared: &NetShared,
        out: &mut Vec<DeskOutput>,
    ) {
        let now = Instant::now();
        self.desk
            .retain(|c| clients.binary_search_by_key(&c, |(id, _)| *id).is_ok());
        for (id, served) in clients {
            let avatar = sessions.get(id).and_then(|s| s.avatar());
            for ask in served.replays.take_asks() {
                self.desk.ask(*id, ask, avatar, self.window, now, out);
            }
            for (replay, sequence) in served.replays.take_acks() {
                self.desk.on_ack(*id, replay, sequence);
            }
        }
        let max_datagram = |c: u64| {
            find(clients, c)
                .and_then(|s| s.connection.max_datagram_size())
                .unwrap_or(1200)
                .saturating_sub(ACK_ROOM)
        };
        let until = self.until;
        self.desk.serve(
            self.window,
            now,
            max_datagram,
            || Instant::now() < until,
            out,
        );
        for output in out.drain(..) {
            match output {
                DeskOutput::Datagram { connection, bytes } => {
                    if let Some(served) = find(clients, connection) {
                        send_datagram(&served.connection, bytes, shared);
                        shared.metrics.replay_snapshots.inc();
                    }
                }
                DeskOutput::Answer { connection, answer } => {
                    shared.metrics.replay_outcome(answer.label());
                    if let Some(served) = find(clients, connection) {
                        tell_replay(served, answer);
                    }
                }
            }
        }
        shared
            .metrics
            .replays_playing
            .set(self.desk.playing() as i64);
        shared
            .metrics
            .replays_waiting
            .set(self.desk.waiting() as i64);
    }
}

/// The client served as connection `connection`.
fn find(clients: &[(u64, Arc<Served>)], connection: u64) -> Option<&Served> {
    clients
        .binary_search_by_key(&connection, |(id, _)| *id)
        .ok()
        .map(|i| &*clients[i].1)
}

/// Queues `answer` on the client's control stream and wakes its
/// connection task to write it.
fn tell_replay(served: &Served, answer: ReplayAnswer) {
    let Ok(bytes) = encode_frame(&ServerControl::Replay(answer)) else {
        return;
    };
    if let Ok(mut out) = served.out.lock() {
        out.control.extend_from_slice(&bytes);
    }
    served.ready.notify_one();
}

/// One snapshot slot: its number and the frame it serves, quantized.
struct Slot<'a> {
    frame: &'a Frame,
    quantized: &'a QuantizedFrame,
    number: u64,
}

/// Serves one client its slot: brings what it has been told up to date
/// with the frame (catalog, events), codes its snapshot in the room those
/// control messages leave in the packet, and hands both to its connection
/// task, which writes the control messages and then queues the datagram,
/// so that quinn sends them (and an acknowledgement) in one packet. A
/// snapshot with no control message beside it is queued from here.
fn serve(
    served: &Served,
    session: &mut ServerSession,
    slot: &Slot<'_>,
    deltas: &mut SharedDeltas,
    shared: &NetShared,
) {
    let (frame, quantized) = (slot.frame, slot.quantized);
    // The rules' unreliable messages for the client, sent before its
    // snapshot.
    let mut datagrams = Vec::new();
    // What the slot tells the client, and the room it takes; the lock is
    // not held over the encode, so the connection task is never kept
    // waiting for one.
    let control = {
        let Ok(mut out) = served.out.lock() else {
            return;
        };
        let out = &mut *out;
        if out.error.is_some() {
            return;
        }
        let told = out.told.catch_up(
            frame.catalog_version,
            &frame.catalog,
            &frame.catalog_changes,
            &frame.messages,
            &mut out.control,
            &mut datagrams,
        );
        match told {
            Ok(caught) => {
                shared.metrics.bytes_sent.inc_by(caught.bytes as u64);
                shared.metrics.messages_missed.inc_by(caught.missed);
            }
            Err(e) => {
                out.error = Some(e);
                served.ready.notify_one();
                return;
            }
        };
        let told = tell_input_timing(out, frame, served.client, shared.streaming.tick_hz);
        shared.metrics.bytes_sent.inc_by(told as u64);
        out.control.len()
    };
    for bytes in datagrams {
        let len = bytes.len();
        if served.connection.send_datagram(bytes.into()) {
            shared.metrics.bytes_sent.inc_by(len as u64);
            shared.metrics.packets_sent.inc();
        }
    }
    let max = served.connection.max_datagram_size().unwrap_or(1200);
    let max = max.saturating_sub(room_beside(control));
    served.take_acks(session);
    follow_avatar(session, frame, served.client);
    let started = Instant::now();
    let bytes = session.poll_snapshot(quantized, deltas, slot.number, max);
    let encoding = started.elapsed();
    if bytes.is_some() {
        shared
            .metrics
            .snapshot_encode
            .observe(encoding.as_secs_f64());
    }
    let Ok(mut out) = served.out.lock() else {
        return;
    };
    match bytes {
        // Nothing for the control stream, and nothing of an earlier slot
        // still waiting: the snapshot goes now, from here, and the
        // connection task is not woken for it.
        Some(bytes) if out.control.is_empty() && out.datagram.is_none() => {
            drop(out);
            send_datagram(&served.connection, bytes, shared);
        }
        Some(bytes) => {
            if out.datagram.replace(bytes).is_some() {
                shared.metrics.snapshots_superseded.inc();
            }
            served.ready.notify_one();
        }
        None if !out.control.is_empty() => served.ready.notify_one(),
        None => {}
    }
}

/// Tells the client how its inputs have been arriving (the server's
/// `InputTiming` message), at most once a second of live ticks and only
/// when the report changed. Returns the bytes queued.
fn tell_input_timing(out: &mut SlotOutput, frame: &Frame, client: u64, tick_hz: u32) -> usize {
    let Some(&report) = frame.inputs.get(&client) else {
        return 0;
    };
    let due = out.inputs_told.is_none_or(|(tick, told)| {
        told != report && frame.live_tick >= tick.saturating_add(u64::from(tick_hz))
    });
    if !due {
        return 0;
    }
    let Ok(bytes) = encode_frame(&ServerControl::InputTiming(report)) else {
        return 0;
    };
    out.control.extend_from_slice(&bytes);
    out.inputs_told = Some((frame.live_tick, report));
    bytes.len()
}

/// Queues snapshot `bytes` on `connection` for quinn to send, and counts
/// it.
pub fn send_datagram(connection: &super::link::Link, bytes: Vec<u8>, shared: &NetShared) {
    let len = bytes.len();
    if connection.send_datagram(bytes.into()) {
        shared.metrics.bytes_sent.inc_by(len as u64);
        shared.metrics.packets_sent.inc();
        shared.metrics.snapshot_size.observe(len as f64);
    }
}

/// Gives the session the client's new avatar when a loaded checkpoint
/// gave it one (its old one is gone from the live catalog).
fn follow_avatar(session: &mut ServerSession, frame: &Frame, client: u64) {
    let gone = session
        .avatar()
        .is_some_and(|avatar| !frame.catalog.contains_key(&avatar));
    if gone && frame.mode == TimeMode::Live {
        if let Some(id) = frame.avatar_of(client) {
            session.set_avatar(id);
        }
    }
}

/// The rates as last handed out: how many clients at the lower rate,
/// among which connections. New clients start at full rate, so while
/// none is lowered there is nothing to hand out.
#[derive(Debug, Default)]
struct RatesHandedOut {
    degraded: usize,
    connections: Vec<u64>,
}

impl RatesHandedOut {
    /// Whether `degraded` lowered among `clients` needs handing out again.
    fn stale(&self, degraded: usize, clients: &[(u64, Arc<Served>)]) -> bool {
        (degraded > 0 || self.degraded > 0)
            && (degraded != self.degraded
                || !clients.iter().map(|(id, _)| id).eq(&self.connections))
    }

    fn record(&mut self, degraded: usize, clients: &[(u64, Arc<Served>)]) {
        self.degraded = degraded;
        self.connections.clear();
        self.connections.extend(clients.iter().map(|(id, _)| *id));
    }
}

/// Gives the first `degraded` clients by [`degrade_rank`] the lower rate
/// and every other client its full rate.
fn set_rates(
    clients: &[(u64, Arc<Served>)],
    sessions: &mut BTreeMap<u64, ServerSession>,
    degraded: usize,
) {
    let mut order: Vec<Candidate> = clients
        .iter()
        .map(|(id, _)| Candidate {
            connection: *id,
            plays: sessions.get(id).is_some_and(|s| s.avatar().is_some()),
        })
        .collect();
    order.sort_unstable_by_key(degrade_rank);
    for (rank, candidate) in order.iter().enumerate() {
        let (divisor, phase) = rate_for(rank, degraded);
        if let Some(session) = sessions.get_mut(&candidate.connection) {
            session.set_rate_divisor(divisor, phase);
        }
    }
}
