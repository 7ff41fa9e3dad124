//! The game's properties as this client knows them: each entity's and the
//! match's values, as of the ticks the snapshots that carried them
//! describe, so the game reads them as of the tick it draws.
//!
//! A snapshot carries only what changed since a view this client
//! acknowledged ([`inertia_protocol::property`]); [`KnownProperties`]
//! keeps the last few values of each with their ticks, answers for any
//! tick (the newest value at or before it), and drops an entity's when it
//! leaves the view.

use std::collections::{BTreeMap, VecDeque};
use std::sync::Arc;

use inertia_protocol::property::{PropertyDecl, PropertyRow, PropertySchema, PropertyValue};
use inertia_protocol::snapshot::View;
use inertia_protocol::EntityId;

/// Values kept per entity (and for the match): enough to answer for a
/// render tick some snapshots behind the newest.
const KEPT: usize = 8;

/// One thing's values over the last ticks, oldest first.
#[derive(Debug, Clone, Default)]
struct History {
    rows: VecDeque<(u64, PropertyRow)>,
}

impl History {
    /// Takes the row of `tick`; an older tick than the newest held is
    /// news of the past and is not taken (a newer snapshot already said).
    fn push(&mut self, tick: u64, row: PropertyRow) -> bool {
        if self.rows.back().is_some_and(|(t, _)| *t > tick) {
            return false;
        }
        if self.rows.back().is_some_and(|(t, _)| *t == tick) {
            self.rows.pop_back();
        }
        self.rows.push_back((tick, row));
        if self.rows.len() > KEPT {
            self.rows.pop_front();
        }
        true
    }

    /// The row as of `tick`: the newest at or before it, else the oldest
    /// known (nothing earlier is known).
    fn at(&self, tick: u64) -> Option<&PropertyRow> {
        self.rows
            .iter()
            .rev()
            .find(|(t, _)| *t <= tick)
            .or_else(|| self.rows.front())
            .map(|(_, r)| r)
    }

    fn newest(&self) -> Option<&PropertyRow> {
        self.rows.back().map(|(_, r)| r)
    }
}

/// What changed, for the game's notifications.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PropertyChange {
    /// An entity's properties.
    Entity(EntityId),
    /// The match's.
    Match,
}

/// Every property this client holds.
#[derive(Debug, Clone, Default)]
pub struct KnownProperties {
    schema: Arc<PropertySchema>,
    entities: BTreeMap<EntityId, History>,
    match_state: History,
    /// The tick of the newest view taken.
    newest_tick: Option<u64>,
}

fn values(decls: &[PropertyDecl], row: Option<&PropertyRow>) -> Vec<PropertyValue> {
    decls
        .iter()
        .enumerate()
        .map(|(i, d)| {
            let raw = row.and_then(|r| r.get(i)).copied().unwrap_or(0);
            PropertyValue::from_raw(d.kind, raw)
        })
        .collect()
}

impl KnownProperties {
    /// Nothing known yet, under the server's `schema`.
    pub fn new(schema: Arc<PropertySchema>) -> Self {
        Self {
            schema,
            ..Self::default()
        }
    }

    /// The server's schema.
    pub fn schema(&self) -> &Arc<PropertySchema> {
        &self.schema
    }

    /// Takes the view of the newest snapshot (its tick, and the whole
    /// view the decoder holds for it) and returns what changed, for
    /// notifications: each row that differs from the newest held, every
    /// entity that left the view forgotten. A view older than the newest
    /// held (the server's timeline went back) starts the history anew.
    pub fn on_view(&mut self, tick: u64, view: &View) -> Vec<PropertyChange> {
        let props = view.properties();
        if self.newest_tick.is_some_and(|t| t > tick) {
            self.clear();
        }
        self.newest_tick = Some(tick);
        let mut changed = Vec::new();
        // Entities that left the view go; those whose row went back to
        // the defaults take a row of zeros.
        let zeros: PropertyRow = vec![0; self.schema.entity.len()].into();
        let gone: Vec<EntityId> = self
            .entities
            .keys()
            .copied()
            .filter(|id| props.entity(*id).is_none())
            .collect();
        for id in gone {
            if view.get(id).is_some() {
                let h = self.entities.get_mut(&id).expect("listed");
                if h.newest().is_some_and(|r| r.iter().any(|&v| v != 0))
                    && h.push(tick, zeros.clone())
                {
                    changed.push(PropertyChange::Entity(id));
                }
            } else {
                self.entities.remove(&id);
            }
        }
        for (id, row) in props.entities() {
            let h = self.entities.entry(*id).or_default();
            let same = h.newest().is_some_and(|r| Arc::ptr_eq(r, row) || r == row);
            if !same && h.push(tick, row.clone()) {
                changed.push(PropertyChange::Entity(*id));
            }
        }
        if let Some(row) = props.match_state() {
            let same = self
                .match_state
                .newest()
                .is_some_and(|r| Arc::ptr_eq(r, row) || r == row);
            if !same && self.match_state.push(tick, row.clone()) {
                changed.push(PropertyChange::Match);
            }
        }
        changed
    }

    /// Forgets everything (what the server says next replaces it all).
    pub fn clear(&mut self) {
        self.entities.clear();
        self.match_state = History::default();
    }

    /// An entity's values as of `tick` (schema order; defaults where
    /// nothing was said), or `None` for an entity not in view.
    pub fn entity_at(&self, id: EntityId, tick: u64) -> Option<Vec<PropertyValue>> {
        let h = self.entities.get(&id)?;
        Some(values(&self.schema.entity, h.at(tick)))
    }

    /// The defaults of an entity's properties (schema order): what an
    /// entity in view whose properties the rules never set holds.
    pub fn entity_defaults(&self) -> Vec<PropertyValue> {
        values(&self.schema.entity, None)
    }

    /// An entity's newest values.
    pub fn entity(&self, id: EntityId) -> Option<Vec<PropertyValue>> {
        let h = self.entities.get(&id)?;
        Some(values(&self.schema.entity, h.newest()))
    }

    /// The match's values as of `tick` (schema order).
    pub fn match_at(&self, tick: u64) -> Vec<PropertyValue> {
        values(&self.schema.match_state, self.match_state.at(tick))
    }

    /// The match's newest values.
    pub fn match_state(&self) -> Vec<PropertyValue> {
        values(&self.schema.match_state, self.match_state.newest())
    }

    /// Entities with properties known, ascending.
    pub fn entities(&self) -> impl Iterator<Item = EntityId> + '_ {
        self.entities.keys().copied()
    }
}

#[cfg(test)]
mod tests {
    use inertia_protocol::property::{FrameProperties, PropertyKind};
    use inertia_protocol::snapshot::QuantizedFrame;
    use inertia_protocol::{
        EntityState, Interest, PriorityAccumulator, SnapshotConfig, SnapshotDecoder,
        SnapshotEncoder,
    };

    use super::*;

    #[test]
    fn values_answer_for_a_tick_and_leave_with_their_entity() {
        let schema = Arc::new(PropertySchema {
            entity: vec![PropertyDecl::new("health", PropertyKind::UInt { bits: 7 })],
            match_state: vec![PropertyDecl::new("clock", PropertyKind::F32)],
        });
        let config = SnapshotConfig::default();
        let mut enc = SnapshotEncoder::new(config)
            .unwrap()
            .with_properties(schema.clone());
        let mut dec = SnapshotDecoder::new(config)
            .unwrap()
            .with_properties(schema.clone());
        let mut pri = PriorityAccumulator::new(Interest::everything());
        let mut known = KnownProperties::new(schema);
        let mut send =
            |known: &mut KnownProperties, tick: u64, ids: &[EntityId], rows: &[(EntityId, u64)]| {
                let states: Vec<EntityState> = ids
                    .iter()
                    .map(|&id| EntityState {
                        id,
                        position: glam::DVec3::ZERO,
                        rotation: glam::DQuat::IDENTITY,
                        linear_velocity: glam::DVec3::ZERO,
                        angular_velocity: glam::DVec3::ZERO,
                        asleep: true,
                    })
                    .collect();
                let props = FrameProperties {
                    entities: rows
                        .iter()
                        .map(|&(id, v)| (id, PropertyRow::from(vec![v])))
                        .collect(),
                    match_state: None,
                };
                let frame = QuantizedFrame::new(tick, 1.0, false, &states, &config)
                    .with_properties(Arc::new(props));
                let got = dec
                    .decode(&enc.encode_frame(&frame, &mut pri, 1200))
                    .unwrap();
                enc.on_ack(got.sequence);
                known.on_view(tick, dec.view(got.sequence).unwrap())
            };
        assert_eq!(
            send(&mut known, 10, &[4, 5], &[(4, 100)]),
            [PropertyChange::Entity(4)]
        );
        assert!(
            send(&mut known, 15, &[4, 5], &[(4, 100)]).is_empty(),
            "nothing changed"
        );
        assert_eq!(
            send(&mut known, 20, &[4, 5], &[(4, 80)]),
            [PropertyChange::Entity(4)]
        );
        assert_eq!(known.entity_at(4, 12), Some(vec![PropertyValue::UInt(100)]));
        assert_eq!(known.entity_at(4, 25), Some(vec![PropertyValue::UInt(80)]));
        assert_eq!(known.entity_at(4, 5), Some(vec![PropertyValue::UInt(100)]));
        assert_eq!(known.match_state(), vec![PropertyValue::F32(0.0)]);
        // Back to the default: a row of zeros; then the entity leaves.
        assert_eq!(
            send(&mut known, 25, &[4, 5], &[]),
            [PropertyChange::Entity(4)]
        );
        assert_eq!(known.entity(4), Some(vec![PropertyValue::UInt(0)]));
        send(&mut known, 30, &[5], &[]);
        assert_eq!(known.entity(4), None);
        // The timeline went back: the history starts again.
        assert_eq!(
            send(&mut known, 12, &[4, 5], &[(4, 60)]),
            [PropertyChange::Entity(4)]
        );
        assert_eq!(known.entity_at(4, 30), Some(vec![PropertyValue::UInt(60)]));
    }
}
