//! A [`NeutralScene`] built into an `inertia_physics::World`.
//!
//! Gravity is set explicitly (the world's gravity is zero until set), the
//! solver runs [`SOLVER_ITERATIONS`] substeps, and sleeping
//! is switched on or off for the whole world (`SolverConfig::sleep.enabled`)
//! and for every body (`can_sleep`). Friction is one coefficient used as
//! both the static and the dynamic one.

use inertia_physics::glam::{DQuat, DVec3};
use inertia_physics::rigid::body::{BodyKind, RigidBodyDesc};
use inertia_physics::rigid::contact::ManifoldCount;
use inertia_physics::rigid::joint::{JointDesc, JointKind};
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::shape::Shape;
use inertia_physics::rigid::solver::SolverConfig;
use inertia_physics::{BodyHandle, World, WorldConfig};

use super::scene::{NeutralJointKind, NeutralKind, NeutralScene, NeutralShape};
use super::{Engine, GRAVITY, SOLVER_ITERATIONS};
use crate::BenchError;

/// Our world with the handles of the scene's dynamic bodies.
#[derive(Debug)]
pub struct Ours {
    world: World,
    /// Handles of the dynamic bodies, in scene order.
    dynamic: Vec<BodyHandle>,
    dt: f64,
    quarantined: usize,
    /// Shape pairs collided and manifolds used again, over every step.
    manifolds: ManifoldCount,
}

fn shape(s: &NeutralShape) -> Result<Shape, BenchError> {
    Ok(match s {
        NeutralShape::Sphere { radius } => Shape::sphere(*radius)?,
        NeutralShape::Cuboid { half_extents } => Shape::cuboid(*half_extents)?,
        NeutralShape::Capsule {
            half_height,
            radius,
        } => Shape::capsule(*half_height, *radius)?,
        NeutralShape::Cylinder {
            half_height,
            radius,
        } => Shape::cylinder(*half_height, *radius)?,
        NeutralShape::ConvexHull(points) => Shape::convex_hull(points)?,
        NeutralShape::HeightField {
            heights,
            rows,
            cols,
            scale,
        } => Shape::heightfield(heights.as_ref().clone(), *rows, *cols, *scale)?,
    })
}

impl Ours {
    /// The world's per-stage timings summed since it was built.
    pub fn profile_totals(&self) -> inertia_physics::ProfileTotals {
        *self.world.profile_totals()
    }

    /// Shape pairs collided and manifolds used again, summed over every
    /// step so far.
    pub fn manifolds(&self) -> ManifoldCount {
        self.manifolds
    }

    /// Builds `scene` in a new world. `threads == 1` runs the step inline on
    /// the caller (the engine's own single-thread mode); more threads use
    /// the rayon pool the step is called from (`WorldConfig::threads = 0`).
    pub fn build(
        scene: &NeutralScene,
        threads: usize,
        sleeping: bool,
        dt: f64,
    ) -> Result<Self, BenchError> {
        let mut world = World::new(WorldConfig {
            threads: if threads == 1 { 1 } else { 0 },
            energy_accounting: false,
            gpu_readback_every_step: true,
            ..WorldConfig::default()
        })?;
        world.set_gravity(DVec3::new(0.0, GRAVITY, 0.0))?;
        let mut cfg = SolverConfig {
            substeps: SOLVER_ITERATIONS as u32,
            ..SolverConfig::default()
        };
        cfg.sleep.enabled = sleeping;
        world.set_solver_config(cfg)?;
        let mut handles = Vec::with_capacity(scene.bodies.len());
        let mut dynamic = Vec::new();
        for b in &scene.bodies {
            let pose = Pose::new(b.position, b.rotation);
            let mut desc = match b.kind {
                NeutralKind::Dynamic => RigidBodyDesc::dynamic(shape(&b.shape)?, b.density, pose)?,
                NeutralKind::Static => RigidBodyDesc::fixed(shape(&b.shape)?, pose),
            };
            desc.friction_static = b.friction;
            desc.friction_dynamic = b.friction;
            desc.restitution = b.restitution;
            desc.angular_damping = b.angular_damping;
            desc.can_sleep = sleeping;
            let h = world.add_body(&desc)?;
            if b.kind == NeutralKind::Dynamic {
                dynamic.push(h);
            }
            handles.push(h);
        }
        for j in &scene.joints {
            let (ra, rb) = (scene.bodies[j.a].rotation, scene.bodies[j.b].rotation);
            // The frame's X axis in each body's frame.
            let axes = |frame: DQuat| {
                let w = frame * DVec3::X;
                (ra.inverse() * w, rb.inverse() * w)
            };
            let kind = match j.kind {
                NeutralJointKind::Ball => JointKind::Ball,
                NeutralJointKind::SwingTwist { swing, twist } => {
                    let (axis_a, axis_b) = axes(j.frame);
                    JointKind::SwingTwist {
                        axis_a,
                        axis_b,
                        swing_limit: swing,
                        twist_limits: twist,
                    }
                }
                NeutralJointKind::Hinge { limits } => {
                    let (axis_a, axis_b) = axes(j.frame);
                    JointKind::Hinge {
                        axis_a,
                        axis_b,
                        limits: Some(limits),
                        motor: None,
                    }
                }
            };
            world.add_joint(JointDesc {
                a: handles[j.a],
                b: handles[j.b],
                anchor_a: j.anchor_a,
                anchor_b: j.anchor_b,
                kind,
                break_force: f64::MAX,
            })?;
        }
        Ok(Self {
            world,
            dynamic,
            dt,
            quarantined: 0,
            manifolds: ManifoldCount::default(),
        })
    }
}

impl Engine for Ours {
    fn step(&mut self) -> Result<(), BenchError> {
        let report = self.world.step(self.dt)?;
        self.quarantined += report.quarantined_bodies.len();
        self.manifolds += report.manifolds;
        Ok(())
    }

    fn penetration(&self) -> f64 {
        self.world.deepest_penetration()
    }

    fn positions(&self) -> Vec<DVec3> {
        self.dynamic
            .iter()
            .map(|h| {
                self.world
                    .body(*h)
                    .map_or(DVec3::NAN, |b| b.pose().translation)
            })
            .collect()
    }

    fn awake(&self) -> usize {
        self.world
            .bodies()
            .filter(|(_, b)| b.kind() == BodyKind::Dynamic && !b.is_sleeping())
            .count()
    }

    fn quarantined(&self) -> usize {
        self.quarantined
    }
}
