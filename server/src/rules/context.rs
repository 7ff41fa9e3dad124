//! What the rules may do to the world: [`SimContext`], its caps and its
//! queries at the poses a player saw.

use inertia_physics::glam::DVec3;
use inertia_physics::rigid::body::{BodyKind, RigidBody, RigidBodyDesc};
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::query::{ray_aabb, ray_cast_shape, RayHit};
use inertia_physics::rigid::shape::Shape;
use inertia_physics::{PhysicsError, QueryIndex, World};
use inertia_protocol::{EntityDesc, EntityId, EntityKind};

use crate::pose_history::{KeptPose, PoseHistory, RewindError, Rewound};
use crate::properties::PropertyStore;
use crate::scene::{shape_desc, EntitySource, EntityTable};

use inertia_protocol::message::{check_len, Delivery, GameMessage, MessageRefusal};
use inertia_protocol::property::{PropertyError, PropertyValue};

use super::{ClientId, OutgoingMessage, Recipients};

/// Caps on what rules may do to a body in one call.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ControlLimits {
    /// Largest control force, N.
    pub max_force: f64,
    /// Largest impulse, N·s.
    pub max_impulse: f64,
    /// Largest velocity change one impulse may cause, m/s.
    pub max_delta_v: f64,
}

impl Default for ControlLimits {
    fn default() -> Self {
        Self {
            max_force: 5_000.0,
            max_impulse: 1_000.0,
            max_delta_v: 12.0,
        }
    }
}

/// Why a context call failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum ContextError {
    /// No entity has this id (any more).
    #[error("no entity {0}")]
    UnknownEntity(EntityId),
    /// The entity is a particle, not a body.
    #[error("entity {0} is not a rigid body")]
    NotABody(EntityId),
    /// The engine refused.
    #[error(transparent)]
    Physics(#[from] PhysicsError),
}

/// How a spawned entity looks to clients.
#[derive(Debug, Clone, PartialEq)]
pub struct EntityLook {
    /// What it is.
    pub kind: EntityKind,
    /// RGBA colour.
    pub color: [u8; 4],
    /// The owning client, for avatars.
    pub owner: Option<ClientId>,
    /// A name for tools (≤ 64 bytes).
    pub name: String,
}

/// The world as rules see it during one call.
#[derive(Debug)]
pub struct SimContext<'a> {
    world: &'a mut World,
    entities: &'a mut EntityTable,
    spawn_points: &'a [DVec3],
    messages: &'a mut Vec<OutgoingMessage>,
    properties: &'a mut PropertyStore,
    tick: u64,
    dt: f64,
    limits: ControlLimits,
    /// The bodies in a tree for ray casts, built by the first cast and
    /// dropped whenever a body is added, removed or moved.
    query: std::cell::OnceCell<QueryIndex>,
    /// The moving bodies' recent poses, for queries as a player saw the
    /// world; `None`: queries answer the world as it is.
    poses: Option<&'a PoseHistory>,
    /// Rewound queries asked in this call, and how many were clamped.
    rewinds: std::cell::Cell<RewindCount>,
}

/// Rewound queries asked of a [`SimContext`].
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct RewindCount {
    /// Queries answered at a view tick.
    pub asked: u64,
    /// Of those, views older than the pose window, answered at its oldest
    /// tick.
    pub clamped: u64,
}

/// The parts of a timeline the rules act on through a [`SimContext`].
#[derive(Debug)]
pub struct TimelineParts<'a> {
    /// The world.
    pub world: &'a mut World,
    /// Its entities.
    pub entities: &'a mut EntityTable,
    /// Where avatars may appear, m.
    pub spawn_points: &'a [DVec3],
    /// The game's properties.
    pub properties: &'a mut PropertyStore,
}

impl<'a> SimContext<'a> {
    /// A context over a timeline's `parts` at `tick` (ticks of `dt` s),
    /// the rules' messages going to `messages`.
    pub fn new(
        parts: TimelineParts<'a>,
        messages: &'a mut Vec<OutgoingMessage>,
        tick: u64,
        dt: f64,
        limits: ControlLimits,
    ) -> Self {
        let TimelineParts {
            world,
            entities,
            spawn_points,
            properties,
        } = parts;
        Self {
            world,
            entities,
            spawn_points,
            messages,
            properties,
            tick,
            dt,
            limits,
            query: std::cell::OnceCell::new(),
            poses: None,
            rewinds: std::cell::Cell::new(RewindCount::default()),
        }
    }

    /// The same context, answering rewound queries from `poses`.
    pub fn with_poses(mut self, poses: &'a PoseHistory) -> Self {
        self.poses = Some(poses);
        self
    }

    /// Rewound queries asked so far in this call.
    pub fn rewinds(&self) -> RewindCount {
        self.rewinds.get()
    }

    /// Where a query at the view tick `view_tick` (ticks, fractional) is
    /// answered: within the pose window, clamped to its ends (`clamped`
    /// when older than the window). `Ok(None)` when no poses are kept
    /// (queries then answer the world as it is).
    pub fn rewound(&self, view_tick: f64) -> Result<Option<Rewound>, RewindError> {
        match self.poses {
            Some(p) => p.rewound(view_tick),
            None if view_tick.is_finite() => Ok(None),
            None => Err(RewindError::NotFinite(view_tick)),
        }
    }

    /// The moving bodies at `view_tick`, counted; `None`: none kept.
    fn posed_at(&self, view_tick: f64) -> Result<Option<Vec<KeptPose>>, RewindError> {
        let Some(poses) = self.poses else {
            return self.rewound(view_tick).map(|_| None);
        };
        let mut posed = Vec::new();
        let Some(rewound) = poses.poses_at(view_tick, &mut posed)? else {
            return Ok(None);
        };
        let mut count = self.rewinds.get();
        count.asked += 1;
        count.clamped += u64::from(rewound.clamped);
        self.rewinds.set(count);
        Ok(Some(posed))
    }

    /// An entity's body, if it is still there, solid and shaped.
    fn solid(&self, entity: EntityId) -> Option<&RigidBody> {
        let b = self.world.body(self.entities.body(entity)?)?;
        (!b.is_sensor() && b.shape().is_some()).then_some(b)
    }

    /// [`Self::cast_ray`] against the world as it stood at the view tick
    /// `view_tick` (ticks, fractional; a player's is
    /// [`PlayerInput::view_tick`]): every body that moves is tested at its
    /// pose of then, interpolated between the two ticks around it, and
    /// bodies that did not exist then are not hit; static bodies are
    /// tested as they are. A view older than the pose window is answered
    /// at its oldest tick (counted in
    /// [`SimStats::rewinds_clamped`](crate::sim::SimStats::rewinds_clamped)),
    /// one ahead of the newest at the newest. `origin` m, `dir` need not
    /// be unit, `max_t` in units of `|dir|`, so m for a unit `dir`.
    /// Returns the entity hit (`None` for a static body without one) and
    /// the hit, the point m in the world of then. A ray the engine would
    /// refuse (not finite, zero direction, negative `max_t`) hits nothing.
    ///
    /// # Errors
    /// [`RewindError::NotFinite`] for a NaN or infinite `view_tick`.
    pub fn cast_ray_at(
        &self,
        view_tick: f64,
        origin: DVec3,
        dir: DVec3,
        max_t: f64,
        ignore: Option<EntityId>,
    ) -> Result<Option<(Option<EntityId>, RayHit)>, RewindError> {
        let Some(posed) = self.posed_at(view_tick)? else {
            return Ok(self.cast_ray(origin, dir, max_t, ignore));
        };
        if !(origin.is_finite() && dir.is_finite() && max_t >= 0.0 && dir != DVec3::ZERO) {
            return Ok(None);
        }
        let mut best: Option<(Option<EntityId>, RayHit)> = None;
        for k in posed.iter().filter(|k| Some(k.entity) != ignore) {
            let Some(shape) = self.solid(k.entity).and_then(RigidBody::shape) else {
                continue;
            };
            if ray_aabb(origin, dir, max_t, &shape.aabb(&k.pose).expanded(1e-9)).is_none() {
                continue;
            }
            if let Some(hit) = ray_cast_shape(shape, &k.pose, origin, dir, max_t) {
                if best.is_none_or(|(_, b)| hit.t < b.t) {
                    best = Some((Some(k.entity), hit));
                }
            }
        }
        // Static bodies as they are (skipping any kept as moving then).
        let skip = ignore.and_then(|id| self.entities.body(id));
        let kept = |h| {
            self.entities
                .by_body(h)
                .is_some_and(|id| posed.binary_search_by_key(&id, |k| k.entity).is_ok())
        };
        let reach = best.map_or(max_t, |(_, b)| b.t);
        let index = self.query.get_or_init(|| QueryIndex::build(self.world));
        let still = index
            .cast_ray(self.world, origin, dir, reach, |h, b| {
                Some(h) != skip && b.kind() == BodyKind::Static && !b.is_sensor() && !kept(h)
            })
            .ok()
            .flatten();
        if let Some((h, hit)) = still {
            if best.is_none_or(|(_, b)| hit.t < b.t) {
                best = Some((self.entities.by_body(h), hit));
            }
        }
        Ok(best)
    }

    /// [`Self::overlap_sphere`] against the world as it stood at the view
    /// tick `view_tick` (see [`Self::cast_ray_at`]): entities whose solid
    /// bodies touched a ball of `radius` m at `center` (m) then, sorted by
    /// id.
    ///
    /// # Errors
    /// [`RewindError::NotFinite`] for a NaN or infinite `view_tick`.
    pub fn overlap_sphere_at(
        &self,
        view_tick: f64,
        center: DVec3,
        radius: f64,
    ) -> Result<Vec<EntityId>, RewindError> {
        let Some(posed) = self.posed_at(view_tick)? else {
            return Ok(self.overlap_sphere(center, radius));
        };
        let (Ok(ball), true) = (Shape::sphere(radius), center.is_finite()) else {
            return Ok(Vec::new());
        };
        let at = Pose::from_translation(center);
        let bounds = ball.aabb(&at);
        let mut out = Vec::new();
        for k in &posed {
            let Some(shape) = self.solid(k.entity).and_then(RigidBody::shape) else {
                continue;
            };
            if shape.aabb(&k.pose).intersects(&bounds)
                && inertia_physics::rigid::query::overlap(&ball, &at, shape, &k.pose)
                    .unwrap_or(false)
            {
                out.push(k.entity);
            }
        }
        for id in self.overlap_sphere(center, radius) {
            let still = self.body(id).is_some_and(|b| b.kind() == BodyKind::Static);
            if still && posed.binary_search_by_key(&id, |k| k.entity).is_err() {
                out.push(id);
            }
        }
        out.sort_unstable();
        out.dedup();
        Ok(out)
    }

    /// The tick about to run (in `before_tick`, input and join calls) or
    /// just run (in `after_tick`).
    pub fn tick(&self) -> u64 {
        self.tick
    }

    /// Simulation time per tick, s.
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// The caps on forces and impulses.
    pub fn limits(&self) -> ControlLimits {
        self.limits
    }

    /// Read access to the world.
    pub fn world(&self) -> &World {
        self.world
    }

    /// Read access to the entity table.
    pub fn entities(&self) -> &EntityTable {
        self.entities
    }

    /// Where avatars may appear, m.
    pub fn spawn_points(&self) -> &[DVec3] {
        self.spawn_points
    }

    /// Sets entity property `index` (of the rules' schema,
    /// [`GameRules::properties`](super::GameRules::properties)) of entity
    /// `id`: every client that has the entity in view holds the new value
    /// within a snapshot or two. Refused, changing nothing, for an entity
    /// that is not there, an index the schema lacks or a value not of its
    /// kind.
    pub fn set_property(
        &mut self,
        id: EntityId,
        index: usize,
        value: impl Into<PropertyValue>,
    ) -> Result<(), PropertyError> {
        if self.entities.get(id).is_none() {
            return Err(PropertyError::UnknownEntity(id));
        }
        self.properties.set(id, index, value.into())
    }

    /// Entity property `index` of entity `id` (its default until set).
    pub fn property(&self, id: EntityId, index: usize) -> Result<PropertyValue, PropertyError> {
        if self.entities.get(id).is_none() {
            return Err(PropertyError::UnknownEntity(id));
        }
        self.properties.get(id, index)
    }

    /// Sets match property `index` (the score, the clock, the phase):
    /// every client holds the new value within a snapshot or two. Refused,
    /// changing nothing, as [`Self::set_property`].
    pub fn set_match_property(
        &mut self,
        index: usize,
        value: impl Into<PropertyValue>,
    ) -> Result<(), PropertyError> {
        self.properties.set_match(index, value.into())
    }

    /// Match property `index` (its default until set).
    pub fn match_property(&self, index: usize) -> Result<PropertyValue, PropertyError> {
        self.properties.get_match(index)
    }

    /// Sends a message of the game's to clients: `to` whom, `delivery`
    /// how. It leaves with the frame of this tick (see
    /// [`OutgoingMessage`]). Refused past
    /// [`MAX_MESSAGE_BYTES`](inertia_protocol::message::MAX_MESSAGE_BYTES).
    pub fn send<M: GameMessage>(
        &mut self,
        to: Recipients,
        delivery: Delivery,
        message: &M,
    ) -> Result<(), MessageRefusal> {
        self.send_bytes(to, delivery, message.to_bytes())
    }

    /// [`Self::send`] of bytes already coded.
    pub fn send_bytes(
        &mut self,
        to: Recipients,
        delivery: Delivery,
        bytes: Vec<u8>,
    ) -> Result<(), MessageRefusal> {
        check_len(&bytes)?;
        self.messages.push(OutgoingMessage {
            to,
            delivery,
            bytes,
        });
        Ok(())
    }

    /// The body of an entity.
    pub fn body(&self, id: EntityId) -> Option<&RigidBody> {
        self.world.body(self.entities.body(id)?)
    }

    /// Adds a body and its entity.
    pub fn spawn(
        &mut self,
        desc: &RigidBodyDesc,
        look: EntityLook,
    ) -> Result<EntityId, ContextError> {
        let h = self.world.add_body(desc)?;
        self.query.take();
        let shape = desc
            .shape
            .as_ref()
            .map(shape_desc)
            .unwrap_or(inertia_protocol::ShapeDesc::Sphere { radius: 0.1 });
        Ok(self.entities.insert(
            EntitySource::Body(h),
            EntityDesc {
                id: 0,
                kind: look.kind,
                shape,
                color: look.color,
                owner: look.owner,
                name: look.name,
                position: desc.pose.translation.to_array(),
                rotation: desc.pose.rotation.to_array(),
            },
        ))
    }

    /// Removes an entity and its body or particle; false if unknown.
    pub fn despawn(&mut self, id: EntityId) -> bool {
        let Some(e) = self.entities.remove(id) else {
            return false;
        };
        self.query.take();
        self.properties.forget(id);
        // Already gone from the world is fine: the table was stale.
        let _ = match e.source {
            EntitySource::Body(h) => self.world.remove_body(h),
            EntitySource::Particle(h) => self.world.remove_particle(h),
            EntitySource::SoftBody(h) => self.world.remove_soft_body(h),
            EntitySource::Fluid(h) => self.world.remove_fluid(h),
        };
        true
    }

    fn body_handle(&self, id: EntityId) -> Result<inertia_physics::BodyHandle, ContextError> {
        match self.entities.get(id) {
            None => Err(ContextError::UnknownEntity(id)),
            Some(e) => match e.source {
                EntitySource::Body(h) => Ok(h),
                _ => Err(ContextError::NotABody(id)),
            },
        }
    }

    /// Sets the force (N, world, at the centre of mass) that acts on an
    /// entity's body every tick until changed, capped at
    /// [`ControlLimits::max_force`]. Returns the force applied.
    pub fn set_control_force(&mut self, id: EntityId, force: DVec3) -> Result<DVec3, ContextError> {
        let h = self.body_handle(id)?;
        let force = clamp_length(force, self.limits.max_force);
        self.world.set_body_control(h, force, DVec3::ZERO)?;
        Ok(force)
    }

    /// Applies an impulse (N·s, world) at `point` (m, world), capped at
    /// [`ControlLimits::max_impulse`] and at the impulse that changes the
    /// body's speed by [`ControlLimits::max_delta_v`]. Returns the impulse
    /// applied (zero for bodies that are not dynamic).
    pub fn apply_impulse(
        &mut self,
        id: EntityId,
        impulse: DVec3,
        point: DVec3,
    ) -> Result<DVec3, ContextError> {
        let h = self.body_handle(id)?;
        let Some(b) = self.world.body(h) else {
            return Err(ContextError::UnknownEntity(id));
        };
        if b.kind() != BodyKind::Dynamic {
            return Ok(DVec3::ZERO);
        }
        let cap = self
            .limits
            .max_impulse
            .min(b.mass() * self.limits.max_delta_v);
        let impulse = clamp_length(impulse, cap);
        self.world.apply_body_impulse(h, impulse, point)?;
        Ok(impulse)
    }

    /// Teleports an entity's body (m, world); it is streamed every frame
    /// from now on even if static.
    pub fn set_pose(&mut self, id: EntityId, pose: Pose) -> Result<(), ContextError> {
        let h = self.body_handle(id)?;
        self.query.take();
        self.world.set_body_pose(h, pose)?;
        self.entities.set_always_stream(id);
        Ok(())
    }

    /// Sets an entity's body's velocities (m/s and rad/s, world), capped
    /// as one impulse's change is ([`ControlLimits::max_delta_v`]): what
    /// a teleport that starts at rest pairs with [`Self::set_pose`].
    /// Refused for bodies that are not dynamic or kinematic.
    pub fn set_velocity(
        &mut self,
        id: EntityId,
        linear: DVec3,
        angular: DVec3,
    ) -> Result<(), ContextError> {
        let h = self.body_handle(id)?;
        let linear = clamp_length(linear, self.limits.max_delta_v);
        self.world.set_body_velocity(h, linear, angular)?;
        Ok(())
    }

    /// The nearest hit of a ray (`dir` need not be unit; `max_t` in units of
    /// `|dir|`) on solid bodies, skipping `ignore`. Returns the entity hit
    /// (`None` for a body without one) and the hit. The answer is
    /// [`World::cast_ray`]'s, from a [`QueryIndex`] that the casts of one
    /// call share, so a rule may cast rays for every player every tick.
    pub fn cast_ray(
        &self,
        origin: DVec3,
        dir: DVec3,
        max_t: f64,
        ignore: Option<EntityId>,
    ) -> Option<(Option<EntityId>, RayHit)> {
        let skip = ignore.and_then(|id| self.entities.body(id));
        let index = self.query.get_or_init(|| QueryIndex::build(self.world));
        let (h, hit) = index
            .cast_ray(self.world, origin, dir, max_t, |h, b| {
                Some(h) != skip && !b.is_sensor()
            })
            .ok()??;
        Some((self.entities.by_body(h), hit))
    }

    /// Entities whose solid bodies touch a ball of `radius` m at `center`.
    pub fn overlap_sphere(&self, center: DVec3, radius: f64) -> Vec<EntityId> {
        let Ok(ball) = Shape::sphere(radius) else {
            return Vec::new();
        };
        let Ok(hits) = self
            .world
            .overlap_shape(&ball, Pose::from_translation(center))
        else {
            return Vec::new();
        };
        hits.into_iter()
            .filter(|&h| self.world.body(h).is_some_and(|b| !b.is_sensor()))
            .filter_map(|h| self.entities.by_body(h))
            .collect()
    }

    /// The sensors an entity's body touches now (entities whose sensor
    /// bodies overlap its shape where it stands): how a rule sees a ball
    /// in a goal or a player in a zone. Empty for an entity without a
    /// shaped body.
    pub fn sensors_touching(&self, id: EntityId) -> Vec<EntityId> {
        let Some(b) = self.body(id) else {
            return Vec::new();
        };
        let Some(shape) = b.shape() else {
            return Vec::new();
        };
        let Ok(hits) = self.world.overlap_shape(shape, b.pose()) else {
            return Vec::new();
        };
        hits.into_iter()
            .filter(|&h| self.world.body(h).is_some_and(|b| b.is_sensor()))
            .filter_map(|h| self.entities.by_body(h))
            .filter(|&other| other != id)
            .collect()
    }
}

fn clamp_length(v: DVec3, max: f64) -> DVec3 {
    let len = v.length();
    if len > max && len > 0.0 {
        v * (max / len)
    } else {
        v
    }
}
