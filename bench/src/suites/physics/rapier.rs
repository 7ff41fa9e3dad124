//! A [`NeutralScene`] built into rapier3d 0.36 (`f32`, glam-based math).
//!
//! One `PhysicsWorld` holds the sets, the pipeline, the broad phase
//! (`BroadPhaseBvh`), the narrow phase and the CCD solver. Integration
//! parameters are rapier's defaults with `dt` = 1/60 s and
//! `num_solver_iterations` = [`SOLVER_ITERATIONS`] written out; the
//! pipeline's profiling counters are switched off (they only time its
//! stages). Sleeping off means `can_sleep(false)` on every body. Colliders
//! combine friction by geometric mean and restitution by maximum, as our
//! engine does. Jointed bodies do not collide with each other, as in our
//! engine.

use std::collections::HashSet;

use inertia_physics::glam::{DQuat, DVec3};
use rapier3d::parry::query;
use rapier3d::prelude::{
    Array2, CoefficientCombineRule, ColliderBuilder, GenericJointBuilder, JointAxesMask, JointAxis,
    PhysicsWorld, Pose, RigidBodyBuilder, RigidBodyHandle, Rot3, Vec3,
};

use super::scene::{NeutralJointKind, NeutralKind, NeutralScene, NeutralShape};
use super::{Engine, GRAVITY, SOLVER_ITERATIONS};
use crate::BenchError;

fn v(p: DVec3) -> Vec3 {
    Vec3::new(p.x as f32, p.y as f32, p.z as f32)
}

fn q(r: DQuat) -> Rot3 {
    Rot3::from_xyzw(r.x as f32, r.y as f32, r.z as f32, r.w as f32).normalize()
}

fn pose(p: DVec3, r: DQuat) -> Pose {
    Pose::from_parts(v(p), q(r))
}

fn collider(s: &NeutralShape) -> Result<ColliderBuilder, BenchError> {
    Ok(match s {
        NeutralShape::Sphere { radius } => ColliderBuilder::ball(*radius as f32),
        NeutralShape::Cuboid { half_extents: h } => {
            ColliderBuilder::cuboid(h.x as f32, h.y as f32, h.z as f32)
        }
        NeutralShape::Capsule {
            half_height,
            radius,
        } => ColliderBuilder::capsule_y(*half_height as f32, *radius as f32),
        NeutralShape::Cylinder {
            half_height,
            radius,
        } => ColliderBuilder::cylinder(*half_height as f32, *radius as f32),
        NeutralShape::ConvexHull(points) => {
            let pts: Vec<Vec3> = points.iter().map(|p| v(*p)).collect();
            ColliderBuilder::convex_hull(&pts).ok_or("rapier: convex hull of the points failed")?
        }
        NeutralShape::HeightField {
            heights,
            rows,
            cols,
            scale,
        } => {
            let cols = *cols;
            let h = Array2::from_fn(*rows, cols, |r, c| heights[r * cols + c] as f32);
            ColliderBuilder::heightfield(h, v(*scale))
        }
    })
}

/// A rapier world with the handles of the scene's dynamic bodies.
pub struct Rapier {
    world: PhysicsWorld,
    dynamic: Vec<RigidBodyHandle>,
    /// Pairs of bodies joined by a joint (they do not collide).
    jointed: HashSet<(RigidBodyHandle, RigidBodyHandle)>,
    quarantined: usize,
}

fn ordered(a: RigidBodyHandle, b: RigidBodyHandle) -> (RigidBodyHandle, RigidBodyHandle) {
    if a.into_raw_parts() <= b.into_raw_parts() {
        (a, b)
    } else {
        (b, a)
    }
}

impl std::fmt::Debug for Rapier {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Rapier")
            .field("bodies", &self.world.bodies.len())
            .finish_non_exhaustive()
    }
}

impl Rapier {
    /// Builds `scene` in a new rapier world. The step runs on the rayon
    /// pool it is called from (no pool of its own).
    pub fn build(scene: &NeutralScene, sleeping: bool, dt: f64) -> Result<Self, BenchError> {
        let mut world = PhysicsWorld::new();
        world.gravity = Vec3::new(0.0, GRAVITY as f32, 0.0);
        world.integration_parameters.dt = dt as f32;
        world.integration_parameters.num_solver_iterations = SOLVER_ITERATIONS;
        world.physics_pipeline.counters.disable();
        let mut handles = Vec::with_capacity(scene.bodies.len());
        let mut dynamic = Vec::new();
        for b in &scene.bodies {
            let builder = match b.kind {
                NeutralKind::Dynamic => RigidBodyBuilder::dynamic(),
                NeutralKind::Static => RigidBodyBuilder::fixed(),
            }
            .pose(pose(b.position, b.rotation))
            .angular_damping(b.angular_damping as f32)
            .can_sleep(sleeping);
            let h = world.bodies.insert(builder);
            let c = collider(&b.shape)?
                .density(b.density as f32)
                .friction(b.friction as f32)
                .friction_combine_rule(CoefficientCombineRule::GeometricMean)
                .restitution(b.restitution as f32)
                .restitution_combine_rule(CoefficientCombineRule::Max);
            world.colliders.insert_with_parent(c, h, &mut world.bodies);
            if b.kind == NeutralKind::Dynamic {
                dynamic.push(h);
            }
            handles.push(h);
        }
        let mut jointed = HashSet::new();
        for j in &scene.joints {
            jointed.insert(ordered(handles[j.a], handles[j.b]));
            let (ra, rb) = (scene.bodies[j.a].rotation, scene.bodies[j.b].rotation);
            let frame1 = pose(j.anchor_a, ra.inverse() * j.frame);
            let frame2 = pose(j.anchor_b, rb.inverse() * j.frame);
            let builder = match j.kind {
                NeutralJointKind::Ball => {
                    GenericJointBuilder::new(JointAxesMask::LOCKED_SPHERICAL_AXES)
                }
                NeutralJointKind::SwingTwist { swing, twist } => {
                    let s = swing as f32;
                    GenericJointBuilder::new(JointAxesMask::LOCKED_SPHERICAL_AXES)
                        .limits(JointAxis::AngX, [twist.0 as f32, twist.1 as f32])
                        .limits(JointAxis::AngY, [-s, s])
                        .limits(JointAxis::AngZ, [-s, s])
                }
                NeutralJointKind::Hinge { limits } => {
                    GenericJointBuilder::new(JointAxesMask::LOCKED_REVOLUTE_AXES)
                        .limits(JointAxis::AngX, [limits.0 as f32, limits.1 as f32])
                }
            };
            let joint = builder
                .local_frame1(frame1)
                .local_frame2(frame2)
                .contacts_enabled(false)
                .build();
            world
                .impulse_joints
                .insert(handles[j.a], handles[j.b], joint, true);
        }
        Ok(Self {
            world,
            dynamic,
            jointed,
            quarantined: 0,
        })
    }
}

impl Rapier {
    /// The deepest penetration among the contact points of rapier's own
    /// contact manifolds, m. With contact recycling (on by default) a
    /// manifold keeps the distances of its last full update while the pair
    /// moves less than the recycle distance, so this can be stale; the
    /// suite's `rapier_max_penetration_mm` comes from [`Engine::penetration`]
    /// instead.
    pub fn manifold_penetration(&self) -> f64 {
        let mut deepest = 0.0f32;
        for pair in self.world.narrow_phase.contact_pairs() {
            for m in pair.manifolds() {
                for p in &m.points {
                    deepest = deepest.max(-p.dist);
                }
            }
        }
        f64::from(deepest)
    }
}

impl Engine for Rapier {
    fn step(&mut self) -> Result<(), BenchError> {
        self.world.step();
        self.quarantined += self.world.quarantine().bodies().len();
        Ok(())
    }

    fn penetration(&self) -> f64 {
        let mut deepest = 0.0f32;
        for pair in self.world.narrow_phase.contact_pairs() {
            let (Some(c1), Some(c2)) = (
                self.world.colliders.get(pair.collider1),
                self.world.colliders.get(pair.collider2),
            ) else {
                continue;
            };
            if let (Some(b1), Some(b2)) = (c1.parent(), c2.parent()) {
                if self.jointed.contains(&ordered(b1, b2)) {
                    continue;
                }
            }
            let contact = query::contact(c1.position(), c1.shape(), c2.position(), c2.shape(), 0.0);
            if let Ok(Some(c)) = contact {
                deepest = deepest.max(-c.dist);
            }
        }
        f64::from(deepest)
    }

    fn positions(&self) -> Vec<DVec3> {
        self.dynamic
            .iter()
            .map(|h| {
                self.world.bodies.get(*h).map_or(DVec3::NAN, |b| {
                    let t = b.translation();
                    DVec3::new(f64::from(t.x), f64::from(t.y), f64::from(t.z))
                })
            })
            .collect()
    }

    fn awake(&self) -> usize {
        self.world
            .bodies
            .iter()
            .filter(|(_, b)| b.is_dynamic() && !b.is_sleeping())
            .count()
    }

    fn quarantined(&self) -> usize {
        self.quarantined
    }
}
