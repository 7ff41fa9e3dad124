//! The server's half of one client's game session that sends, without
//! sockets: what goes out as snapshots, against what the client
//! acknowledged. The client's datagrams (acknowledgements and inputs) are
//! taken by its connection ([`crate::connection::ServerConnection::on_datagram`]),
//! which keeps the inputs and hands on the acknowledgement; the server's
//! snapshot stage owns every client's [`ServerSession`] and is the only
//! one to touch it. The tests drive the very same types through simulated
//! links.
//!
//! Snapshots are coded from published frames ([`QuantizedFrame`], one per
//! frame for every client) at the server's snapshot slots: every client
//! is served the same frame in the same slot, and one whose rate is lower
//! takes every `n`-th slot, the same slots on every run.

use crate::entity::EntityId;
use crate::interest::Interest;
use crate::priority::PriorityAccumulator;
use crate::snapshot::{
    EncodeReport, QuantizedFrame, SharedDeltas, SnapshotConfig, SnapshotConfigError,
    SnapshotEncoder,
};

/// Within this distance of a client's avatar, m, entities are fully
/// relevant; relevance then falls off to zero at [`INTEREST_MAX_M`].
pub const INTEREST_FULL_M: f64 = 60.0;
/// Beyond this distance of a client's avatar, m, entities are not sent
/// (and leave the client's view) unless always relevant.
pub const INTEREST_MAX_M: f64 = 250.0;

/// How a [`ServerSession`] serves its client.
#[derive(Debug, Clone, PartialEq)]
pub struct SessionConfig {
    /// How snapshots are coded (the same for every client of a server).
    pub snapshot: SnapshotConfig,
    /// The client's budget for one snapshot, bytes (its bandwidth budget
    /// over the snapshot rate); the datagram size bounds it too.
    pub budget_bytes: usize,
    /// Serve one snapshot slot in this many (1: every slot).
    pub every_slots: u32,
    /// Within this distance of the avatar entities are fully relevant, m.
    pub interest_full_m: f64,
    /// Beyond this distance of the avatar entities are not sent, m.
    pub interest_max_m: f64,
    /// The game's properties every snapshot carries (see
    /// [`crate::property`]; none by default).
    pub properties: std::sync::Arc<crate::property::PropertySchema>,
}

impl SessionConfig {
    /// `snapshot` coding within `budget_bytes` a snapshot, every slot, with
    /// interest [`INTEREST_FULL_M`] full and [`INTEREST_MAX_M`] at most.
    pub fn new(snapshot: SnapshotConfig, budget_bytes: usize) -> Self {
        Self {
            snapshot,
            budget_bytes,
            every_slots: 1,
            interest_full_m: INTEREST_FULL_M,
            interest_max_m: INTEREST_MAX_M,
            properties: Default::default(),
        }
    }
}

/// One client's session on the server: its snapshot encoder (views sent,
/// acknowledgements), priorities and interest.
#[derive(Debug, Clone)]
pub struct ServerSession {
    config: SessionConfig,
    encoder: SnapshotEncoder,
    priorities: PriorityAccumulator,
    avatar: Option<EntityId>,
    /// The server's divisor on top of `every_slots` when it degrades
    /// (1: none), and which of those slots this client takes.
    divisor: u32,
    phase: u32,
}

impl ServerSession {
    /// A session that has sent nothing and received nothing.
    pub fn new(config: SessionConfig) -> Result<Self, SnapshotConfigError> {
        let encoder =
            SnapshotEncoder::new(config.snapshot)?.with_properties(config.properties.clone());
        Ok(Self {
            priorities: PriorityAccumulator::new(Interest::everything()),
            encoder,
            config,
            avatar: None,
            divisor: 1,
            phase: 0,
        })
    }

    /// The configuration.
    pub fn config(&self) -> &SessionConfig {
        &self.config
    }

    /// The client's avatar: always relevant, and where its interest is
    /// centred once a frame holds it.
    pub fn set_avatar(&mut self, avatar: EntityId) {
        if let Some(old) = self.avatar.replace(avatar) {
            self.priorities.interest_mut().always_relevant.remove(&old);
        }
        self.priorities
            .interest_mut()
            .always_relevant
            .insert(avatar);
    }

    /// The client's avatar, if it has one.
    pub fn avatar(&self) -> Option<EntityId> {
        self.avatar
    }

    /// The client acknowledged snapshot `sequence` (the newest it had
    /// when it sent a datagram, as its connection read it): the encoder's
    /// next baseline. Acknowledgements are taken in the order they came.
    pub fn on_ack(&mut self, sequence: u16) {
        self.encoder.on_ack(sequence);
    }

    /// Whether snapshot slot `slot` (counted by the server from its
    /// start) is one this client is served in.
    pub fn serves_slot(&self, slot: u64) -> bool {
        let every = u64::from(self.config.every_slots.max(1)) * u64::from(self.divisor);
        (slot + u64::from(self.phase)) % every == 0
    }

    /// Serves this client in one slot of `divisor` of those it takes by
    /// its configuration (1: all of them), offset by `phase` slots, so a
    /// server that lowers some clients' rates can spread them over the
    /// slots. A divisor of 0 counts as 1.
    pub fn set_rate_divisor(&mut self, divisor: u32, phase: u32) {
        self.divisor = divisor.max(1);
        self.phase = phase % self.divisor;
    }

    /// The divisor [`Self::set_rate_divisor`] set (1: full rate).
    pub fn rate_divisor(&self) -> u32 {
        self.divisor
    }

    /// The snapshot of `frame` for this client in slot `slot`, at most
    /// `max_datagram` bytes (the path's datagram size), taking entity
    /// deltas from `shared` (the frame's, shared by every client); `None`
    /// in a slot the client skips. Interest centres on the avatar where
    /// the frame holds it.
    pub fn poll_snapshot(
        &mut self,
        frame: &QuantizedFrame,
        shared: &mut SharedDeltas,
        slot: u64,
        max_datagram: usize,
    ) -> Option<Vec<u8>> {
        if !self.serves_slot(slot) {
            return None;
        }
        Some(self.snapshot_at(frame, frame.time_scale, shared, max_datagram))
    }

    /// The snapshot of `frame` with the header's time scale `time_scale`
    /// (a replay's speed), whatever the slot, at most `max_datagram`
    /// bytes: what a replay of the recent past sends, on a session of its
    /// own (its own views and sequence numbers) whose "avatar" is the
    /// entity it centres on.
    pub fn snapshot_at(
        &mut self,
        frame: &QuantizedFrame,
        time_scale: f32,
        shared: &mut SharedDeltas,
        max_datagram: usize,
    ) -> Vec<u8> {
        let point = self
            .avatar
            .and_then(|a| frame.index_of(a))
            .map(|i| frame.position(i));
        // Until the frame holds the avatar, the interest stays as it was
        // (everything, everywhere, at first).
        if let Some(p) = point {
            let interest = self.priorities.interest_mut();
            interest.point = p;
            interest.radius_full = self.config.interest_full_m;
            interest.radius_max = self.config.interest_max_m;
        }
        let budget = self.config.budget_bytes.min(max_datagram);
        self.encoder
            .encode_shared_at(frame, time_scale, shared, &mut self.priorities, budget)
    }

    /// What the last snapshot did.
    pub fn last_report(&self) -> EncodeReport {
        self.encoder.last_report()
    }

    /// The snapshot encoder (views sent, the newest acknowledged).
    pub fn encoder(&self) -> &SnapshotEncoder {
        &self.encoder
    }
}
