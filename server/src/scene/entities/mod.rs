//! The entity table: what clients see of the world.
//!
//! Every streamed thing — a rigid body, a mass-spring particle, an XPBD
//! soft body or a fluid — is an entity with a `u32` id (from 1, in build
//! order, never reused within a run) and an [`EntityDesc`] telling a client
//! how to draw it. A soft body or a fluid is one entity whose points travel
//! as the entities just after it ([`ShapeDesc::PointSet`]): it takes one id
//! for itself and one for each point ([`super::point_sets`]). The table
//! maps ids to physics handles and back, and counts its changes in a
//! `version` so the tick loop republishes the catalog only when it changed.

mod describe;
mod stored;

use std::collections::BTreeMap;

use inertia_physics::glam::{DQuat, DVec3};
use inertia_physics::rigid::body::BodyKind;
use inertia_physics::{BodyHandle, FluidHandle, ParticleHandle, SoftBodyHandle, World};
use inertia_protocol::control::truncate_utf8;
use inertia_protocol::{EntityDesc, EntityId, EntityState, ShapeDesc};

pub use describe::{entity_kind, height_field_desc, shape_desc};
pub use stored::{TableError, MAX_TABLE_BYTES};

/// Longest entity name sent to clients, bytes.
pub const MAX_NAME_BYTES: usize = 64;

/// What an entity is in the physics world.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum EntitySource {
    /// A rigid body.
    Body(BodyHandle),
    /// A particle (a mass-spring rope or cloth vertex).
    Particle(ParticleHandle),
    /// An XPBD soft body, streamed as a point set.
    SoftBody(SoftBodyHandle),
    /// A fluid, streamed as a point set.
    Fluid(FluidHandle),
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
    by_soft_body: BTreeMap<SoftBodyHandle, EntityId>,
    by_fluid: BTreeMap<FluidHandle, EntityId>,
    /// Of each soft body's entity, the body's triangles and edges its
    /// description was made from: when they change (it tore), so does the
    /// description.
    soft_topology: BTreeMap<EntityId, [usize; 2]>,
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
            by_soft_body: BTreeMap::new(),
            by_fluid: BTreeMap::new(),
            soft_topology: BTreeMap::new(),
            next_id: 1,
            version: 0,
        }
    }

    /// Adds an entity for `source`; `desc.id` is overwritten with the new
    /// id and the name cut to [`MAX_NAME_BYTES`]. Returns the id. A point
    /// set takes the ids of its points too (the next entity's id is past
    /// them); one that would run past `u32::MAX` starts again at 1.
    pub fn insert(&mut self, source: EntitySource, mut desc: EntityDesc) -> EntityId {
        let taken = desc.ids_taken();
        let mut id = self.next_id;
        if u64::from(id) + taken - 1 > u64::from(EntityId::MAX) {
            id = 1;
        }
        self.next_id = EntityId::try_from(u64::from(id) + taken).unwrap_or(1);
        desc.id = id;
        truncate_utf8(&mut desc.name, MAX_NAME_BYTES);
        match source {
            EntitySource::Body(h) => {
                self.by_body.insert(h, id);
            }
            EntitySource::Particle(h) => {
                self.by_particle.insert(h, id);
            }
            EntitySource::SoftBody(h) => {
                self.by_soft_body.insert(h, id);
            }
            EntitySource::Fluid(h) => {
                self.by_fluid.insert(h, id);
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
            EntitySource::SoftBody(h) => {
                self.by_soft_body.remove(&h);
                self.soft_topology.remove(&id);
            }
            EntitySource::Fluid(h) => {
                self.by_fluid.remove(&h);
            }
        }
        self.version += 1;
        Some(e)
    }

    /// Adds the entity of soft body `h` (see
    /// [`super::point_sets::soft_body_desc`]); `None` if the world has no
    /// such body.
    pub fn insert_soft_body(
        &mut self,
        world: &World,
        h: SoftBodyHandle,
        name: String,
        color: [u8; 4],
    ) -> Option<EntityId> {
        let body = world.soft_body(h)?;
        let desc = super::point_sets::soft_body_desc(body, name, color);
        let id = self.insert(EntitySource::SoftBody(h), desc);
        self.soft_topology.insert(id, topology(body));
        Some(id)
    }

    /// Adds the entity of fluid `h` (see
    /// [`super::point_sets::fluid_desc`]); `None` if the world has no such
    /// fluid.
    pub fn insert_fluid(
        &mut self,
        world: &World,
        h: FluidHandle,
        name: String,
        color: [u8; 4],
    ) -> Option<EntityId> {
        let fluid = world.fluid(h)?;
        let desc = super::point_sets::fluid_desc(fluid, name, color);
        Some(self.insert(EntitySource::Fluid(h), desc))
    }

    /// Describes again every soft body whose triangles or edges changed
    /// since it was described (it tore), keeping its id, name and colour:
    /// the catalog then tells clients its new shape. Returns how many.
    pub fn reshape_soft_bodies(&mut self, world: &World) -> usize {
        let mut reshaped = 0;
        for (&h, &id) in &self.by_soft_body {
            let (Some(entity), Some(body)) = (self.entries.get_mut(&id), world.soft_body(h)) else {
                continue;
            };
            let now = topology(body);
            let was = self.soft_topology.entry(id).or_insert(now);
            if *was == now {
                continue;
            }
            *was = now;
            let old = &entity.desc;
            let mut desc = super::point_sets::soft_body_desc(body, old.name.clone(), old.color);
            desc.id = id;
            // Its points keep their ids: the set keeps its size.
            if let (
                ShapeDesc::PointSet { points, .. },
                ShapeDesc::PointSet { points: before, .. },
            ) = (&mut desc.shape, &old.shape)
            {
                *points = *before;
            }
            entity.desc = desc;
            reshaped += 1;
        }
        if reshaped > 0 {
            self.version += 1;
        }
        reshaped
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

    /// The entity of a soft body.
    pub fn by_soft_body(&self, h: SoftBodyHandle) -> Option<EntityId> {
        self.by_soft_body.get(&h).copied()
    }

    /// The entity of a fluid.
    pub fn by_fluid(&self, h: FluidHandle) -> Option<EntityId> {
        self.by_fluid.get(&h).copied()
    }

    /// The body of an entity, if it is a body.
    pub fn body(&self, id: EntityId) -> Option<BodyHandle> {
        match self.entries.get(&id)?.source {
            EntitySource::Body(h) => Some(h),
            _ => None,
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
    /// bodies, free particles, every point of a soft body or fluid,
    /// anything teleported), sorted by id. Entities whose physics object is
    /// gone are skipped.
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
                EntitySource::SoftBody(h) => {
                    if let Some(body) = world.soft_body(h) {
                        let (x, v) = (body.positions(), body.velocities());
                        super::point_sets::push_points(&e.desc, x, v, out);
                    }
                }
                EntitySource::Fluid(h) => {
                    if let Some(fluid) = world.fluid(h) {
                        let (x, v) = (fluid.positions(), fluid.velocities());
                        super::point_sets::push_points(&e.desc, x, v, out);
                    }
                }
            }
        }
    }
}

/// What a soft body's description is made from that tearing changes: its
/// triangles and its edges.
fn topology(body: &inertia_physics::xpbd::soft::SoftBody) -> [usize; 2] {
    [body.triangles().len(), body.constraint_counts()[0]]
}

#[cfg(test)]
mod tests {
    use super::*;
    use inertia_physics::rigid::pose::Pose;
    use inertia_physics::rigid::shape::{HeightField, Shape};
    use inertia_protocol::EntityKind;

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
    fn issue_16_soft_bodies_and_fluids_stream_their_points_and_a_torn_cloth_is_described_again() {
        use inertia_physics::xpbd::soft::{SoftCloth, SoftMaterial};
        use inertia_physics::FluidDesc;
        let mut w = World::new(Default::default()).unwrap();
        w.set_gravity(DVec3::new(0.0, -9.81, 0.0)).unwrap();
        let n = 12;
        let cloth = SoftCloth {
            corner: DVec3::new(-1.0, 3.0, 0.0),
            across: DVec3::new(2.0, 0.0, 0.0),
            down: DVec3::new(0.0, -2.0, 0.0),
            rows: n,
            cols: n,
            stretch_compliance: 1e-3,
            shear_compliance: 1e-3,
            bend_compliance: 100.0,
            pinned: vec![[0, 0], [0, n - 1]],
            material: SoftMaterial {
                tear_strain: Some(0.05),
                ..SoftMaterial::default()
            },
            ..SoftCloth::default()
        };
        let soft = w.add_soft_body(&cloth.build().unwrap()).unwrap();
        let fluid_desc =
            FluidDesc::block(DVec3::new(2.0, 0.0, 0.0), DVec3::new(2.4, 0.4, 0.4), 0.1).unwrap();
        let fluid = w.add_fluid(fluid_desc).unwrap();
        let particles = w.fluid(fluid).unwrap().len();

        let mut t = EntityTable::new();
        let flag = t
            .insert_soft_body(&w, soft, "flag".into(), [200, 0, 0, 255])
            .unwrap();
        let pool = t
            .insert_fluid(&w, fluid, "pool".into(), [0, 0, 255, 128])
            .unwrap();
        let desc = &t.get(flag).unwrap().desc;
        let ShapeDesc::PointSet {
            points, triangles, ..
        } = &desc.shape
        else {
            panic!("a point set: {:?}", desc.shape);
        };
        assert_eq!(*points, n * n);
        assert_eq!(triangles.len(), 2 * (n as usize - 1).pow(2));
        inertia_protocol::control::validate_entity(desc).unwrap();
        assert_eq!(pool, flag + 1 + n * n, "the set's points took their ids");
        let ShapeDesc::PointSet { points: room, .. } = t.get(pool).unwrap().desc.shape else {
            panic!("a point set");
        };
        assert!(room as usize >= particles, "its capacity");

        // Every point of both, in id order, where the world has them.
        let states = t.states(&w);
        assert_eq!(states.len(), (n * n) as usize + particles);
        assert!(states.windows(2).all(|s| s[0].id < s[1].id));
        assert_eq!(states[0].id, flag + 1);
        assert_eq!(
            states[5].position,
            w.soft_body(soft).unwrap().positions()[5].as_dvec3()
        );
        assert_eq!(states[(n * n) as usize].id, pool + 1);

        // Saved and restored alike.
        let back = EntityTable::from_bytes(&t.to_bytes()).unwrap();
        assert_eq!(back.catalog(), t.catalog());
        assert_eq!(back.by_soft_body(soft), Some(flag));
        assert_eq!(back.by_fluid(fluid), Some(pool));

        // It tears: described again with fewer triangles, the same points.
        let version = t.version();
        let mut reshaped = 0;
        for _ in 0..600 {
            w.step(1.0 / 60.0).unwrap();
            reshaped += t.reshape_soft_bodies(&w);
            if reshaped > 0 {
                break;
            }
        }
        assert!(reshaped > 0, "the cloth tore");
        assert!(t.version() > version);
        let ShapeDesc::PointSet {
            points: after,
            triangles: fewer,
            ..
        } = &t.get(flag).unwrap().desc.shape
        else {
            panic!("a point set");
        };
        assert_eq!(*after, n * n);
        assert!(fewer.len() < triangles_before(n));
        assert_eq!(t.reshape_soft_bodies(&w), 0, "nothing new: no change");
        // A removed set frees nothing of the ids: the next entity comes
        // after its points still.
        t.remove(flag);
        assert!(t.states(&w).iter().all(|s| s.id > pool));
    }

    fn triangles_before(n: u32) -> usize {
        2 * (n as usize - 1).pow(2)
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
