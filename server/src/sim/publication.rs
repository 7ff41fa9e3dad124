//! The publication of frames: the rules' messages of the ticks since the
//! last frame numbered and kept among the recent ones, and the entity catalog
//! remade (with the change it made) when the entity table changed or the
//! timeline shown was swapped. Everything else a [`Frame`](super::Frame) carries is
//! read off the timeline shown when it is made.

use std::collections::BTreeMap;
use std::sync::Arc;

use inertia_protocol::property::FrameProperties;
use inertia_protocol::{EntityDesc, EntityId};

use super::frame::{CatalogChange, RecentMessage, RECENT_CATALOG_CHANGES, RECENT_MESSAGES};
use crate::properties::PropertyStore;
use crate::rules::OutgoingMessage;
use crate::scene::EntityTable;

/// What frames are published from besides the timeline shown.
#[derive(Debug)]
pub(super) struct Publication {
    /// Every live entity's description, as last published.
    pub(super) catalog: Arc<BTreeMap<EntityId, EntityDesc>>,
    /// Bumped whenever the catalog changes.
    pub(super) catalog_version: u64,
    /// The most recent catalog changes, for
    /// [`Frame::catalog_changes`](super::Frame::catalog_changes).
    pub(super) catalog_changes: Arc<Vec<Arc<CatalogChange>>>,
    /// The most recent messages, for [`Frame::messages`](super::Frame::messages).
    pub(super) recent_messages: Arc<Vec<Arc<RecentMessage>>>,
    /// Messages of the ticks since the last frame, with their ticks.
    pending_messages: Vec<(u64, OutgoingMessage)>,
    /// Messages published so far (the number of the newest).
    messages_published: u64,
    /// The entity table version the catalog was last made from.
    catalog_seen: u64,
    /// The timeline shown was swapped: remake the catalog.
    catalog_stale: bool,
    /// The game's properties as last published (none: it declares none).
    pub(super) properties: Option<Arc<FrameProperties>>,
    /// The property store version they were made from.
    properties_seen: Option<u64>,
}

impl Publication {
    /// Publication of a simulation whose entities are `entities`.
    pub(super) fn new(entities: &EntityTable) -> Self {
        Self {
            catalog: Arc::new(entities.catalog()),
            catalog_version: entities.version(),
            catalog_changes: Arc::new(Vec::new()),
            recent_messages: Arc::new(Vec::new()),
            pending_messages: Vec::new(),
            messages_published: 0,
            catalog_seen: entities.version(),
            catalog_stale: false,
            properties: None,
            properties_seen: None,
        }
    }

    /// Messages the rules sent in `tick`, for the next frame.
    pub(super) fn push_messages(
        &mut self,
        tick: u64,
        messages: impl IntoIterator<Item = OutgoingMessage>,
    ) {
        self.pending_messages
            .extend(messages.into_iter().map(|m| (tick, m)));
    }

    /// The number the next message handed over will get.
    pub(super) fn next_number(&self) -> u64 {
        self.messages_published + self.pending_messages.len() as u64 + 1
    }

    /// How many messages wait for the next frame.
    pub(super) fn pending(&self) -> usize {
        self.pending_messages.len()
    }

    /// Forgets the messages that came after the first `kept` waiting (the
    /// ticks a seek passed over are not news to anyone).
    pub(super) fn forget_pending_after(&mut self, kept: usize) {
        self.pending_messages.truncate(kept);
    }

    /// The timeline shown was swapped (its entity table's version says
    /// nothing of the last one's): the next frame remakes the catalog.
    pub(super) fn timeline_swapped(&mut self) {
        self.catalog_stale = true;
        self.properties_seen = None;
    }

    /// Brings the recent messages, the catalog and the properties up to
    /// date for a frame of `entities` and `properties`.
    pub(super) fn update(&mut self, entities: &EntityTable, properties: &PropertyStore) {
        if !properties.is_empty() && self.properties_seen != Some(properties.version()) {
            self.properties = Some(Arc::new(properties.frame()));
            self.properties_seen = Some(properties.version());
        }
        if !self.pending_messages.is_empty() {
            let mut recent = self.recent_messages.as_ref().clone();
            for (tick, message) in self.pending_messages.drain(..) {
                self.messages_published += 1;
                let number = self.messages_published;
                recent.push(Arc::new(RecentMessage::new(number, tick, message)));
            }
            let excess = recent.len().saturating_sub(RECENT_MESSAGES);
            recent.drain(..excess);
            self.recent_messages = Arc::new(recent);
        }
        if self.catalog_stale || entities.version() != self.catalog_seen {
            let catalog = Arc::new(entities.catalog());
            self.catalog_version += 1;
            let change = CatalogChange::between(self.catalog_version, &self.catalog, &catalog);
            let mut changes = self.catalog_changes.as_ref().clone();
            changes.push(Arc::new(change));
            let excess = changes.len().saturating_sub(RECENT_CATALOG_CHANGES);
            changes.drain(..excess);
            self.catalog_changes = Arc::new(changes);
            self.catalog = catalog;
            self.catalog_seen = entities.version();
            self.catalog_stale = false;
        }
    }
}
