//! The entities a client knows of: what each looks like (from the reliable
//! spawn messages) and where it last was (from snapshots).
//!
//! Spawns travel on a reliable stream and snapshots as unreliable
//! datagrams, so a snapshot may name an entity before its spawn has
//! arrived: such states are held (a bounded number) and attached when the
//! spawn comes. A despawn forgets the entity and any held state.
//!
//! A soft body or a fluid is one entity whose description is a
//! [`ShapeDesc::PointSet`]: its points travel as the entities just after
//! its id, with no spawn of their own. Their states are kept with the set
//! ([`KnownEntity::points`]); [`crate::point_sets`] draws them.

use std::collections::BTreeMap;

use glam::{DQuat, DVec3};
use inertia_protocol::snapshot::ViewEntity;
use inertia_protocol::{EntityDesc, EntityId, ShapeDesc};

/// The newest state a snapshot gave for an entity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LatestState {
    /// The tick of the snapshot it came from.
    pub tick: u64,
    /// The state as the snapshot carried it (position m, rotation,
    /// linear velocity m/s when sent).
    pub state: ViewEntity,
}

/// One known entity.
#[derive(Debug, Clone, PartialEq)]
pub struct KnownEntity {
    /// What it is and looks like, as spawned.
    pub desc: EntityDesc,
    /// Its newest state from a snapshot, if one came since the spawn.
    pub latest: Option<LatestState>,
    /// For a point set, the newest state of each point (by index), if one
    /// came; empty for any other entity.
    pub points: Vec<Option<LatestState>>,
}

impl KnownEntity {
    fn new(desc: EntityDesc, latest: Option<LatestState>) -> Self {
        let points = match desc.shape {
            ShapeDesc::PointSet { points, .. } => vec![None; points as usize],
            _ => Vec::new(),
        };
        Self {
            desc,
            latest,
            points,
        }
    }
}

impl KnownEntity {
    /// Its newest known position, m: from the latest snapshot, else as
    /// spawned.
    pub fn position(&self) -> DVec3 {
        match &self.latest {
            Some(l) => l.state.position,
            None => DVec3::from_array(self.desc.position),
        }
    }

    /// Its newest known orientation: from the latest snapshot, else as
    /// spawned (normalised; identity if the spawn's was degenerate).
    pub fn rotation(&self) -> DQuat {
        match &self.latest {
            Some(l) => l.state.rotation,
            None => {
                let q = DQuat::from_array(self.desc.rotation);
                if q.is_finite() && q.length_squared() > 1e-12 {
                    q.normalize()
                } else {
                    DQuat::IDENTITY
                }
            }
        }
    }
}

/// What [`KnownEntities::update`] did with a state.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Update {
    /// Stored as the entity's newest state.
    Applied,
    /// The entity has not been spawned (yet): held for its spawn.
    Held,
    /// Not spawned, and too many states are held already: dropped.
    Dropped,
}

/// Entities by id, in id order. See the [module docs](self).
#[derive(Debug, Clone, Default)]
pub struct KnownEntities {
    entities: BTreeMap<EntityId, KnownEntity>,
    early: BTreeMap<EntityId, LatestState>,
}

impl KnownEntities {
    /// The most states held for entities not spawned yet.
    pub const MAX_EARLY: usize = 4096;

    /// An empty table.
    pub fn new() -> Self {
        Self::default()
    }

    /// Applies a spawn: adds the entity, or replaces its description if it
    /// is known (its latest state kept, and its points' as far as the new
    /// set has them). Returns true when it was new.
    pub fn spawn(&mut self, desc: EntityDesc) -> bool {
        let id = desc.id;
        let taken = desc.ids_taken();
        let new = match self.entities.get_mut(&id) {
            Some(e) => {
                let mut points = std::mem::take(&mut e.points);
                *e = KnownEntity::new(desc, e.latest);
                points.truncate(e.points.len());
                e.points[..points.len()].copy_from_slice(&points);
                false
            }
            None => {
                let latest = self.early.remove(&id);
                self.entities.insert(id, KnownEntity::new(desc, latest));
                true
            }
        };
        if taken > 1 {
            // States of its points that came before it.
            let last = EntityId::try_from(u64::from(id) + taken - 1).unwrap_or(EntityId::MAX);
            let early: Vec<EntityId> = self.early.range(id + 1..=last).map(|(&k, _)| k).collect();
            for point in early {
                if let Some(state) = self.early.remove(&point) {
                    self.update(state.tick, state.state);
                }
            }
        }
        new
    }

    /// Applies a despawn: forgets the entity (and any state held for it or
    /// its points). Returns its description if it was known.
    pub fn despawn(&mut self, id: EntityId) -> Option<EntityDesc> {
        self.early.remove(&id);
        self.entities.remove(&id).map(|e| e.desc)
    }

    /// The point set entity `id` is a point of, and its index there.
    pub fn point_of(&self, id: EntityId) -> Option<(EntityId, u32)> {
        let (&set, e) = self.entities.range(..id).next_back()?;
        Some((set, e.desc.point_index(id)?))
    }

    /// Records a state from the snapshot of `tick` as the entity's
    /// newest. Feed it the newest snapshot by sequence number only: its
    /// tick may be lower than the one held when the server's timeline
    /// went back (a seek, or reverse play).
    pub fn update(&mut self, tick: u64, state: ViewEntity) -> Update {
        let latest = LatestState { tick, state };
        match self.entities.get_mut(&state.id) {
            Some(e) => {
                e.latest = Some(latest);
                Update::Applied
            }
            None => {
                if let Some((set, index)) = self.point_of(state.id) {
                    if let Some(slot) = self
                        .entities
                        .get_mut(&set)
                        .and_then(|e| e.points.get_mut(index as usize))
                    {
                        *slot = Some(latest);
                        return Update::Applied;
                    }
                }
                if let Some(held) = self.early.get_mut(&state.id) {
                    *held = latest;
                    return Update::Held;
                }
                if self.early.len() >= Self::MAX_EARLY {
                    return Update::Dropped;
                }
                self.early.insert(state.id, latest);
                Update::Held
            }
        }
    }

    /// [`Self::update`] for every state of one snapshot, ascending by id
    /// as the decoder yields them: one walk of the table beside the
    /// states instead of a search for each.
    pub fn update_all(&mut self, tick: u64, states: &[ViewEntity]) {
        let applied = crate::by_id::visit_beside(&mut self.entities, states, |e, state| {
            e.latest = Some(LatestState { tick, state });
        });
        if applied < states.len() {
            // Some are not spawned yet (or the states were out of order):
            // one by one.
            for &state in states {
                self.update(tick, state);
            }
        }
    }

    /// Forgets every entity and held state (after a reconnect, or when the
    /// server's timeline broke and it will spawn everything again).
    pub fn clear(&mut self) {
        self.entities.clear();
        self.early.clear();
    }

    /// One entity.
    pub fn get(&self, id: EntityId) -> Option<&KnownEntity> {
        self.entities.get(&id)
    }

    /// True when the entity is known.
    pub fn contains(&self, id: EntityId) -> bool {
        self.entities.contains_key(&id)
    }

    /// How many entities are known.
    pub fn len(&self) -> usize {
        self.entities.len()
    }

    /// True when no entity is known.
    pub fn is_empty(&self) -> bool {
        self.entities.is_empty()
    }

    /// How many states are held for entities not spawned yet.
    pub fn held(&self) -> usize {
        self.early.len()
    }

    /// The entities in id order.
    pub fn iter(&self) -> impl Iterator<Item = (EntityId, &KnownEntity)> + '_ {
        self.entities.iter().map(|(&id, e)| (id, e))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use inertia_protocol::{EntityKind, ShapeDesc};

    fn desc(id: EntityId, name: &str) -> EntityDesc {
        EntityDesc {
            id,
            kind: EntityKind::Dynamic,
            shape: ShapeDesc::Sphere { radius: 0.5 },
            color: [255, 0, 0, 255],
            owner: None,
            name: name.into(),
            position: [1.0, 2.0, 3.0],
            rotation: [0.0, 0.0, 0.0, 1.0],
        }
    }

    fn state(id: EntityId, x: f64) -> ViewEntity {
        ViewEntity {
            id,
            position: DVec3::new(x, 0.0, 0.0),
            rotation: DQuat::IDENTITY,
            linear_velocity: None,
            angular_velocity: None,
            at_rest: false,
        }
    }

    #[test]
    fn spawn_update_despawn_and_iterate_in_id_order() {
        let mut table = KnownEntities::new();
        assert!(table.spawn(desc(5, "b")));
        assert!(table.spawn(desc(2, "a")));
        assert!(!table.spawn(desc(5, "b2")));
        assert_eq!(table.get(5).unwrap().desc.name, "b2");
        assert_eq!(table.get(2).unwrap().position(), DVec3::new(1.0, 2.0, 3.0));
        assert_eq!(table.update(10, state(2, 4.0)), Update::Applied);
        // A seek back: the newest snapshot has a lower tick.
        assert_eq!(table.update(9, state(2, 3.0)), Update::Applied);
        assert_eq!(table.get(2).unwrap().position().x, 3.0);
        let ids: Vec<EntityId> = table.iter().map(|(id, _)| id).collect();
        assert_eq!(ids, [2, 5]);
        assert_eq!(table.despawn(2).unwrap().name, "a");
        assert!(table.despawn(2).is_none());
        assert_eq!(table.len(), 1);
    }

    #[test]
    fn updating_a_snapshot_at_once_is_updating_each_state() {
        let spawned = |table: &mut KnownEntities| {
            for id in (2..=40).step_by(2) {
                table.spawn(desc(id, "x"));
            }
        };
        let (mut walked, mut each) = (KnownEntities::new(), KnownEntities::new());
        spawned(&mut walked);
        spawned(&mut each);
        // Ascending, with ids not spawned yet among them; a few of many
        // (looked up, not walked); then out of order.
        let dense: Vec<_> = (1..=40).map(|id| state(id, f64::from(id))).collect();
        let snapshots = [
            dense,
            vec![state(1, 1.0), state(2, 2.0), state(5, 5.0), state(8, 8.0)],
            vec![state(4, 4.0), state(6, 6.0)],
            vec![state(8, 9.0), state(2, 3.0)],
        ];
        for (tick, states) in snapshots.iter().enumerate() {
            walked.update_all(tick as u64, states);
            for &s in states {
                each.update(tick as u64, s);
            }
        }
        assert_eq!(walked.held(), each.held());
        let all = |t: &KnownEntities| t.iter().map(|(_, e)| e.clone()).collect::<Vec<_>>();
        assert_eq!(all(&walked), all(&each));
        assert_eq!(walked.get(2).unwrap().latest.unwrap().state.position.x, 3.0);
        walked.spawn(desc(5, "late"));
        assert_eq!(walked.get(5).unwrap().position().x, 5.0);
    }

    #[test]
    fn a_state_before_its_spawn_is_held_and_attached() {
        let mut table = KnownEntities::new();
        assert_eq!(table.update(3, state(9, 7.0)), Update::Held);
        assert_eq!(table.held(), 1);
        table.spawn(desc(9, "late"));
        assert_eq!(table.held(), 0);
        assert_eq!(table.get(9).unwrap().latest.unwrap().tick, 3);
        assert_eq!(table.get(9).unwrap().position().x, 7.0);
        for id in 100..100 + KnownEntities::MAX_EARLY as u32 {
            table.update(1, state(id, 0.0));
        }
        assert_eq!(table.update(1, state(1, 0.0)), Update::Dropped);
        table.clear();
        assert!(table.is_empty() && table.held() == 0);
    }
}
