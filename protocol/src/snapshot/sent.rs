//! What an encoder remembers of what it sent, in memory that does not grow
//! with the world times the ring: for each of the last [`RING`] snapshots
//! only what it changed in the view it was coded against (its removals and
//! updates, at most a datagram's worth), and whole views only for the
//! newest one the client acknowledged (the next baseline) and the few
//! older acknowledged ones that snapshots still in flight were coded
//! against. A snapshot's view is built when the client acknowledges it,
//! in place when no snapshot in flight still needs the old one.
//!
//! At 1000 entities a whole view is about 44 KB; holding one per sent
//! snapshot cost about 2.8 MB a client, and building one per snapshot
//! copied 44 KB a client every slot.

use crate::entity::EntityId;
use crate::property::PropertyRow;

use super::view::{QuantizedEntity, View};
use super::{sequence_newer, RING};

/// Older acknowledged views held at most besides the newest: enough for a
/// round trip of this many snapshot periods (0.53 s at 30 snapshots a
/// second), over which every snapshot in flight may have been coded
/// against a different one. When more are needed, the oldest goes and an
/// acknowledgement of a snapshot coded against it is passed over (the
/// baseline stays a little older; nothing is sent wrong).
pub const HELD_VIEWS: usize = 16;

/// One sent snapshot, as the change it made to its baseline's view.
#[derive(Debug, Clone, Default)]
pub(crate) struct Sent {
    pub(crate) sequence: u16,
    /// The acknowledged view it was coded against (`None`: against nothing).
    pub(crate) baseline: Option<u16>,
    /// The tick its view describes.
    pub(crate) tick: u64,
    /// Ids it removed from the baseline's view, ascending.
    pub(crate) removed: Vec<EntityId>,
    /// The states it sent, ascending by id.
    pub(crate) updated: Vec<(EntityId, QuantizedEntity)>,
    /// The property rows it sent (whole, as they are now), ascending by id.
    pub(crate) properties: Vec<(EntityId, PropertyRow)>,
    /// The match's row, when it sent a change of it.
    pub(crate) match_state: Option<PropertyRow>,
}

impl Sent {
    /// Puts what this snapshot sent of the properties into `view`, built
    /// from its baseline's entities and properties.
    fn apply_properties(&self, view: &mut View) {
        if self.properties.is_empty()
            && self.match_state.is_none()
            && (self.removed.is_empty() || view.properties.is_empty())
        {
            return;
        }
        view.properties =
            view.properties
                .apply(&self.removed, &self.properties, self.match_state.as_ref());
    }
}

/// The encoder's memory of what it sent and what the client holds.
#[derive(Debug, Clone)]
pub(crate) struct SentLog {
    /// The last [`RING`] snapshots, by sequence number modulo [`RING`].
    slots: Vec<Option<Sent>>,
    /// The newest acknowledged view: the baseline of the next snapshot.
    acked: Option<(u16, View)>,
    /// Older acknowledged views that a snapshot in flight was coded
    /// against, oldest first, at most [`HELD_VIEWS`].
    held: Vec<(u16, View)>,
    /// A buffer for merges, kept for its memory.
    scratch: Vec<(EntityId, QuantizedEntity)>,
}

impl SentLog {
    pub(crate) fn new() -> Self {
        Self {
            slots: vec![None; RING],
            acked: None,
            held: Vec::new(),
            scratch: Vec::new(),
        }
    }

    /// Snapshot `sequence`, while remembered.
    pub(crate) fn get(&self, sequence: u16) -> Option<&Sent> {
        self.slots[usize::from(sequence) % RING]
            .as_ref()
            .filter(|s| s.sequence == sequence)
    }

    /// The newest acknowledged view, if it can be the baseline of snapshot
    /// `next` (the decoder holds [`RING`] views back from a snapshot).
    pub(crate) fn baseline(&self, next: u16) -> Option<(u16, &View)> {
        self.acked
            .as_ref()
            .filter(|(a, _)| *a != next && usize::from(next.wrapping_sub(*a)) <= RING)
            .map(|(a, v)| (*a, v))
    }

    /// The newest acknowledged sequence number, whatever its age.
    pub(crate) fn acked(&self) -> Option<u16> {
        self.acked.as_ref().map(|(a, _)| *a)
    }

    /// Remembers `sent` in its slot and hands back the snapshot it
    /// replaces there (for its buffers).
    pub(crate) fn record(&mut self, sent: Sent) -> Option<Sent> {
        let slot = usize::from(sent.sequence) % RING;
        self.slots[slot].replace(sent)
    }

    /// The client acknowledged `sequence` with `next` the next to send:
    /// its view becomes the baseline when it is newer than the one
    /// acknowledged so far and the view it was coded against is still
    /// held. Anything else is ignored.
    pub(crate) fn on_ack(&mut self, sequence: u16, next: u16) {
        let in_window =
            sequence_newer(next, sequence) && usize::from(next.wrapping_sub(sequence)) <= RING;
        if !in_window || self.acked().is_some_and(|a| !sequence_newer(sequence, a)) {
            return;
        }
        let slot = usize::from(sequence) % RING;
        let Some(base) = self.get(sequence).map(|s| s.baseline) else {
            return;
        };
        // Whether a snapshot sent after this one was coded against `b`.
        let needed_later = |log: &Self, b: u16| {
            log.slots.iter().flatten().any(|t| {
                t.baseline == Some(b)
                    && sequence_newer(t.sequence, sequence)
                    && sequence_newer(next, t.sequence)
            })
        };
        // The view it was coded against goes into the new one in place
        // when nothing sent later needs it (acknowledgements that come a
        // slot or more late leave it among the held views, and two or
        // three chains of baselines then run side by side); else the new
        // view is a copy.
        let old = self.acked.take();
        let had_old = old.is_some();
        self.held.extend(old);
        let mut scratch = std::mem::take(&mut self.scratch);
        let sent = self.slots[slot].as_ref().expect("found above");
        let mut view = match base {
            None => View::default().apply_into(sent.tick, &sent.removed, &sent.updated, scratch),
            Some(b) => {
                let Some(at) = self.held.iter().position(|(h, _)| *h == b) else {
                    // Its baseline was let go: keep the one acknowledged.
                    if had_old {
                        self.acked = self.held.pop();
                    }
                    self.scratch = scratch;
                    return;
                };
                if needed_later(self, b) {
                    self.held[at]
                        .1
                        .apply_into(sent.tick, &sent.removed, &sent.updated, scratch)
                } else {
                    let (_, mut view) = self.held.remove(at);
                    view.apply_in_place(sent.tick, &sent.removed, &sent.updated, &mut scratch);
                    self.scratch = scratch;
                    view
                }
            }
        };
        let sent = self.slots[slot].as_ref().expect("found above");
        sent.apply_properties(&mut view);
        self.acked = Some((sequence, view));
        // Keep only the older views a snapshot in flight still needs.
        let held = std::mem::take(&mut self.held);
        for (h, view) in held {
            if needed_later(self, h) {
                self.held.push((h, view));
            } else if view.entities.capacity() > self.scratch.capacity() {
                self.scratch = view.entities;
            }
        }
        if self.held.len() > HELD_VIEWS {
            self.held.drain(..self.held.len() - HELD_VIEWS);
        }
    }

    /// The view snapshot `sequence` described, built from its baseline's
    /// while that is held.
    pub(crate) fn view(&self, sequence: u16) -> Option<View> {
        let sent = self.get(sequence)?;
        let empty = View::default();
        let from = match sent.baseline {
            None => &empty,
            Some(b) => match &self.acked {
                Some((a, v)) if *a == b => v,
                _ => self.held.iter().find(|(h, _)| *h == b).map(|(_, v)| v)?,
            },
        };
        let mut view = from.apply_into(sent.tick, &sent.removed, &sent.updated, Vec::new());
        sent.apply_properties(&mut view);
        Some(view)
    }

    /// Whole views held, and snapshots remembered (for memory figures).
    pub(crate) fn held_views(&self) -> usize {
        usize::from(self.acked.is_some()) + self.held.len()
    }
}
