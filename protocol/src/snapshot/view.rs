//! What a snapshot describes: entities quantized exactly as they travel,
//! the view (a set of them, by id) that both ends hold per sequence
//! number, and the ring of recent views.

use glam::{DQuat, DVec3};

use crate::entity::{EntityId, EntityState};
use crate::property::PropertyView;
use crate::quantize::{rotation_from_levels, rotation_levels};

use super::{SnapshotConfig, RING};

/// A rotation as smallest three: which component was dropped and the
/// other three, each `rotation_bits` wide, in order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default)]
pub struct QuantizedRotation {
    /// Index (0 = x … 3 = w) of the largest component, rebuilt on decode.
    pub largest: u8,
    /// The other three components as levels `0 ..= 2^bits - 1` spanning
    /// `[-1/√2, 1/√2]`.
    pub small: [u16; 3],
}

impl QuantizedRotation {
    /// Quantizes `q` with `bits` a component, by the shared quantizer
    /// ([`rotation_levels`]), so every user of it agrees bit for bit.
    pub fn new(q: DQuat, bits: u32) -> Self {
        let (largest, small) = rotation_levels(q.to_array(), bits);
        Self { largest, small }
    }

    /// The unit quaternion these levels stand for (as [`read_rotation`]
    /// rebuilds it).
    ///
    /// [`read_rotation`]: crate::quantize::read_rotation
    pub fn to_quat(self, bits: u32) -> DQuat {
        DQuat::from_array(rotation_from_levels(self.largest, self.small, bits))
    }
}

/// One entity exactly as snapshots carry it. Two states that quantize
/// alike are the same state to the protocol.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub struct QuantizedEntity {
    /// Position grid index per axis ([`crate::quantize::PositionGrid::index`]).
    pub position: [u32; 3],
    /// Orientation.
    pub rotation: QuantizedRotation,
    /// Velocity grid index per axis; `Some` only when the config sends
    /// velocities and the entity is not at rest.
    pub velocity: Option<[u32; 3]>,
    /// The body sleeps: it will not move until something wakes it.
    pub at_rest: bool,
}

impl QuantizedEntity {
    /// Quantizes `e` under `config`.
    pub fn new(e: &EntityState, config: &SnapshotConfig) -> Self {
        let index =
            |g: &crate::quantize::PositionGrid, v: DVec3| v.to_array().map(|x| g.index(x) as u32);
        Self {
            position: index(&config.grid, e.position),
            rotation: QuantizedRotation::new(e.rotation, config.rotation_bits),
            velocity: (config.velocities && !e.asleep)
                .then(|| index(&config.velocity_grid, e.linear_velocity)),
            at_rest: e.asleep,
        }
    }

    /// The values these indices stand for.
    pub fn dequantize(&self, id: EntityId, config: &SnapshotConfig) -> ViewEntity {
        let coords = |g: &crate::quantize::PositionGrid, i: [u32; 3]| {
            DVec3::from_array(i.map(|x| g.coordinate(u64::from(x))))
        };
        ViewEntity {
            id,
            position: coords(&config.grid, self.position),
            rotation: self.rotation.to_quat(config.rotation_bits),
            linear_velocity: self.velocity.map(|v| coords(&config.velocity_grid, v)),
            angular_velocity: None,
            at_rest: self.at_rest,
        }
    }
}

/// One entity as a snapshot shows it, in world units: what the decoder
/// yields, the client's interpolation buffers and its entity table holds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewEntity {
    /// The entity.
    pub id: EntityId,
    /// Position of its origin (on the grid, from a snapshot), m.
    pub position: DVec3,
    /// Orientation (unit quaternion).
    pub rotation: DQuat,
    /// Linear velocity (on the velocity grid, from a snapshot), m/s of
    /// simulation time, when sent.
    pub linear_velocity: Option<DVec3>,
    /// Angular velocity (world frame), rad/s of simulation time, when
    /// known (snapshots do not carry it; the interpolation turns by it
    /// when a state from elsewhere has it).
    pub angular_velocity: Option<DVec3>,
    /// The body sleeps: it will not move until something wakes it.
    pub at_rest: bool,
}

impl From<&EntityState> for ViewEntity {
    /// The server's state of an entity, exactly (no quantization).
    fn from(s: &EntityState) -> Self {
        Self {
            id: s.id,
            position: s.position,
            rotation: s.rotation,
            linear_velocity: Some(s.linear_velocity),
            angular_velocity: Some(s.angular_velocity),
            at_rest: s.asleep,
        }
    }
}

/// A full quantized view: the tick it describes, its entities, ascending
/// by id, and their properties and the match's.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct View {
    /// The tick the view describes.
    pub tick: u64,
    pub(crate) entities: Vec<(EntityId, QuantizedEntity)>,
    pub(crate) properties: PropertyView,
}

impl View {
    /// The properties of its entities and of the match.
    pub fn properties(&self) -> &PropertyView {
        &self.properties
    }

    /// The entities, ascending by id.
    pub fn entities(&self) -> &[(EntityId, QuantizedEntity)] {
        &self.entities
    }

    /// One entity, if in the view.
    pub fn get(&self, id: EntityId) -> Option<&QuantizedEntity> {
        self.entities
            .binary_search_by_key(&id, |e| e.0)
            .ok()
            .map(|i| &self.entities[i].1)
    }

    /// [`Self::get`] for ids asked in ascending order: `at` (0 before the
    /// first) is where the last search ended, and the search goes on from
    /// there.
    pub(crate) fn find_from(&self, at: &mut usize, id: EntityId) -> Option<&QuantizedEntity> {
        self.index_from(at, id).map(|i| &self.entities[i].1)
    }

    /// Where `id` is, searching on from `at` (see [`Self::find_from`]),
    /// which is left at the first entity not below `id`.
    fn index_from(&self, at: &mut usize, id: EntityId) -> Option<usize> {
        // Galloping: the next id is usually a few places on, so bracket it
        // by doubling steps, then search only the bracket.
        let rest = &self.entities[*at..];
        let mut end = 1;
        while end < rest.len() && rest[end - 1].0 < id {
            end *= 2;
        }
        let end = end.min(rest.len());
        *at += rest[..end].partition_point(|e| e.0 < id);
        self.entities
            .get(*at)
            .is_some_and(|e| e.0 == id)
            .then_some(*at)
    }

    /// Entities in the view.
    pub fn len(&self) -> usize {
        self.entities.len()
    }

    /// Whether the view holds no entity.
    pub fn is_empty(&self) -> bool {
        self.entities.is_empty()
    }

    /// This view with `removed` gone and `updated` put in (both ascending by
    /// id), by one merge into `buffer` (cleared first; passed in for its
    /// memory).
    pub(crate) fn apply_into(
        &self,
        tick: u64,
        removed: &[EntityId],
        updated: &[(EntityId, QuantizedEntity)],
        mut buffer: Vec<(EntityId, QuantizedEntity)>,
    ) -> View {
        buffer.clear();
        buffer.reserve(self.entities.len() + updated.len());
        let (mut r, mut u) = (0, 0);
        for &(id, q) in &self.entities {
            while u < updated.len() && updated[u].0 < id {
                buffer.push(updated[u]);
                u += 1;
            }
            while r < removed.len() && removed[r] < id {
                r += 1;
            }
            if u < updated.len() && updated[u].0 == id {
                buffer.push(updated[u]);
                u += 1;
            } else if !(r < removed.len() && removed[r] == id) {
                buffer.push((id, q));
            }
        }
        buffer.extend_from_slice(&updated[u..]);
        View {
            tick,
            entities: buffer,
            properties: self.properties.clone(),
        }
    }

    /// [`Self::apply_into`] on this view itself: when nothing is removed
    /// and every updated id is already here (a world that only moves),
    /// each update is written over its entity; otherwise the merge goes
    /// through `scratch`, which is left holding the old buffer.
    pub(crate) fn apply_in_place(
        &mut self,
        tick: u64,
        removed: &[EntityId],
        updated: &[(EntityId, QuantizedEntity)],
        scratch: &mut Vec<(EntityId, QuantizedEntity)>,
    ) {
        self.tick = tick;
        if removed.is_empty() {
            let mut at = 0;
            let mut all_here = true;
            for &(id, q) in updated {
                match self.index_from(&mut at, id) {
                    Some(i) => self.entities[i].1 = q,
                    None => {
                        all_here = false;
                        break;
                    }
                }
            }
            if all_here {
                return;
            }
        }
        // Updates already written are written again by the merge.
        let merged = self.apply_into(tick, removed, updated, std::mem::take(scratch));
        *scratch = std::mem::replace(&mut self.entities, merged.entities);
    }
}

/// The last [`RING`] views by sequence number.
#[derive(Debug, Clone)]
pub(crate) struct Ring {
    slots: Vec<Option<(u16, View)>>,
}

impl Ring {
    pub(crate) fn new() -> Self {
        Self {
            slots: vec![None; RING],
        }
    }

    pub(crate) fn get(&self, seq: u16) -> Option<&View> {
        match &self.slots[usize::from(seq) % RING] {
            Some((s, v)) if *s == seq => Some(v),
            _ => None,
        }
    }

    /// A buffer for the view of `seq`: the one of the view its slot holds
    /// now (which `seq` replaces), unless that view is `keep` (a baseline
    /// still to be read); empty otherwise.
    pub(crate) fn spare_for(
        &mut self,
        seq: u16,
        keep: Option<u16>,
    ) -> Vec<(EntityId, QuantizedEntity)> {
        let slot = &mut self.slots[usize::from(seq) % RING];
        match slot {
            Some((held, _)) if Some(*held) == keep => Vec::new(),
            _ => slot.take().map(|(_, v)| v.entities).unwrap_or_default(),
        }
    }

    pub(crate) fn insert(&mut self, seq: u16, view: View) {
        self.slots[usize::from(seq) % RING] = Some((seq, view));
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// An entity told apart by its position.
    fn q(x: u32) -> QuantizedEntity {
        QuantizedEntity {
            position: [x; 3],
            rotation: QuantizedRotation::default(),
            velocity: None,
            at_rest: false,
        }
    }

    #[test]
    fn rotation_levels_rebuild_what_the_shared_reader_rebuilds() {
        let q = DQuat::from_euler(glam::EulerRot::XYZ, 0.3, -1.2, 2.0);
        for bits in [9, 11, 16] {
            let r = QuantizedRotation::new(q, bits);
            let back = r.to_quat(bits);
            assert!(back.dot(q).abs() > 0.9999, "{bits}: {back:?} vs {q:?}");
            assert_eq!(QuantizedRotation::new(back, bits), r, "stable at {bits}");
        }
    }

    #[test]
    fn a_forward_cursor_finds_what_get_finds() {
        let view = View {
            tick: 1,
            entities: (0..300u32).map(|i| (i * 8 + i % 7, q(i))).collect(),
            ..View::default()
        };
        for stride in [1u32, 2, 5, 40, 333] {
            let mut at = 0;
            for id in (0..2500).step_by(stride as usize) {
                assert_eq!(
                    view.find_from(&mut at, id),
                    view.get(id),
                    "{id} by {stride}"
                );
            }
        }
    }

    #[test]
    fn apply_merges_removals_and_updates() {
        let base = View {
            tick: 1,
            entities: vec![(1, q(1)), (3, q(3)), (5, q(5)), (7, q(7))],
            ..View::default()
        };
        let (removed, updated) = ([3, 7], [(0, q(9)), (5, q(8)), (9, q(9))]);
        let next = base.apply_into(2, &removed, &updated, vec![(4, q(4))]);
        assert_eq!(next.tick, 2);
        assert_eq!(
            next.entities,
            vec![(0, q(9)), (1, q(1)), (5, q(8)), (9, q(9))]
        );
        // In place, through the merge (removals, a new id) and by writing
        // over (updates of ids held only), the same view.
        let mut scratch = Vec::new();
        let mut in_place = base.clone();
        in_place.apply_in_place(2, &removed, &updated, &mut scratch);
        assert_eq!(in_place, next);
        let moved = [(1, q(11)), (7, q(17))];
        let mut in_place = base.clone();
        in_place.apply_in_place(3, &[], &moved, &mut scratch);
        assert_eq!(in_place, base.apply_into(3, &[], &moved, Vec::new()));
        // An id not held, after some written over: the merge still agrees.
        let mixed = [(1, q(11)), (6, q(6))];
        let mut in_place = base.clone();
        in_place.apply_in_place(4, &[], &mixed, &mut scratch);
        assert_eq!(in_place, base.apply_into(4, &[], &mixed, Vec::new()));
    }
    proptest::proptest! {
        /// The merge of runs gives what a map of the view, with the
        /// removals taken out and the updates put in, gives.
        #[test]
        fn apply_agrees_with_a_map_of_the_view(
            held in proptest::collection::btree_set(0u32..400, 0..200),
            removed in proptest::collection::btree_set(0u32..400, 0..40),
            updated in proptest::collection::btree_map(0u32..400, 0u32..1000, 0..40),
        ) {
            let base = View {
                tick: 1,
                entities: held.iter().map(|&id| (id, q(id))).collect(),
                ..View::default()
            };
            let mut model: std::collections::BTreeMap<u32, QuantizedEntity> =
                base.entities.iter().copied().collect();
            for id in &removed {
                model.remove(id);
            }
            let updated: Vec<_> = updated.into_iter().map(|(id, x)| (id, q(x))).collect();
            model.extend(updated.iter().copied());
            let removed: Vec<_> = removed.into_iter().collect();
            let next = base.apply_into(2, &removed, &updated, Vec::new());
            proptest::prop_assert_eq!(&next.entities, &model.into_iter().collect::<Vec<_>>());
            let mut in_place = base.clone();
            in_place.apply_in_place(2, &removed, &updated, &mut Vec::new());
            proptest::prop_assert_eq!(in_place, next);
        }
    }
}
