//! Game rules: what players may do to the world.
//!
//! The tick thread calls a [`GameRules`] implementation at fixed points —
//! a client joins or leaves, an input arrives, before and after every tick
//! — and hands it a [`SimContext`]: controlled access to the world and the
//! entity table. Rules spawn and despawn entities and push bodies through
//! the context, which caps every force and impulse at its
//! [`ControlLimits`], so no rule (and no input it forwards) can launch a
//! body at absurd speed.
//!
//! Inputs come from the network and are untrusted: [`validate_input`]
//! refuses NaN and infinities and inputs for ticks outside a window around
//! now, and clamps the rest (movement length ≤ 1, yaw wrapped to ±π,
//! unknown button bits cleared). [`SandboxRules`] is the default game: a
//! capsule avatar per client, moved by a capped control force towards the
//! desired velocity, a jump only when standing on something, and a push
//! for whatever is in front.
//!
//! Rules may answer an input against the world as its player saw it (lag
//! compensation): [`SimContext::cast_ray_at`] and
//! [`SimContext::overlap_sphere_at`] take the input's
//! [`PlayerInput::view_tick`] and test the moving bodies at their poses
//! of that tick, kept by the simulation's
//! [`PoseHistory`](crate::sim::PoseHistory) for as long as the rules ask
//! ([`GameRules::rewind_window_ms`]); static bodies are tested as they
//! are.

use std::collections::BTreeMap;
use std::f64::consts::PI;

use inertia_physics::character::{self, WalkSettings};
use inertia_physics::glam::DVec3;
use inertia_physics::rigid::body::{BodyKind, RigidBody, RigidBodyDesc};
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::query::{ray_aabb, ray_cast_shape, RayHit};
use inertia_physics::rigid::shape::Shape;
use inertia_physics::{PhysicsError, QueryIndex, World};
use inertia_protocol::entity::buttons;
use inertia_protocol::input::MAX_VIEW_BEHIND;
use inertia_protocol::{EntityDesc, EntityId, EntityKind, PlayerInput};

use crate::scene::{shape_desc, EntitySource, EntityTable};
use crate::sim::{KeptPose, PoseHistory, RewindError, Rewound};

/// A connected client, as the network layer numbers it.
pub type ClientId = u64;

/// Why a client may not join.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Refusal {
    /// The server holds its maximum number of clients.
    #[error("server full ({max} clients)")]
    Full {
        /// The maximum.
        max: u32,
    },
    /// This client id is already in the game.
    #[error("client {0} has already joined")]
    AlreadyJoined(ClientId),
    /// No free place to put an avatar.
    #[error("no room to spawn an avatar")]
    NoRoom,
    /// The simulation is shutting down or not answering.
    #[error("the simulation is not running")]
    Unavailable,
    /// The rules refused, for their own reason.
    #[error("{0}")]
    Rules(String),
}

/// Why an input was refused (it is then ignored; the client's previous
/// input stays in force).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum InputError {
    /// The client has not joined.
    #[error("client {0} has not joined")]
    NotJoined(ClientId),
    /// A field was NaN or infinite.
    #[error("input field {0} is not a finite number")]
    NonFinite(&'static str),
    /// Meant for a tick too long ago.
    #[error("input for tick {tick} is too old (now {now})")]
    Stale {
        /// The input's tick.
        tick: u64,
        /// The server's tick.
        now: u64,
    },
    /// Meant for a tick too far ahead.
    #[error("input for tick {tick} is too far ahead (now {now})")]
    Future {
        /// The input's tick.
        tick: u64,
        /// The server's tick.
        now: u64,
    },
    /// The client already has as many inputs waiting for their ticks as
    /// the server holds.
    #[error("the client has {max} inputs waiting already")]
    Backlog {
        /// The most held per client.
        max: usize,
    },
    /// Not newer than the last accepted input (duplicate or reordered).
    #[error("input sequence {sequence} is not after {last}")]
    OutOfOrder {
        /// The input's sequence number.
        sequence: u32,
        /// The last accepted one.
        last: u32,
    },
}

/// How far an input's tick may lie from the server's.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct InputWindow {
    /// Ticks into the past (default 120: 2 s at 60 Hz).
    pub past: u64,
    /// Ticks into the future (default 60: 1 s at 60 Hz).
    pub future: u64,
}

impl Default for InputWindow {
    fn default() -> Self {
        Self {
            past: 120,
            future: 60,
        }
    }
}

/// Checks and clamps one input against the server tick `now`: NaN or
/// infinite fields and ticks outside `window` are refused; movement is
/// clamped to [−1, 1] per axis and length 1, yaw wrapped into (−π, π], and
/// undefined button bits cleared.
///
/// The view offset ([`PlayerInput::view_behind`]) is clamped, never
/// refused, so a bad view costs the player the compensation of that one
/// input, not its movement: NaN, infinite or negative (a view ahead of the
/// input's tick) becomes 0, "the world as it is"; more than
/// [`MAX_VIEW_BEHIND`] becomes that. The rewind itself is capped later, by
/// the pose window ([`SimContext::cast_ray_at`]), which knows how far back
/// the server keeps poses.
pub fn validate_input(
    input: &PlayerInput,
    now: u64,
    window: InputWindow,
) -> Result<PlayerInput, InputError> {
    let [mx, mz] = input.movement;
    if !(mx.is_finite() && mz.is_finite()) {
        return Err(InputError::NonFinite("movement"));
    }
    if !input.yaw.is_finite() {
        return Err(InputError::NonFinite("yaw"));
    }
    if input.tick.saturating_add(window.past) < now {
        return Err(InputError::Stale {
            tick: input.tick,
            now,
        });
    }
    if input.tick > now.saturating_add(window.future) {
        return Err(InputError::Future {
            tick: input.tick,
            now,
        });
    }
    let (mut mx, mut mz) = (mx.clamp(-1.0, 1.0), mz.clamp(-1.0, 1.0));
    let len = (mx * mx + mz * mz).sqrt();
    if len > 1.0 {
        mx /= len;
        mz /= len;
    }
    let yaw = f64::from(input.yaw);
    let mut yaw = (yaw + PI).rem_euclid(2.0 * PI) - PI;
    if yaw <= -PI {
        yaw += 2.0 * PI;
    }
    Ok(PlayerInput {
        sequence: input.sequence,
        tick: input.tick,
        movement: [mx, mz],
        yaw: yaw as f32,
        buttons: input.buttons & buttons::ALL,
        view_behind: if input.view_behind.is_finite() && input.view_behind > 0.0 {
            input.view_behind.min(MAX_VIEW_BEHIND)
        } else {
            0.0
        },
    })
}

/// Why something happened to an entity without anyone asking.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RemovalReason {
    /// It left the world bounds.
    OutOfBounds,
    /// Its state went non-finite.
    Quarantined,
    /// The rules removed it.
    Despawned,
}

/// Something clients may want to show: sent reliably with the frame of the
/// tick it happened in.
#[derive(Debug, Clone, PartialEq)]
pub enum GameEvent {
    /// A client joined and got an avatar.
    Joined {
        /// The client.
        client: ClientId,
        /// Its avatar.
        avatar: EntityId,
    },
    /// A client left.
    Left {
        /// The client.
        client: ClientId,
    },
    /// A client's avatar was lost (fell off the world) and made anew.
    Respawned {
        /// The client.
        client: ClientId,
        /// The new avatar.
        avatar: EntityId,
    },
    /// An avatar jumped.
    Jumped {
        /// The avatar.
        avatar: EntityId,
    },
    /// An avatar pushed a body.
    Pushed {
        /// The avatar.
        avatar: EntityId,
        /// What it pushed.
        target: EntityId,
        /// The impulse given, N·s.
        impulse: [f64; 3],
    },
    /// An entity was removed by the simulation.
    Removed {
        /// The entity (its id is never reused).
        entity: EntityId,
        /// Why.
        reason: RemovalReason,
    },
    /// A game-specific event.
    Custom {
        /// What happened.
        name: String,
        /// The entity concerned, if any.
        entity: Option<EntityId>,
    },
}

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
    events: &'a mut Vec<GameEvent>,
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

impl<'a> SimContext<'a> {
    /// A context over `world` and `entities` at `tick` (ticks of `dt` s).
    pub fn new(
        world: &'a mut World,
        entities: &'a mut EntityTable,
        spawn_points: &'a [DVec3],
        events: &'a mut Vec<GameEvent>,
        tick: u64,
        dt: f64,
        limits: ControlLimits,
    ) -> Self {
        Self {
            world,
            entities,
            spawn_points,
            events,
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

    /// Reports an event to clients.
    pub fn emit(&mut self, event: GameEvent) {
        self.events.push(event);
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
}

fn clamp_length(v: DVec3, max: f64) -> DVec3 {
    let len = v.length();
    if len > max && len > 0.0 {
        v * (max / len)
    } else {
        v
    }
}

/// What a game does with players. Called on the tick thread only, in this
/// order each loop: joins and leaves, inputs, then per tick `before_tick`,
/// the physics step, `after_tick`, and `events`.
pub trait GameRules: Send {
    /// A client joins: make its avatar and return its entity id, or refuse.
    fn on_connect(
        &mut self,
        client: ClientId,
        ctx: &mut SimContext<'_>,
    ) -> Result<EntityId, Refusal>;

    /// A client left (or was dropped): clean up after it.
    fn on_disconnect(&mut self, client: ClientId, ctx: &mut SimContext<'_>);

    /// An input arrived. Validate it (see [`validate_input`]) before acting
    /// on any field; a refused input changes nothing.
    fn on_input(
        &mut self,
        client: ClientId,
        input: &PlayerInput,
        ctx: &mut SimContext<'_>,
    ) -> Result<(), InputError>;

    /// How far back these rules look when they answer an input against
    /// the world the player saw (`SimContext::cast_ray_at` and
    /// `overlap_sphere_at`), ms: the server keeps the moving bodies' poses
    /// that long (capped by `SimConfig::max_rewind_ms`), and carries them
    /// in every saved state. Rules that never look back keep the default,
    /// 0, and pay nothing; a shooter asks for about 500 (a view lags its
    /// input's tick by a round trip, the input's margin and the client's
    /// interpolation delay).
    fn rewind_window_ms(&self) -> u32 {
        0
    }

    /// Before each physics step: turn the latest inputs into forces.
    fn before_tick(&mut self, _ctx: &mut SimContext<'_>) {}

    /// After each physics step.
    fn after_tick(&mut self, _ctx: &mut SimContext<'_>) {}

    /// An orchestrator allocated this server for a match with `settings`
    /// (Agones: the allocation's labels and annotations, see
    /// [`crate::orchestrator::allocation`]): set the rules variant and seed
    /// the match's random choices. Called on the tick thread, after the
    /// allocation's scene (if any) is loaded and before the match's
    /// players join. An error is logged and changes nothing the rules did
    /// not. Rules with no variants and no randomness keep the default.
    fn configure_match(
        &mut self,
        _settings: &crate::orchestrator::MatchSettings,
        _ctx: &mut SimContext<'_>,
    ) -> Result<(), String> {
        Ok(())
    }

    /// Whether the game is over, and why (for the players, at most
    /// [`MAX_REASON_BYTES`](inertia_protocol::control::MAX_REASON_BYTES)):
    /// asked after each live tick; once it says so, the server drains,
    /// telling every client `MatchOver` with the reason, and stops. Rules
    /// that never end a match keep the default.
    fn match_over(&self) -> Option<String> {
        None
    }

    /// Events the rules gathered since the last call (drained).
    fn events(&mut self) -> Vec<GameEvent> {
        Vec::new()
    }

    /// Everything the rules remember between ticks (players, their latest
    /// inputs, cooldowns, scores), as bytes. Keyframes and checkpoints
    /// carry it, and seeking, `--resume` and `load` re-simulate from it,
    /// so state left out here makes re-simulation differ from the
    /// recording. Rules that remember nothing keep the default (empty).
    fn save_state(&self) -> Vec<u8> {
        Vec::new()
    }

    /// Replaces the rules' state with one from [`GameRules::save_state`].
    /// On error nothing changes.
    fn restore_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        if bytes.is_empty() {
            Ok(())
        } else {
            Err(format!(
                "these rules keep no state, but {} bytes were given",
                bytes.len()
            ))
        }
    }
}

/// Tuning of [`SandboxRules`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SandboxSettings {
    /// The avatar's capsule and how it walks and jumps (the SDK's
    /// prediction walks it with the same settings).
    pub walk: WalkSettings,
    /// How far in front a push reaches, m.
    pub push_reach: f64,
    /// Impulse of a push, N·s (capped by the context's limits).
    pub push_impulse: f64,
    /// Least time between pushes, s.
    pub push_cooldown: f64,
    /// How far input ticks may stray from the server's.
    pub input_window: InputWindow,
}

impl Default for SandboxSettings {
    fn default() -> Self {
        Self {
            walk: WalkSettings::default(),
            push_reach: 1.5,
            push_impulse: 400.0,
            push_cooldown: 0.4,
            input_window: InputWindow::default(),
        }
    }
}

/// One client in the sandbox (saved with the rules' state: field order is
/// the format).
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
struct Player {
    avatar: EntityId,
    /// The latest accepted (clamped) input.
    input: PlayerInput,
    last_sequence: Option<u32>,
    /// Buttons of the previous input, for press edges.
    held: u8,
    /// A jump (push) was pressed since the last tick.
    jump_pressed: bool,
    push_pressed: bool,
    /// No jump (push) before this tick.
    jump_ready_at: u64,
    push_ready_at: u64,
}

/// The default game: every client walks a capsule avatar around the scene,
/// jumps, and pushes things.
#[derive(Debug, Default)]
pub struct SandboxRules {
    settings: SandboxSettings,
    players: BTreeMap<ClientId, Player>,
    events: Vec<GameEvent>,
}

impl SandboxRules {
    /// Sandbox rules with `settings`.
    pub fn new(settings: SandboxSettings) -> Self {
        Self {
            settings,
            players: BTreeMap::new(),
            events: Vec::new(),
        }
    }

    /// The avatar of a client.
    pub fn avatar(&self, client: ClientId) -> Option<EntityId> {
        self.players.get(&client).map(|p| p.avatar)
    }

    fn avatar_desc(&self, at: DVec3) -> Result<RigidBodyDesc, Refusal> {
        self.settings
            .walk
            .body_desc(at)
            .map_err(|e| Refusal::Rules(e.to_string()))
    }

    fn spawn_avatar(
        &self,
        client: ClientId,
        ctx: &mut SimContext<'_>,
    ) -> Result<EntityId, Refusal> {
        let s = &self.settings;
        let half = s.walk.half_height + s.walk.radius;
        let shape = Shape::capsule(s.walk.half_height, s.walk.radius)
            .map_err(|e| Refusal::Rules(e.to_string()))?;
        // The first spawn point with nothing in the way; then the same
        // points lifted by one avatar height at a time.
        let mut place = None;
        'search: for lift in 0..4 {
            for &p in ctx.spawn_points() {
                let at = p + DVec3::Y * (lift as f64 * (2.0 * half + 0.1));
                let free = ctx
                    .world()
                    .overlap_shape(&shape, Pose::from_translation(at))
                    .map(|hits| {
                        hits.iter()
                            .all(|&h| ctx.world().body(h).is_some_and(|b| b.is_sensor()))
                    })
                    .unwrap_or(false);
                if free {
                    place = Some(at);
                    break 'search;
                }
            }
        }
        let at = place.ok_or(Refusal::NoRoom)?;
        let desc = self.avatar_desc(at)?;
        let palette = [
            [66, 133, 244, 255],
            [219, 68, 55, 255],
            [244, 180, 0, 255],
            [15, 157, 88, 255],
            [171, 71, 188, 255],
        ];
        ctx.spawn(
            &desc,
            EntityLook {
                kind: EntityKind::Avatar,
                color: palette[(client % palette.len() as u64) as usize],
                owner: Some(client),
                name: format!("avatar {client}"),
            },
        )
        .map_err(|e| Refusal::Rules(e.to_string()))
    }

    /// Whether the avatar stands on something: rays from its centre down
    /// to a little below its feet hit a solid body (see
    /// [`WalkSettings::grounded`]).
    fn grounded(&self, avatar: EntityId, ctx: &SimContext<'_>) -> bool {
        let Some(b) = ctx.body(avatar) else {
            return false;
        };
        self.settings
            .walk
            .grounded(b.center_of_mass(), |from, dir, reach| {
                ctx.cast_ray(from, dir, reach, Some(avatar)).is_some()
            })
    }

    fn drive(&mut self, client: ClientId, ctx: &mut SimContext<'_>) {
        let s = self.settings;
        let Some(p) = self.players.get_mut(&client) else {
            return;
        };
        let avatar = p.avatar;
        let (jump, push) = (
            std::mem::take(&mut p.jump_pressed),
            std::mem::take(&mut p.push_pressed),
        );
        let input = p.input;
        let Some(b) = ctx.body(avatar) else { return };
        let (v, com) = (b.linear_velocity(), b.center_of_mass());
        let grounded = self.grounded(avatar, ctx);
        let Some(p) = self.players.get_mut(&client) else {
            return;
        };

        // Walk: a force towards the desired horizontal velocity.
        let walk = s.walk;
        let _ = ctx.set_control_force(avatar, walk.walk_force(input.movement, v, grounded));

        let tick = ctx.tick();
        let dt = ctx.dt();
        if let Some(j) = walk.jump(jump, grounded, tick, p.jump_ready_at, v, dt) {
            if ctx.apply_impulse(avatar, j.impulse, com).is_ok() {
                p.jump_ready_at = j.ready_at;
                ctx.emit(GameEvent::Jumped { avatar });
            }
        }
        if push && tick >= p.push_ready_at {
            p.push_ready_at = tick + character::ticks(s.push_cooldown, dt);
            let yaw = f64::from(input.yaw);
            let facing = DVec3::new(yaw.sin(), 0.0, yaw.cos());
            let radius = s.push_reach * 0.5;
            let center = com + facing * (s.walk.radius + radius);
            for target in ctx.overlap_sphere(center, radius) {
                if target == avatar {
                    continue;
                }
                let Some(tb) = ctx.body(target) else { continue };
                if tb.kind() != BodyKind::Dynamic {
                    continue;
                }
                let at = tb.center_of_mass();
                let dir = (facing + DVec3::Y * 0.2).normalize();
                if let Ok(given) = ctx.apply_impulse(target, dir * s.push_impulse, at) {
                    ctx.emit(GameEvent::Pushed {
                        avatar,
                        target,
                        impulse: given.to_array(),
                    });
                }
            }
        }
    }
}

impl GameRules for SandboxRules {
    fn on_connect(
        &mut self,
        client: ClientId,
        ctx: &mut SimContext<'_>,
    ) -> Result<EntityId, Refusal> {
        if self.players.contains_key(&client) {
            return Err(Refusal::AlreadyJoined(client));
        }
        let avatar = self.spawn_avatar(client, ctx)?;
        self.players.insert(
            client,
            Player {
                avatar,
                input: PlayerInput::default(),
                last_sequence: None,
                held: 0,
                jump_pressed: false,
                push_pressed: false,
                jump_ready_at: 0,
                push_ready_at: 0,
            },
        );
        self.events.push(GameEvent::Joined { client, avatar });
        Ok(avatar)
    }

    fn on_disconnect(&mut self, client: ClientId, ctx: &mut SimContext<'_>) {
        if let Some(p) = self.players.remove(&client) {
            ctx.despawn(p.avatar);
            self.events.push(GameEvent::Left { client });
        }
    }

    fn on_input(
        &mut self,
        client: ClientId,
        input: &PlayerInput,
        ctx: &mut SimContext<'_>,
    ) -> Result<(), InputError> {
        let p = self
            .players
            .get_mut(&client)
            .ok_or(InputError::NotJoined(client))?;
        let input = validate_input(input, ctx.tick(), self.settings.input_window)?;
        if let Some(last) = p.last_sequence {
            // Wrapping comparison: newer means ahead by less than half the
            // sequence space.
            if input.sequence.wrapping_sub(last) == 0
                || input.sequence.wrapping_sub(last) > u32::MAX / 2
            {
                return Err(InputError::OutOfOrder {
                    sequence: input.sequence,
                    last,
                });
            }
        }
        let pressed = input.buttons & !p.held;
        p.jump_pressed |= pressed & buttons::JUMP != 0;
        p.push_pressed |= pressed & buttons::PUSH != 0;
        p.held = input.buttons;
        p.last_sequence = Some(input.sequence);
        p.input = input;
        Ok(())
    }

    fn before_tick(&mut self, ctx: &mut SimContext<'_>) {
        let clients: Vec<ClientId> = self.players.keys().copied().collect();
        for client in clients {
            let lost = self
                .players
                .get(&client)
                .is_some_and(|p| ctx.entities().get(p.avatar).is_none());
            if lost {
                match self.spawn_avatar(client, ctx) {
                    Ok(avatar) => {
                        if let Some(p) = self.players.get_mut(&client) {
                            p.avatar = avatar;
                        }
                        self.events.push(GameEvent::Respawned { client, avatar });
                    }
                    // No room this tick: try again next tick.
                    Err(_) => continue,
                }
            }
            self.drive(client, ctx);
        }
    }

    fn events(&mut self) -> Vec<GameEvent> {
        std::mem::take(&mut self.events)
    }

    fn save_state(&self) -> Vec<u8> {
        postcard::to_allocvec(&self.players).unwrap_or_default()
    }

    fn restore_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        let players: BTreeMap<ClientId, Player> =
            postcard::from_bytes(bytes).map_err(|e| format!("sandbox players: {e}"))?;
        self.players = players;
        self.events.clear();
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn input(movement: [f32; 2], yaw: f32, buttons: u8) -> PlayerInput {
        PlayerInput {
            sequence: 1,
            tick: 100,
            movement,
            yaw,
            buttons,
            view_behind: 0.0,
        }
    }

    #[test]
    fn non_finite_input_is_refused() {
        let w = InputWindow::default();
        for bad in [
            input([f32::NAN, 0.0], 0.0, 0),
            input([0.0, f32::INFINITY], 0.0, 0),
            input([0.0, 0.0], f32::NAN, 0),
            input([0.0, 0.0], f32::NEG_INFINITY, 0),
        ] {
            assert!(matches!(
                validate_input(&bad, 100, w),
                Err(InputError::NonFinite(_))
            ));
        }
    }

    #[test]
    fn huge_input_is_clamped() {
        let w = InputWindow::default();
        let v = validate_input(&input([1e30, -1e30], 1e9, 0xff), 100, w).unwrap();
        let len = (v.movement[0].powi(2) + v.movement[1].powi(2)).sqrt();
        assert!((len - 1.0).abs() < 1e-6, "{v:?}");
        assert!(v.yaw.abs() <= std::f32::consts::PI + 1e-6);
        assert_eq!(v.buttons, buttons::ALL);
        let v = validate_input(&input([0.3, 0.4], 0.5, 0), 100, w).unwrap();
        assert_eq!(v.movement, [0.3, 0.4]);
        assert_eq!(v.yaw, 0.5);
    }

    #[test]
    fn bad_views_are_clamped_not_refused() {
        let w = InputWindow::default();
        let view = |view_behind| {
            validate_input(
                &PlayerInput {
                    view_behind,
                    ..input([0.5, 0.0], 0.0, 0)
                },
                100,
                w,
            )
            .map(|v| (v.view_behind, v.movement))
        };
        for (bad, want) in [
            (f32::NAN, 0.0),
            (f32::INFINITY, 0.0),
            (f32::NEG_INFINITY, 0.0),
            // Ahead of the input's own tick.
            (-3.0, 0.0),
            (-0.0, 0.0),
            (1e9, MAX_VIEW_BEHIND),
            (6.5, 6.5),
        ] {
            assert_eq!(view(bad), Ok((want, [0.5, 0.0])), "{bad}");
        }
        let v = validate_input(
            &PlayerInput {
                view_behind: 2.5,
                ..input([0.0, 0.0], 0.0, 0)
            },
            100,
            w,
        )
        .unwrap();
        assert_eq!(v.view_tick(), 97.5);
    }

    #[test]
    fn inputs_outside_the_tick_window_are_refused() {
        let w = InputWindow {
            past: 10,
            future: 5,
        };
        let at = |tick| PlayerInput {
            tick,
            ..PlayerInput::default()
        };
        assert!(validate_input(&at(90), 100, w).is_ok());
        assert!(validate_input(&at(105), 100, w).is_ok());
        assert!(matches!(
            validate_input(&at(89), 100, w),
            Err(InputError::Stale { .. })
        ));
        assert!(matches!(
            validate_input(&at(106), 100, w),
            Err(InputError::Future { .. })
        ));
        assert!(validate_input(&at(u64::MAX), u64::MAX - 1, w).is_ok());
    }
}
