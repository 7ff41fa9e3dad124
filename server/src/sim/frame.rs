//! What the tick thread publishes after a loop's ticks: the states of
//! everything that moves, the entity catalog, the rules' recent messages
//! and the clock, with the states quantized once for every client on demand.

use std::collections::BTreeMap;
use std::sync::{Arc, OnceLock};
use std::time::Duration;

use inertia_protocol::control::{encode_frame, InputReport, ServerControl};
use inertia_protocol::message::{Delivery, MessageDatagram};
use inertia_protocol::property::FrameProperties;
use inertia_protocol::snapshot::{QuantizedFrame, SnapshotConfig};
use inertia_protocol::{EntityDesc, EntityId, EntityKind, EntityState};

use super::{Simulation, TimeMode};
use crate::rules::OutgoingMessage;

/// Messages a [`Frame`] carries: the most recent ones, whatever frame they
/// were first published in. A client whose slots fall further behind
/// than this misses the oldest (counted in `/metrics`). The tick thread
/// copies the list (its `Arc`s) whenever a message is published, so it
/// stays short.
pub const RECENT_MESSAGES: usize = 1024;

/// Catalog changes a [`Frame`] carries: the most recent ones. A client
/// told an older version is brought up to date by a walk of the whole
/// catalog instead.
pub const RECENT_CATALOG_CHANGES: usize = 64;

/// One change of the catalog, as the version it made: what left and what
/// came (both ascending by id), so that each client is told the change
/// without walking the whole catalog.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct CatalogChange {
    /// The catalog version after the change.
    pub version: u64,
    /// Entities gone from the catalog.
    pub despawned: Vec<EntityId>,
    /// Entities new to it.
    pub spawned: Vec<EntityId>,
    /// Entities in it before and after whose description changed (a soft
    /// body that tore): told again to clients that know them.
    pub reshaped: Vec<EntityId>,
}

impl CatalogChange {
    /// Which ids changed from `old` to `new`, as version `version`.
    pub fn between(
        version: u64,
        old: &BTreeMap<EntityId, EntityDesc>,
        new: &BTreeMap<EntityId, EntityDesc>,
    ) -> Self {
        let mut change = Self::of_ids(version, old.keys().copied(), new.keys().copied());
        change.reshaped = new
            .iter()
            .filter(|&(id, desc)| old.get(id).is_some_and(|o| o != desc))
            .map(|(&id, _)| id)
            .collect();
        change
    }

    /// Which ids left and which came between two ascending runs of ids,
    /// as version `version`: one walk of both, side by side.
    pub fn of_ids(
        version: u64,
        old: impl IntoIterator<Item = EntityId>,
        new: impl IntoIterator<Item = EntityId>,
    ) -> Self {
        let mut change = Self {
            version,
            ..Self::default()
        };
        let (mut old, mut new) = (old.into_iter().peekable(), new.into_iter().peekable());
        loop {
            match (old.peek().copied(), new.peek().copied()) {
                (Some(a), Some(b)) if a == b => {
                    old.next();
                    new.next();
                }
                (Some(a), b) if b.is_none_or(|b| a < b) => {
                    change.despawned.push(a);
                    old.next();
                }
                (_, Some(b)) => {
                    change.spawned.push(b);
                    new.next();
                }
                (_, None) => return change,
            }
        }
    }
}

/// One of the rules' messages as frames carry it: its number, the tick it
/// was sent in, the message, and its wire form (a control frame or a
/// message datagram), coded by the first connection that sends it and
/// shared by every other (as [`Frame::quantized`] is), off the tick
/// thread.
#[derive(Debug)]
pub struct RecentMessage {
    /// Messages are numbered from 1 in the order they are published, so a
    /// reader finds what is new to it by number, whatever the ticks did
    /// (they go back on a rewind).
    pub number: u64,
    /// The tick it was sent in.
    pub tick: u64,
    /// The message.
    pub message: OutgoingMessage,
    wire: OnceLock<Option<Vec<u8>>>,
}

impl RecentMessage {
    /// Message `number`, sent in `tick`.
    pub fn new(number: u64, tick: u64, message: OutgoingMessage) -> Self {
        Self {
            number,
            tick,
            message,
            wire: OnceLock::new(),
        }
    }

    /// The message as it travels, coded once for every client: a
    /// `ServerControl::Message` frame (length prefix included) when
    /// reliable, a message datagram when not; `None` for one that cannot
    /// be coded (the rules' send refuses those, so never), sent to nobody
    /// rather than ending every client's session.
    pub fn wire(&self) -> Option<&[u8]> {
        self.wire
            .get_or_init(|| {
                let bytes = &self.message.bytes;
                let coded = match self.message.delivery {
                    Delivery::Reliable => encode_frame(&ServerControl::Message(bytes.clone()))
                        .map_err(|e| e.to_string()),
                    Delivery::Unreliable => {
                        MessageDatagram::encode(bytes).map_err(|e| e.to_string())
                    }
                };
                coded
                    .map_err(|e| {
                        tracing::warn!(tick = self.tick, error = %e, "a message that cannot be coded is not sent")
                    })
                    .ok()
            })
            .as_deref()
    }
}

/// What the world looked like after a loop's ticks: the latest state of
/// every entity that can move, plus the catalog of all entities.
#[derive(Debug, Clone)]
pub struct Frame {
    /// Ticks completed (the world's tick).
    pub tick: u64,
    /// Simulation time, s (`tick × dt`).
    pub sim_time: f64,
    /// Simulation seconds per wall second now (0 while paused; negative
    /// while history plays backwards).
    pub time_scale: f64,
    /// Whether real-time ticking is paused.
    pub paused: bool,
    /// States of dynamic and kinematic bodies, free particles and anything
    /// teleported, sorted by id.
    pub entities: Vec<EntityState>,
    /// Every live entity's description; the same `Arc` until it changes.
    pub catalog: Arc<BTreeMap<EntityId, EntityDesc>>,
    /// Changes whenever the catalog does (compare, don't diff).
    pub catalog_version: u64,
    /// The most recent catalog changes (at most
    /// [`RECENT_CATALOG_CHANGES`]), oldest first, the last one making
    /// `catalog_version` (none before the first change).
    pub catalog_changes: Arc<Vec<Arc<CatalogChange>>>,
    /// The rules' most recent messages (at most [`RECENT_MESSAGES`]),
    /// oldest first, each with the tick it was sent in; the same `Arc`
    /// until one is sent.
    pub messages: Arc<Vec<Arc<RecentMessage>>>,
    /// The game's properties at this tick (none: it declares none); the
    /// same `Arc` until one changes.
    pub properties: Option<Arc<FrameProperties>>,
    /// Wall time of the last tick.
    pub tick_duration: Duration,
    /// Loops that hit the catch-up cap so far.
    pub overruns: u64,
    /// Clients in the game (live).
    pub clients: u32,
    /// The live world's tick (equal to `tick` unless history is shown).
    pub live_tick: u64,
    /// What the clock is showing: live, or which way through history.
    pub mode: TimeMode,
    /// How each live client's inputs have been arriving against their
    /// ticks, by client, as of the last second's end.
    pub inputs: Arc<BTreeMap<u64, InputReport>>,
    /// `entities` quantized for snapshots, made by the first connection
    /// that codes this frame and shared by every other (see
    /// [`Frame::quantized`]).
    quantized: OnceLock<QuantizedFrame>,
}

impl Frame {
    /// This frame's entities and clock quantized under `config`, once for
    /// every client: the first caller quantizes, the rest share it. Every
    /// caller must pass the same config (the server has one).
    pub fn quantized(&self, config: &SnapshotConfig) -> &QuantizedFrame {
        self.quantized.get_or_init(|| {
            let frame = QuantizedFrame::new(
                self.tick,
                self.time_scale as f32,
                self.paused,
                &self.entities,
                config,
            );
            match &self.properties {
                Some(p) => frame.with_properties(p.clone()),
                None => frame,
            }
        })
    }

    /// The avatar `client` owns in this frame's catalog, if any.
    pub fn avatar_of(&self, client: u64) -> Option<EntityId> {
        self.catalog
            .iter()
            .find(|(_, d)| d.kind == EntityKind::Avatar && d.owner == Some(client))
            .map(|(&id, _)| id)
    }
}

impl Simulation {
    /// The frame of the current state, with the most recent
    /// [`RECENT_MESSAGES`] messages (so a reader that skipped frames still
    /// sees every message, as long as it keeps up within that many).
    pub fn frame(&mut self) -> Frame {
        self.frame_in(Vec::new())
    }

    /// [`Self::frame`], its states written into `states` (emptied; passed
    /// in for its memory).
    pub(crate) fn frame_in(&mut self, mut states: Vec<EntityState>) -> Frame {
        let shown = self.timelines.shown();
        self.publication.update(&shown.entities, &shown.properties);
        let publication = &self.publication;
        Frame {
            tick: self.shown().world.tick(),
            sim_time: self.shown().world.time(),
            time_scale: match self.mode() {
                // Clients play backwards where the scale is negative.
                TimeMode::Reverse => -self.shown().clock.time_scale(),
                _ => self.shown().clock.time_scale(),
            },
            paused: self.shown().clock.paused(),
            entities: {
                self.shown()
                    .entities
                    .states_into(&self.shown().world, &mut states);
                states
            },
            catalog: publication.catalog.clone(),
            catalog_version: publication.catalog_version,
            catalog_changes: publication.catalog_changes.clone(),
            messages: publication.recent_messages.clone(),
            properties: publication.properties.clone(),
            tick_duration: self.meter.last_tick(),
            overruns: self.shown().clock.overruns(),
            clients: self.live_clients() as u32,
            live_tick: self.live_tick(),
            mode: self.mode(),
            inputs: self.inputs.reports(),
            quantized: OnceLock::new(),
        }
    }
}
