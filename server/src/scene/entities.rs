//! The entity table: what clients see of the world.
//!
//! Every streamed thing — a rigid body or a particle of a rope or cloth — is
//! an entity with a `u32` id (from 1, in build order, never reused within a
//! run) and an [`EntityDesc`] telling a client how to draw it. The table
//! maps ids to physics handles and back, and counts its changes in a
//! `version` so the tick loop republishes the catalog only when it changed.

use std::collections::BTreeMap;

use inertia_physics::glam::{DQuat, DVec3};
use inertia_physics::rigid::body::BodyKind;
use inertia_physics::rigid::shape::{HeightField, Shape};
use inertia_physics::{BodyHandle, ParticleHandle, World};
use inertia_protocol::control::truncate_utf8;
use inertia_protocol::{EntityDesc, EntityId, EntityKind, EntityState, ShapeDesc};

/// Longest entity name sent to clients, bytes.
pub const MAX_NAME_BYTES: usize = 64;

/// What an entity is in the physics world.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum EntitySource {
    /// A rigid body.
    Body(BodyHandle),
    /// A particle (a rope or cloth vertex).
    Particle(ParticleHandle),
}

/// One entity.
#[derive(Debug, Clone, PartialEq)]
pub struct Entity {
    /// How clients draw it (its `id` is the entity's id; its pose is the
    /// one it was spawned with).
    pub desc: EntityDesc,
    /// Where it lives in the world.
    pub source: EntitySource,
    /// Stream it in every frame even if it is static (it was teleported).
    pub always_stream: bool,
}

/// Entities by id, with reverse lookups from physics handles.
#[derive(Debug, Clone)]
pub struct EntityTable {
    entries: BTreeMap<EntityId, Entity>,
    by_body: BTreeMap<BodyHandle, EntityId>,
    by_particle: BTreeMap<ParticleHandle, EntityId>,
    next_id: EntityId,
    version: u64,
}

impl Default for EntityTable {
    fn default() -> Self {
        Self::new()
    }
}

impl EntityTable {
    /// An empty table; the first id handed out is 1.
    pub fn new() -> Self {
        Self {
            entries: BTreeMap::new(),
            by_body: BTreeMap::new(),
            by_particle: BTreeMap::new(),
            next_id: 1,
            version: 0,
        }
    }

    /// Adds an entity for `source`; `desc.id` is overwritten with the new
    /// id and the name cut to [`MAX_NAME_BYTES`]. Returns the id.
    pub fn insert(&mut self, source: EntitySource, mut desc: EntityDesc) -> EntityId {
        let id = self.next_id;
        self.next_id = self.next_id.wrapping_add(1).max(1);
        desc.id = id;
        truncate_utf8(&mut desc.name, MAX_NAME_BYTES);
        match source {
            EntitySource::Body(h) => {
                self.by_body.insert(h, id);
            }
            EntitySource::Particle(h) => {
                self.by_particle.insert(h, id);
            }
        }
        self.entries.insert(
            id,
            Entity {
                desc,
                source,
                always_stream: false,
            },
        );
        self.version += 1;
        id
    }

    /// Removes an entity (not its physics object); `None` if unknown.
    pub fn remove(&mut self, id: EntityId) -> Option<Entity> {
        let e = self.entries.remove(&id)?;
        match e.source {
            EntitySource::Body(h) => {
                self.by_body.remove(&h);
            }
            EntitySource::Particle(h) => {
                self.by_particle.remove(&h);
            }
        }
        self.version += 1;
        Some(e)
    }

    /// The entity of a body, removed from the table; `None` if it had none.
    pub fn remove_body(&mut self, h: BodyHandle) -> Option<EntityId> {
        let id = *self.by_body.get(&h)?;
        self.remove(id).map(|_| id)
    }

    /// An entity.
    pub fn get(&self, id: EntityId) -> Option<&Entity> {
        self.entries.get(&id)
    }

    /// Marks an entity to be streamed every frame (a teleported static body).
    pub fn set_always_stream(&mut self, id: EntityId) {
        if let Some(e) = self.entries.get_mut(&id) {
            e.always_stream = true;
        }
    }

    /// The entity of a body.
    pub fn by_body(&self, h: BodyHandle) -> Option<EntityId> {
        self.by_body.get(&h).copied()
    }

    /// The entity of a particle.
    pub fn by_particle(&self, h: ParticleHandle) -> Option<EntityId> {
        self.by_particle.get(&h).copied()
    }

    /// The body of an entity, if it is a body.
    pub fn body(&self, id: EntityId) -> Option<BodyHandle> {
        match self.entries.get(&id)?.source {
            EntitySource::Body(h) => Some(h),
            EntitySource::Particle(_) => None,
        }
    }

    /// Entities in id order.
    pub fn iter(&self) -> impl Iterator<Item = (EntityId, &Entity)> {
        self.entries.iter().map(|(&id, e)| (id, e))
    }

    /// Number of entities.
    pub fn len(&self) -> usize {
        self.entries.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.entries.is_empty()
    }

    /// Counts every insert and removal; equal versions mean an equal table.
    pub fn version(&self) -> u64 {
        self.version
    }

    /// Every entity's description, by id.
    pub fn catalog(&self) -> BTreeMap<EntityId, EntityDesc> {
        self.entries
            .iter()
            .map(|(&id, e)| (id, e.desc.clone()))
            .collect()
    }

    /// The state of every entity that can move (dynamic and kinematic
    /// bodies, free particles, anything teleported), sorted by id. Entities
    /// whose physics object is gone are skipped.
    pub fn states(&self, world: &World) -> Vec<EntityState> {
        let mut out = Vec::with_capacity(self.entries.len());
        self.states_into(world, &mut out);
        out
    }

    /// [`Self::states`], into `out` (emptied first; passed in for its
    /// memory).
    pub fn states_into(&self, world: &World, out: &mut Vec<EntityState>) {
        out.clear();
        for (&id, e) in &self.entries {
            match e.source {
                EntitySource::Body(h) => {
                    let Some(b) = world.body(h) else { continue };
                    if b.kind() == BodyKind::Static && !e.always_stream {
                        continue;
                    }
                    let pose = b.pose();
                    let w = b.angular_velocity();
                    out.push(EntityState {
                        id,
                        position: pose.translation,
                        rotation: pose.rotation,
                        // The origin's velocity: the centre of mass's plus
                        // the turn's contribution at the origin.
                        linear_velocity: b.velocity_at(pose.translation),
                        angular_velocity: w,
                        asleep: b.is_sleeping(),
                    });
                }
                EntitySource::Particle(h) => {
                    let Some(p) = world.particle(h) else { continue };
                    if p.pinned && !e.always_stream {
                        continue;
                    }
                    out.push(EntityState {
                        id,
                        position: p.position,
                        rotation: DQuat::IDENTITY,
                        linear_velocity: p.velocity,
                        angular_velocity: DVec3::ZERO,
                        asleep: false,
                    });
                }
            }
        }
    }
}

/// Largest stored entity table [`EntityTable::from_bytes`] accepts, bytes.
pub const MAX_TABLE_BYTES: usize = 256 * 1024 * 1024;

/// An entity as stored beside a saved world (field order is the format:
/// postcard writes by position).
#[derive(serde::Serialize, serde::Deserialize)]
struct StoredEntity {
    #[serde(deserialize_with = "inertia_protocol::control::deserialize_entity")]
    desc: EntityDesc,
    /// 0 a body `[index, generation, 0, 0]`; 1 a particle
    /// `[system index, system generation, slot, generation]`.
    source_kind: u8,
    source: [u32; 4],
    always_stream: bool,
}

#[derive(serde::Serialize, serde::Deserialize)]
struct StoredTable {
    next_id: EntityId,
    version: u64,
    entries: Vec<StoredEntity>,
}

/// Why a stored entity table was refused.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("entity table: {0}")]
pub struct TableError(pub String);

impl EntityTable {
    /// The table as bytes, to store beside the world's saved state (the
    /// physics handles it holds are only meaningful with that state).
    pub fn to_bytes(&self) -> Vec<u8> {
        let stored = StoredTable {
            next_id: self.next_id,
            version: self.version,
            entries: self
                .entries
                .values()
                .map(|e| {
                    let (source_kind, source) = match e.source {
                        EntitySource::Body(h) => {
                            let [i, g] = h.to_raw();
                            (0, [i, g, 0, 0])
                        }
                        EntitySource::Particle(h) => (1, h.to_raw()),
                    };
                    StoredEntity {
                        desc: e.desc.clone(),
                        source_kind,
                        source,
                        always_stream: e.always_stream,
                    }
                })
                .collect(),
        };
        // Serialising owned plain data into a Vec cannot fail.
        postcard::to_allocvec(&stored).unwrap_or_default()
    }

    /// A table from [`EntityTable::to_bytes`]. Every description is checked
    /// as the control channel checks a spawn; ids must be unique and not 0,
    /// and no physics object may have two entities.
    pub fn from_bytes(bytes: &[u8]) -> Result<Self, TableError> {
        if bytes.len() > MAX_TABLE_BYTES {
            return Err(TableError(format!("{} bytes is too large", bytes.len())));
        }
        let stored: StoredTable =
            postcard::from_bytes(bytes).map_err(|e| TableError(e.to_string()))?;
        let mut table = EntityTable::new();
        table.next_id = stored.next_id;
        table.version = stored.version;
        for e in stored.entries {
            let id = e.desc.id;
            inertia_protocol::control::validate_entity(&e.desc)
                .map_err(|err| TableError(format!("entity {id}: {err}")))?;
            if id == 0 {
                return Err(TableError("entity id 0 is not an id".into()));
            }
            let source = match e.source_kind {
                0 => EntitySource::Body(BodyHandle::from_raw([e.source[0], e.source[1]])),
                1 => EntitySource::Particle(ParticleHandle::from_raw(e.source)),
                k => return Err(TableError(format!("entity {id}: unknown source kind {k}"))),
            };
            let clash = match source {
                EntitySource::Body(h) => table.by_body.insert(h, id).is_some(),
                EntitySource::Particle(h) => table.by_particle.insert(h, id).is_some(),
            };
            if clash {
                return Err(TableError(format!(
                    "entity {id}: its physics object has another entity"
                )));
            }
            let entity = Entity {
                desc: e.desc,
                source,
                always_stream: e.always_stream,
            };
            if table.entries.insert(id, entity).is_some() {
                return Err(TableError(format!("entity id {id} appears twice")));
            }
        }
        Ok(table)
    }
}

/// The entity kind a body of `kind` is drawn as.
pub fn entity_kind(kind: BodyKind) -> EntityKind {
    match kind {
        BodyKind::Dynamic => EntityKind::Dynamic,
        BodyKind::Kinematic => EntityKind::Kinematic,
        BodyKind::Static => EntityKind::Static,
    }
}

/// How a client draws `shape`. Shapes beyond the protocol's limits (too
/// many points or parts, nested compounds) are drawn as their bounding
/// box; a heightfield of more samples than a description holds is thinned
/// ([`height_field_desc`]).
pub fn shape_desc(shape: &Shape) -> ShapeDesc {
    exact_shape_desc(shape, true).unwrap_or_else(|| bounding_box(shape))
}

fn f3(v: DVec3) -> [f32; 3] {
    v.as_vec3().to_array()
}

fn exact_shape_desc(shape: &Shape, top: bool) -> Option<ShapeDesc> {
    Some(match shape {
        Shape::Sphere { radius } => ShapeDesc::Sphere {
            radius: *radius as f32,
        },
        Shape::Cuboid { half_extents } => ShapeDesc::Cuboid {
            half_extents: f3(*half_extents),
        },
        Shape::Capsule {
            half_height,
            radius,
        } => ShapeDesc::Capsule {
            half_height: *half_height as f32,
            radius: *radius as f32,
        },
        Shape::Cylinder {
            half_height,
            radius,
        } => ShapeDesc::Cylinder {
            half_height: *half_height as f32,
            radius: *radius as f32,
        },
        Shape::ConvexHull(hull) => {
            let v = hull.vertices();
            if v.len() > ShapeDesc::MAX_POINTS {
                return None;
            }
            ShapeDesc::ConvexHull {
                points: v.iter().map(|&p| f3(p)).collect(),
            }
        }
        Shape::TriMesh(mesh) => {
            if mesh.vertices().len() > ShapeDesc::MAX_POINTS
                || mesh.triangles().len() > ShapeDesc::MAX_POINTS
            {
                return None;
            }
            ShapeDesc::TriMesh {
                vertices: mesh.vertices().iter().map(|&p| f3(p)).collect(),
                triangles: mesh.triangles().to_vec(),
            }
        }
        Shape::HeightField(field) => height_field_desc(field),
        Shape::Compound(parts) => {
            if !top || parts.len() > ShapeDesc::MAX_PARTS {
                return None;
            }
            let mut out = Vec::with_capacity(parts.len());
            for (pose, part) in parts.iter() {
                let part = exact_shape_desc(part, false)?;
                out.push((
                    f3(pose.translation),
                    pose.rotation.as_quat().to_array(),
                    part,
                ));
            }
            ShapeDesc::Compound { parts: out }
        }
    })
}

/// A heightfield's description: every sample when they fit in
/// [`ShapeDesc::MAX_POINTS`], else every `step`-th row and column (the last
/// ones always kept, so the field keeps its size), the smallest step that
/// fits.
pub fn height_field_desc(field: &HeightField) -> ShapeDesc {
    let (rows, cols) = (field.rows(), field.cols());
    let picks = |n: usize, step: usize| -> Vec<usize> {
        let mut v: Vec<usize> = (0..n).step_by(step).collect();
        if v.last() != Some(&(n - 1)) {
            v.push(n - 1);
        }
        v
    };
    let mut step = 1;
    let (rs, cs) = loop {
        let (rs, cs) = (picks(rows, step), picks(cols, step));
        if rs.len() * cs.len() <= ShapeDesc::MAX_POINTS {
            break (rs, cs);
        }
        step += 1;
    };
    let scale = field.scale();
    let heights = rs
        .iter()
        .flat_map(|&r| cs.iter().map(move |&c| (r, c)))
        .map(|(r, c)| (field.heights()[r * cols + c] * scale.y) as f32)
        .collect();
    ShapeDesc::HeightField {
        rows: rs.len() as u32,
        cols: cs.len() as u32,
        size: [scale.x as f32, scale.z as f32],
        heights,
    }
}

fn bounding_box(shape: &Shape) -> ShapeDesc {
    let b = shape.local_aabb();
    let center = (b.min + b.max) * 0.5;
    let cuboid = ShapeDesc::Cuboid {
        half_extents: f3(((b.max - b.min) * 0.5).max(DVec3::splat(1e-3))),
    };
    if center.length() < 1e-9 {
        cuboid
    } else {
        ShapeDesc::Compound {
            parts: vec![(f3(center), [0.0, 0.0, 0.0, 1.0], cuboid)],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use inertia_physics::rigid::pose::Pose;

    #[test]
    fn a_heightfield_is_described_whole_or_thinned_to_fit_keeping_its_corners() {
        let field = |n: usize| {
            let heights = (0..n * n).map(|k| (k % 7) as f64).collect();
            HeightField::new(heights, n, n, DVec3::new(40.0, 0.5, 20.0)).unwrap()
        };
        let small = field(10);
        let ShapeDesc::HeightField {
            rows,
            cols,
            size,
            heights,
        } = shape_desc(&Shape::HeightField(std::sync::Arc::new(small.clone())))
        else {
            panic!("a heightfield");
        };
        assert_eq!((rows, cols, size), (10, 10, [40.0, 20.0]));
        assert_eq!(heights[11], (small.heights()[11] * 0.5) as f32);

        let large = field(200);
        let ShapeDesc::HeightField {
            rows,
            cols,
            heights,
            ..
        } = height_field_desc(&large)
        else {
            panic!("a heightfield");
        };
        assert!(heights.len() <= ShapeDesc::MAX_POINTS);
        assert!(
            rows >= 50 && cols >= 50,
            "{rows}×{cols}: thinned no more than needed"
        );
        assert_eq!(heights.len(), (rows * cols) as usize);
        let h = |r: usize, c: usize| (large.heights()[r * 200 + c] * 0.5) as f32;
        assert_eq!(heights[0], h(0, 0));
        assert_eq!(
            heights[heights.len() - 1],
            h(199, 199),
            "the far corner kept"
        );
    }

    #[test]
    fn ids_start_at_one_and_are_not_reused() {
        let mut t = EntityTable::new();
        let mut w = World::new(Default::default()).unwrap();
        let desc = |name: &str| EntityDesc {
            id: 0,
            kind: EntityKind::Dynamic,
            shape: ShapeDesc::Sphere { radius: 1.0 },
            color: [0; 4],
            owner: None,
            name: name.into(),
            position: [0.0; 3],
            rotation: [0.0, 0.0, 0.0, 1.0],
        };
        let s = Shape::sphere(0.5).unwrap();
        let body = |w: &mut World| {
            w.add_body(
                &inertia_physics::rigid::body::RigidBodyDesc::dynamic(
                    s.clone(),
                    1.0,
                    Pose::IDENTITY,
                )
                .unwrap(),
            )
            .unwrap()
        };
        let (h1, h2) = (body(&mut w), body(&mut w));
        let a = t.insert(EntitySource::Body(h1), desc(&"x".repeat(100)));
        let b = t.insert(EntitySource::Body(h2), desc("b"));
        assert_eq!((a, b), (1, 2));
        assert_eq!(t.get(a).unwrap().desc.name.len(), MAX_NAME_BYTES);
        assert_eq!(t.remove_body(h1), Some(1));
        let h3 = body(&mut w);
        assert_eq!(t.insert(EntitySource::Body(h3), desc("c")), 3);
        assert_eq!(t.by_body(h2), Some(2));
        assert_eq!(t.version(), 4);
        assert_eq!(t.states(&w).len(), 2);
    }

    #[test]
    fn large_shapes_fall_back_to_their_box() {
        let pts: Vec<DVec3> = (0..20)
            .map(|i| {
                let a = i as f64;
                DVec3::new(a.cos(), (a * 0.7).sin(), (a * 1.3).cos() + 2.0)
            })
            .collect();
        let hull = Shape::convex_hull(&pts).unwrap();
        assert!(matches!(shape_desc(&hull), ShapeDesc::ConvexHull { .. }));
        let nested = Shape::compound(vec![(
            Pose::IDENTITY,
            Shape::compound(vec![(Pose::IDENTITY, Shape::sphere(1.0).unwrap())]).unwrap(),
        )])
        .unwrap();
        assert!(matches!(
            shape_desc(&nested),
            ShapeDesc::Cuboid { .. } | ShapeDesc::Compound { .. }
        ));
    }
}
