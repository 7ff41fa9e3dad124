//! Client-side prediction of the player's own avatar.
//!
//! # The problem
//!
//! Inputs reach the server half a round trip after the player makes them
//! and their effect comes back another half later: at 100 ms RTT an
//! avatar drawn from snapshots answers the stick a tenth of a second (plus
//! the interpolation delay) late. Prediction runs the avatar locally and
//! at once, and treats the server's states as corrections.
//!
//! # How
//!
//! [`Predictor`] owns a small physics world: the own avatar, whose body
//! and controller are the game's ([`AvatarController`]: by default the
//! sandbox's walker, a dynamic capsule built by the same
//! [`WalkSettings`](inertia_physics::character) the server's rules use;
//! a game whose rules move avatars their own way gives its own, which
//! reads the game's input bytes), and what is near it ([`PredictionConfig::
//! neighbour_radius`]): static entities as static bodies and every other
//! moving entity as a kinematic body held at its newest known pose. The
//! SDK stamps one input per tick, ahead of the server (see
//! [`crate::lead`]); each one steps the local world one tick with the
//! controller ([`Predictor::on_input`]), so the avatar answers in
//! the very next frame. The state after each step is kept by tick.
//!
//! A snapshot at tick `T` holds the state after `T` steps, before the
//! input stamped `T` acts ([`Predictor::on_snapshot`]). Its avatar state
//! is compared with the one predicted for `T`: that distance is the
//! correction error. When they disagree beyond quantization, the avatar
//! is put back at the server's state and the inputs `T, T+1, …` are
//! replayed up to the present. Inputs and states older than `T` are
//! forgotten: the server has spoken for them.
//!
//! A replay moves the predicted present; drawing that would jerk the
//! avatar, so the move goes into a [`VisualOffset`] that fades over about
//! 0.1 s, and one as large as a teleport snaps (see [`smoothing`]).
//!
//! # Options not taken
//!
//! Replaying the whole local world (others as dynamic bodies) would need
//! their inputs, which the client does not have; holding them kinematic
//! keeps the avatar from walking through them, which is what a player
//! notices. Rolling back only on a large error would let small errors
//! accumulate into visible ones; the tolerance is set at quantization's
//! size, so a replay happens whenever the server knows better.
//!
//! Nothing here reads a clock or a socket: inputs and snapshots go in,
//! the predicted pose comes out.

mod config;
pub mod controller;
pub mod shape;
pub mod smoothing;
mod stats;

use std::collections::BTreeMap;

pub use config::PredictionConfig;
pub use controller::{AvatarController, ControlStep, SandboxWalker};
use glam::{DQuat, DVec3};
use inertia_physics::character::WalkSettings;
use inertia_physics::rigid::body::RigidBodyDesc;
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::shape::Shape;
use inertia_physics::rigid::solver::SolverConfig;
use inertia_physics::{BodyHandle, PhysicsError, World, WorldConfig};
use inertia_protocol::snapshot::ViewEntity;
use inertia_protocol::{EntityId, EntityKind, PlayerInput};
pub use smoothing::{Fold, VisualOffset};
pub use stats::PredictionStats;

use crate::entities::KnownEntities;
use stats::StatsCollector;

/// Why a [`Predictor`] could not be made.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PredictionError {
    /// The tick rate is zero.
    #[error("the tick rate must be positive")]
    ZeroTickRate,
    /// The engine refused the settings (a non-positive size or mass, bad
    /// gravity or substeps): fix the [`PredictionConfig`].
    #[error("prediction settings: {0}")]
    Settings(#[from] PhysicsError),
    /// The avatar's shape was refused (an [`AvatarController`]'s body).
    #[error("the avatar's shape: {0}")]
    Shape(#[from] inertia_physics::rigid::shape::ShapeError),
}

/// The own avatar as prediction has it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PredictedAvatar {
    /// The avatar entity.
    pub id: EntityId,
    /// The tick predicted: the state after that many server steps.
    pub tick: u64,
    /// Where to draw it, m: the predicted position plus the fading
    /// correction offset.
    pub position: DVec3,
    /// Its orientation.
    pub rotation: DQuat,
    /// The predicted position itself, m (jumps when a correction lands).
    pub predicted: DVec3,
    /// The predicted velocity, m/s.
    pub velocity: DVec3,
    /// The sum of every shift corrections gave the predicted position, m:
    /// the predicted motion between two samples is the change of
    /// `predicted` less the change of this.
    pub corrected: DVec3,
}

/// The avatar and its controller at the start of one tick.
#[derive(Debug, Clone, PartialEq)]
struct TickState {
    position: DVec3,
    rotation: DQuat,
    velocity: DVec3,
    angular_velocity: DVec3,
    /// The controller's memory ([`AvatarController::memory`]).
    memory: Vec<u8>,
}

/// A body in the local world standing for a neighbour.
#[derive(Debug, Clone, Copy)]
struct Neighbour {
    body: BodyHandle,
    moving: bool,
}

/// Predicts the own avatar. See the [module docs](self).
pub struct Predictor {
    config: PredictionConfig,
    client_id: u64,
    /// Tick length, s.
    dt: f64,
    world: World,
    avatar: Option<(EntityId, BodyHandle)>,
    neighbours: BTreeMap<EntityId, Neighbour>,
    /// Each entity's shape, converted once (`None`: it does not collide).
    shapes: BTreeMap<EntityId, Option<(Shape, Pose)>>,
    /// Inputs by tick, from the oldest not yet covered by a snapshot.
    inputs: BTreeMap<u64, PlayerInput>,
    /// Predicted states by tick (start of the tick).
    history: BTreeMap<u64, TickState>,
    /// The tick the local world is at, once the avatar is known.
    present: Option<u64>,
    /// How the game's rules move the avatar.
    controller: Box<dyn AvatarController>,
    offset: VisualOffset,
    corrected: DVec3,
    stats: StatsCollector,
}

impl std::fmt::Debug for Predictor {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Predictor")
            .field("avatar", &self.avatar)
            .field("present", &self.present)
            .field("inputs", &self.inputs.len())
            .field("neighbours", &self.neighbours.len())
            .finish_non_exhaustive()
    }
}

/// The most inputs held: 4 s at 60 Hz. More means no snapshot has come for
/// that long; the oldest go.
const MAX_INPUTS: usize = 240;

impl Predictor {
    /// A predictor for the avatar of `client_id` on a server stepping at
    /// `tick_hz`, walking it as the sandbox's rules do ([`SandboxWalker`]).
    pub fn new(
        config: PredictionConfig,
        client_id: u64,
        tick_hz: u32,
    ) -> Result<Self, PredictionError> {
        let walker = SandboxWalker::new(&config);
        Self::with_controller(config, Box::new(walker), client_id, tick_hz)
    }

    /// A predictor that moves the avatar as `controller` says the game's
    /// rules do (a game's own input and avatar).
    pub fn with_controller(
        config: PredictionConfig,
        controller: Box<dyn AvatarController>,
        client_id: u64,
        tick_hz: u32,
    ) -> Result<Self, PredictionError> {
        if tick_hz == 0 {
            return Err(PredictionError::ZeroTickRate);
        }
        let dt = 1.0 / f64::from(tick_hz);
        let mut world = World::new(WorldConfig {
            threads: 1,
            energy_accounting: false,
            ..WorldConfig::default()
        })?;
        world.set_gravity(config.gravity)?;
        world.set_solver_config(SolverConfig {
            substeps: config.solver_substeps,
            ..SolverConfig::default()
        })?;
        // Checks the body now rather than at the first snapshot.
        controller.body(DVec3::ZERO)?;
        Ok(Self {
            offset: VisualOffset::new(config.smoothing, dt, config.snap_distance),
            config,
            client_id,
            dt,
            world,
            avatar: None,
            neighbours: BTreeMap::new(),
            shapes: BTreeMap::new(),
            inputs: BTreeMap::new(),
            history: BTreeMap::new(),
            present: None,
            controller,
            corrected: DVec3::ZERO,
            stats: StatsCollector::default(),
        })
    }

    /// The settings.
    pub fn config(&self) -> &PredictionConfig {
        &self.config
    }

    /// The walking controller in use.
    pub fn walk(&self) -> &WalkSettings {
        &self.config.walk
    }

    /// Inputs held for replay (those after the newest snapshot's tick).
    pub fn inputs_held(&self) -> usize {
        self.inputs.len()
    }

    /// How the prediction has fared.
    pub fn stats(&self) -> PredictionStats {
        self.stats.stats()
    }

    /// The own avatar as predicted and as to be drawn, once a snapshot has
    /// placed it.
    pub fn avatar(&self) -> Option<PredictedAvatar> {
        let (id, h) = self.avatar?;
        let b = self.world.body(h)?;
        let pose = b.pose();
        Some(PredictedAvatar {
            id,
            tick: self.present?,
            position: pose.translation + self.offset.get(),
            rotation: pose.rotation,
            predicted: pose.translation,
            velocity: b.linear_velocity(),
            corrected: self.corrected,
        })
    }

    /// The input stamped for `input.tick` was made: step the local world
    /// up to the end of that tick (ticks skipped run on the previous
    /// input, as the server does). An input for a tick already predicted
    /// is kept for the next replay.
    pub fn on_input(&mut self, input: &PlayerInput) {
        self.inputs.insert(input.tick, *input);
        while self.inputs.len() > MAX_INPUTS {
            self.inputs.pop_first();
        }
        let Some(present) = self.present else { return };
        if input.tick < present {
            return;
        }
        for t in present..=input.tick {
            self.step(t);
            let step = self.offset.decay();
            self.stats.on_visual_step(step);
        }
    }

    /// A snapshot of `tick` arrived with the states in `updated` (those it
    /// carried); `entities` is the entity table after it. Updates the
    /// neighbours, and compares the avatar with its prediction, rolling
    /// back and replaying when they disagree.
    pub fn on_snapshot(&mut self, tick: u64, updated: &[ViewEntity], entities: &KnownEntities) {
        let own = entities.iter().find(|(_, e)| {
            e.desc.kind == EntityKind::Avatar && e.desc.owner == Some(self.client_id)
        });
        let Some((own_id, _)) = own else {
            self.forget_avatar();
            return;
        };
        if self.avatar.is_some_and(|(id, _)| id != own_id) {
            // Respawned: a new body, wherever it is.
            self.forget_avatar();
        }
        let state = updated.iter().find(|s| s.id == own_id);
        self.sync_neighbours(own_id, entities, state.map(|s| s.position));
        let Some(state) = state else { return };
        let velocity = state.linear_velocity.unwrap_or(DVec3::ZERO);
        match self.present {
            None => {
                if self.place_avatar(own_id, state).is_err() {
                    return;
                }
                self.controller.recall(&[]);
                self.rollback(tick, state);
            }
            Some(present) => {
                let Some(predicted) = self.history.get(&tick).cloned() else {
                    if tick > present {
                        // The server is ahead of what was predicted (no
                        // inputs for a while): start again from its state.
                        self.rollback(tick, state);
                    }
                    return;
                };
                let error = (predicted.position - state.position).length();
                self.stats.on_error(error);
                let dv = (predicted.velocity - velocity).length();
                if error > self.config.tolerance || dv > self.config.velocity_tolerance {
                    self.controller.recall(&predicted.memory);
                    self.rollback(tick, state);
                }
            }
        }
        // The server has spoken for everything before `tick`.
        self.inputs = self.inputs.split_off(&tick);
        self.history = self.history.split_off(&tick);
    }

    /// The server's timeline broke (seek, rewind): predict afresh from the
    /// next snapshot.
    pub fn reset(&mut self) {
        self.forget_avatar();
        self.inputs.clear();
    }

    fn forget_avatar(&mut self) {
        if let Some((_, h)) = self.avatar.take() {
            let _ = self.world.remove_body(h);
        }
        self.present = None;
        self.history.clear();
        self.offset.clear();
    }

    fn place_avatar(&mut self, id: EntityId, state: &ViewEntity) -> Result<(), PredictionError> {
        let h = self
            .world
            .add_body(&self.controller.body(state.position)?)?;
        self.avatar = Some((id, h));
        Ok(())
    }

    /// Puts the avatar at the server's state of `tick` (the controller
    /// state is already the one predicted for `tick`) and replays the
    /// inputs from there up to the present; the change of the predicted
    /// present goes to the visual offset.
    fn rollback(&mut self, tick: u64, state: &ViewEntity) {
        let Some((_, h)) = self.avatar else { return };
        let before = self.world.body(h).map(|b| b.pose().translation);
        let pose = Pose {
            translation: state.position,
            rotation: state.rotation,
        };
        let velocity = state.linear_velocity.unwrap_or(DVec3::ZERO);
        if self.world.set_body_pose(h, pose).is_err()
            || self
                .world
                .set_body_velocity(h, velocity, state.angular_velocity.unwrap_or(DVec3::ZERO))
                .is_err()
        {
            return;
        }
        let end = match self.present {
            Some(present) => present.max(tick),
            None => self
                .inputs
                .last_key_value()
                .map_or(tick, |(&t, _)| (t + 1).max(tick)),
        };
        let replaying = self.present.is_some();
        self.history.clear();
        self.history.insert(tick, self.capture(h));
        self.present = Some(tick);
        for t in tick..end {
            self.step(t);
        }
        if replaying {
            self.stats.stats.corrections += 1;
            if let (Some(before), Some(after)) =
                (before, self.world.body(h).map(|b| b.pose().translation))
            {
                let shift = after - before;
                self.corrected += shift;
                if let Fold::Snapped(_) = self.offset.fold(shift) {
                    self.stats.stats.teleports += 1;
                }
            }
        }
    }

    fn capture(&self, h: BodyHandle) -> TickState {
        let b = self.world.body(h);
        TickState {
            position: b.map_or(DVec3::ZERO, |b| b.pose().translation),
            rotation: b.map_or(DQuat::IDENTITY, |b| b.pose().rotation),
            velocity: b.map_or(DVec3::ZERO, |b| b.linear_velocity()),
            angular_velocity: b.map_or(DVec3::ZERO, |b| b.angular_velocity()),
            memory: self.controller.memory(),
        }
    }

    /// Runs tick `t` (from the present, which must be `t`): the input
    /// stamped `t` (or the one before it) through the controller, then
    /// one world step.
    fn step(&mut self, t: u64) {
        let Some((_, h)) = self.avatar else { return };
        let input = self
            .inputs
            .range(..=t)
            .next_back()
            .map(|(_, i)| *i)
            .unwrap_or_default();
        self.controller.control(ControlStep {
            world: &mut self.world,
            avatar: h,
            input: &input.payload,
            tick: t,
            dt: self.dt,
        });
        if self.world.step(self.dt).is_err() {
            return;
        }
        self.present = Some(t + 1);
        let state = self.capture(h);
        self.history.insert(t + 1, state);
    }

    /// Puts what lies within the neighbour radius of the avatar (at `near`,
    /// or where it is predicted) in the local world, moving ones at their
    /// newest poses, and takes out what left.
    fn sync_neighbours(&mut self, own: EntityId, entities: &KnownEntities, near: Option<DVec3>) {
        let Some(center) = near.or_else(|| self.avatar().map(|a| a.predicted)) else {
            return;
        };
        let reach = self.config.neighbour_radius;
        let gone: Vec<EntityId> = self
            .neighbours
            .keys()
            .copied()
            .filter(|id| !entities.contains(*id))
            .collect();
        for id in gone {
            if let Some(n) = self.neighbours.remove(&id) {
                let _ = self.world.remove_body(n.body);
            }
        }
        self.shapes.retain(|&id, _| entities.contains(id));
        for (id, e) in entities.iter() {
            if id == own {
                continue;
            }
            let moving = match e.desc.kind {
                EntityKind::Static => false,
                EntityKind::Dynamic | EntityKind::Kinematic | EntityKind::Avatar => true,
                EntityKind::Water | EntityKind::SoftBody | EntityKind::Fluid => continue,
            };
            let Some((shape, local)) = self
                .shapes
                .entry(id)
                .or_insert_with(|| shape::shape_of(&e.desc.shape).ok().flatten())
                .clone()
            else {
                continue;
            };
            let at = Pose {
                translation: e.position(),
                rotation: e.rotation(),
            }
            .mul(&local);
            let near = distance_to(&shape.aabb(&at), center);
            match self.neighbours.get(&id).copied() {
                Some(n) if near > 2.0 * reach => {
                    let _ = self.world.remove_body(n.body);
                    self.neighbours.remove(&id);
                }
                Some(n) if n.moving => {
                    let _ = self.world.set_body_pose(n.body, at);
                }
                Some(_) => {}
                None if near <= reach => {
                    let desc = if moving {
                        RigidBodyDesc::kinematic(shape, at)
                    } else {
                        RigidBodyDesc::fixed(shape, at)
                    };
                    if let Ok(body) = self.world.add_body(&desc) {
                        self.neighbours.insert(id, Neighbour { body, moving });
                    }
                }
                None => {}
            }
        }
    }
}

/// Distance from `p` to a box, m (0 inside).
fn distance_to(b: &inertia_physics::rigid::aabb::Aabb, p: DVec3) -> f64 {
    (b.min - p).max(p - b.max).max(DVec3::ZERO).length()
}

#[cfg(test)]
mod tests;
