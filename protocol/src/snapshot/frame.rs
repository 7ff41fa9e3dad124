//! One published frame of the world, quantized once for every client.
//!
//! The server quantizes each entity of a frame a single time (grid indices,
//! smallest-three levels, velocity levels), into columns (structure of
//! arrays), and every client's [`super::SnapshotEncoder`] then only
//! compares those integers with its baseline's. Quantizing is the same for
//! all clients because the [`SnapshotConfig`] is: only the baseline, the
//! interest and the budget differ per client.

use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;

use glam::DVec3;

use crate::entity::{EntityId, EntityState};
use crate::property::FrameProperties;

use super::view::{QuantizedEntity, QuantizedRotation};
use super::{SnapshotConfig, MAX_TIME_SCALE};

/// The entities of one tick as snapshots carry them, with the clock
/// fields of the snapshot header, for every client to code against its
/// own baseline.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct QuantizedFrame {
    /// The tick the frame describes.
    pub tick: u64,
    /// The clock's time scale (1 = real time, negative while history plays
    /// backwards), finite and within ±[`MAX_TIME_SCALE`].
    pub time_scale: f32,
    /// The clock is paused.
    pub paused: bool,
    /// Which frame this is, unique in the process (copies share it): what
    /// [`super::SharedDeltas`] are kept for.
    serial: u64,
    /// Ids, ascending and unique.
    ids: Vec<EntityId>,
    /// Where each entity is, m: what a client's interest weighs.
    positions: Vec<DVec3>,
    /// Position grid indices.
    grid: Vec<[u32; 3]>,
    /// Smallest-three levels.
    rotations: Vec<QuantizedRotation>,
    /// Velocity grid indices (all zero when not sent: see `moving`).
    velocities: Vec<[u32; 3]>,
    /// Whether the entity carries a velocity (the config sends them and it
    /// is not at rest).
    moving: Vec<bool>,
    /// The body sleeps.
    at_rest: Vec<bool>,
    /// The game's properties at this tick (none: the game declares none).
    properties: Option<Arc<FrameProperties>>,
}

/// The next [`QuantizedFrame::serial`] (0 is the empty default frame's).
static NEXT_SERIAL: AtomicU64 = AtomicU64::new(1);

impl QuantizedFrame {
    /// Quantizes `entities` at `tick` under `config`. Entities need not be
    /// sorted; an id repeated is taken once (its first state). A time
    /// scale beyond ±[`MAX_TIME_SCALE`] is clamped to it, one not finite
    /// is sent as 0.
    pub fn new(
        tick: u64,
        time_scale: f32,
        paused: bool,
        entities: &[EntityState],
        config: &SnapshotConfig,
    ) -> Self {
        let mut order: Vec<usize> = (0..entities.len()).collect();
        if !entities.windows(2).all(|w| w[0].id < w[1].id) {
            order.sort_by_key(|&i| entities[i].id);
            order.dedup_by_key(|i| entities[*i].id);
        }
        let n = order.len();
        let mut frame = Self {
            tick,
            time_scale: if time_scale.is_finite() {
                time_scale.clamp(-MAX_TIME_SCALE, MAX_TIME_SCALE)
            } else {
                0.0
            },
            paused,
            serial: NEXT_SERIAL.fetch_add(1, Ordering::Relaxed),
            ids: Vec::with_capacity(n),
            positions: Vec::with_capacity(n),
            grid: Vec::with_capacity(n),
            rotations: Vec::with_capacity(n),
            velocities: Vec::with_capacity(n),
            moving: Vec::with_capacity(n),
            at_rest: Vec::with_capacity(n),
            properties: None,
        };
        for i in order {
            let e = &entities[i];
            let q = QuantizedEntity::new(e, config);
            frame.ids.push(e.id);
            frame.positions.push(e.position);
            frame.grid.push(q.position);
            frame.rotations.push(q.rotation);
            frame.moving.push(q.velocity.is_some());
            frame.velocities.push(q.velocity.unwrap_or_default());
            frame.at_rest.push(q.at_rest);
        }
        frame
    }

    /// The same frame with the game's properties at its tick.
    pub fn with_properties(mut self, properties: Arc<FrameProperties>) -> Self {
        self.properties = Some(properties);
        self
    }

    /// The game's properties at this tick, if it declares any.
    pub fn properties(&self) -> Option<&FrameProperties> {
        self.properties.as_deref()
    }

    /// Which frame this is, unique in the process (a copy has its
    /// original's).
    pub fn serial(&self) -> u64 {
        self.serial
    }

    /// The memory its columns take, bytes (the properties, shared with
    /// the published frame, not counted): what a server holding frames
    /// for replays counts against its budget.
    pub fn heap_bytes(&self) -> usize {
        use std::mem::size_of;
        self.ids.capacity() * size_of::<EntityId>()
            + self.positions.capacity() * size_of::<DVec3>()
            + self.grid.capacity() * size_of::<[u32; 3]>()
            + self.rotations.capacity() * size_of::<QuantizedRotation>()
            + self.velocities.capacity() * size_of::<[u32; 3]>()
            + self.moving.capacity()
            + self.at_rest.capacity()
    }

    /// Entities in the frame.
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    /// Whether the frame holds no entity.
    pub fn is_empty(&self) -> bool {
        self.ids.is_empty()
    }

    /// The ids, ascending.
    pub fn ids(&self) -> &[EntityId] {
        &self.ids
    }

    /// Where entity `i` (an index into [`Self::ids`]) is, m.
    pub fn position(&self, i: usize) -> DVec3 {
        self.positions[i]
    }

    /// Whether entity `i` sleeps.
    pub fn at_rest(&self, i: usize) -> bool {
        self.at_rest[i]
    }

    /// Entity `i` exactly as a snapshot carries it.
    pub fn state(&self, i: usize) -> QuantizedEntity {
        QuantizedEntity {
            position: self.grid[i],
            rotation: self.rotations[i],
            velocity: self.moving[i].then_some(self.velocities[i]),
            at_rest: self.at_rest[i],
        }
    }

    /// Whether entity `i` is exactly `q` (the columns compared as
    /// integers, position first: what moves differs there).
    pub fn same_as(&self, i: usize, q: &QuantizedEntity) -> bool {
        self.grid[i] == q.position
            && self.rotations[i] == q.rotation
            && self.at_rest[i] == q.at_rest
            && match q.velocity {
                Some(v) => self.moving[i] && self.velocities[i] == v,
                None => !self.moving[i],
            }
    }

    /// The index of entity `id`, if in the frame.
    pub fn index_of(&self, id: EntityId) -> Option<usize> {
        self.ids.binary_search(&id).ok()
    }
}

#[cfg(test)]
mod tests {
    use glam::DQuat;

    use super::*;

    fn entity(id: EntityId, x: f64, asleep: bool) -> EntityState {
        EntityState {
            id,
            position: DVec3::new(x, 1.0, -2.0),
            rotation: DQuat::from_rotation_y(x),
            linear_velocity: DVec3::new(0.5, 0.0, x),
            angular_velocity: DVec3::ZERO,
            asleep,
        }
    }

    #[test]
    fn columns_hold_what_each_entity_quantizes_to() {
        let config = SnapshotConfig {
            velocities: true,
            ..SnapshotConfig::default()
        };
        let entities = [
            entity(9, 3.0, false),
            entity(2, -1.5, true),
            entity(5, 0.25, false),
            entity(2, 7.0, false),
        ];
        let frame = QuantizedFrame::new(40, f32::INFINITY, true, &entities, &config);
        assert_eq!(frame.ids(), &[2, 5, 9], "sorted, the repeated id once");
        assert_eq!(frame.time_scale, 0.0, "not finite is sent as 0");
        for (i, e) in [&entities[1], &entities[2], &entities[0]]
            .into_iter()
            .enumerate()
        {
            let q = QuantizedEntity::new(e, &config);
            assert_eq!(frame.state(i), q);
            assert!(frame.same_as(i, &q));
            assert_eq!(frame.position(i), e.position);
            assert_eq!(frame.index_of(e.id), Some(i));
        }
        let mut other = frame.state(1);
        other.velocity = None;
        assert!(!frame.same_as(1, &other), "a velocity it does not carry");
        assert!(!frame.same_as(0, &frame.state(1)));
        assert_eq!(frame.state(0).velocity, None, "at rest: no velocity");
    }
}
