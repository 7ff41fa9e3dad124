//! Building a scene file into a world and its entity table.
//!
//! Order (it fixes the entity ids): `bodies`, `generators`, `ragdolls`,
//! `ropes`, `cloths`, then the water regions of `forces`; joints after
//! every body exists, so they may name bodies from any section. The XPBD
//! `soft_bodies` and `fluids` (see [`soft`]) come after the cloths and make
//! no entities. Every check reports the path of the entry it refuses.
//!
//! One kind of entry a file: `checks.rs` (values), `shape.rs` (shapes),
//! `rigid.rs` (bodies, generators, bridges, ragdolls), `particles.rs`
//! (systems, ropes, cloths), `forces.rs`, `joints.rs` and `soft.rs` (soft
//! bodies and fluids); the `Builder` they fill, and the order, here.

mod checks;
mod forces;
mod joints;
mod particles;
mod rigid;
mod shape;
mod soft;

use std::collections::BTreeMap;

use inertia_physics::glam::{DMat3, DQuat, DVec3};
use inertia_physics::ragdoll::{build_ragdoll, RagdollDesc};
use inertia_physics::rigid::aabb::Aabb;
use inertia_physics::rigid::body::{BodyKind, RigidBodyDesc};
use inertia_physics::rigid::joint::{JointDesc, JointKind};
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::shape::Shape;
use inertia_physics::rigid::solver::SolverConfig;
use inertia_physics::{
    build_cloth, build_rope, BodyHandle, Buoyancy, ClothDesc, Drag, Explosion, FluidHandle, Force,
    ParticleHandle, PhysicsError, RopeDesc, SoftBodyHandle, SpringParams, SpringStiffness,
    SystemDesc, SystemHandle, Wind, World, WorldConfig,
};
use inertia_protocol::{EntityDesc, EntityKind, ShapeDesc};

use super::entities::{entity_kind, shape_desc, EntitySource, EntityTable};
use super::schema::*;
use super::{BuiltScene, SceneError};
use checks::*;
use shape::shape;

/// Slowest tick rate at which rope-to-body attachments stay stable, Hz.
const ATTACH_HZ: f64 = 60.0;

/// Most bodies one generator may make.
const MAX_GENERATED: u64 = 100_000;

fn default_color(kind: BodyKind, index: usize) -> [u8; 4] {
    const PALETTE: [[u8; 4]; 6] = [
        [214, 96, 77, 255],
        [67, 147, 195, 255],
        [244, 165, 130, 255],
        [146, 197, 222, 255],
        [178, 171, 210, 255],
        [253, 219, 120, 255],
    ];
    match kind {
        BodyKind::Static => [140, 140, 135, 255],
        BodyKind::Kinematic => [120, 180, 120, 255],
        BodyKind::Dynamic => PALETTE[index % PALETTE.len()],
    }
}

/// Everything the build has made so far.
struct Builder {
    world: World,
    entities: EntityTable,
    names: BTreeMap<String, BodyHandle>,
    /// Where each name was defined, for duplicate reports.
    systems: Vec<SystemHandle>,
    gravity: DVec3,
    /// Joints of generators, made once every body exists: (path, a, b,
    /// world anchor, kind with world axes).
    pending_joints: Vec<PendingJoint>,
    unnamed: usize,
    /// XPBD soft bodies by name.
    soft_bodies: BTreeMap<String, SoftBodyHandle>,
    /// Fluids by name.
    fluids: BTreeMap<String, FluidHandle>,
}

struct PendingJoint {
    at: String,
    a: String,
    b: String,
    anchor: DVec3,
    kind: JointKind,
    break_force: f64,
}

impl Builder {
    fn add_entity(
        &mut self,
        source: EntitySource,
        kind: EntityKind,
        shape: ShapeDesc,
        color: [u8; 4],
        name: String,
        pose: Pose,
    ) {
        self.entities.insert(
            source,
            EntityDesc {
                id: 0,
                kind,
                shape,
                color,
                owner: None,
                name,
                position: pose.translation.to_array(),
                rotation: pose.rotation.to_array(),
            },
        );
    }

    fn name(&mut self, at: &str, name: Option<&str>, h: BodyHandle) -> Result<String, SceneError> {
        let name = match name {
            Some(n) => {
                if n.is_empty() {
                    return Err(invalid(at, "a name must not be empty"));
                }
                n.to_string()
            }
            None => {
                self.unnamed += 1;
                format!("body#{}", self.unnamed)
            }
        };
        if self.names.insert(name.clone(), h).is_some() {
            return Err(invalid(at, format!("duplicate body name `{name}`")));
        }
        Ok(name)
    }
}

/// Builds `file` into a world configured by `config`.
pub(crate) fn build(file: &SceneFile, config: WorldConfig) -> Result<BuiltScene, SceneError> {
    let mut world = World::new(config).map_err(physics("."))?;
    let gravity = vec3("world.gravity", file.world.gravity)?;
    world
        .set_gravity(gravity)
        .map_err(physics("world.gravity"))?;
    let substeps = file.world.solver_substeps;
    if !(1..=64).contains(&substeps) {
        return Err(invalid(
            "world.solver_substeps",
            format!("must be in 1..=64, got {substeps}"),
        ));
    }
    let mut solver = SolverConfig {
        substeps,
        ..SolverConfig::default()
    };
    solver.sleep.enabled = file.world.sleep;
    world
        .set_solver_config(solver)
        .map_err(physics("world.solver_substeps"))?;
    if let Some(b) = &file.world.bounds {
        let min = vec3("world.bounds.min", b.min)?;
        let max = vec3("world.bounds.max", b.max)?;
        if min.cmpgt(max).any() {
            return Err(invalid("world.bounds", "min must not exceed max"));
        }
        world
            .set_body_bounds(Some(Aabb::new(min, max)))
            .map_err(physics("world.bounds"))?;
    }
    let spawn_points = file
        .spawn_points
        .iter()
        .enumerate()
        .map(|(i, p)| vec3(&format!("spawn_points[{i}]"), *p))
        .collect::<Result<Vec<_>, _>>()?;
    if spawn_points.is_empty() {
        return Err(invalid("spawn_points", "give at least one spawn point"));
    }
    let mut b = Builder {
        world,
        entities: EntityTable::new(),
        names: BTreeMap::new(),
        systems: Vec::new(),
        gravity,
        pending_joints: Vec::new(),
        unnamed: 0,
        soft_bodies: BTreeMap::new(),
        fluids: BTreeMap::new(),
    };
    for (i, spec) in file.bodies.iter().enumerate() {
        b.body(&format!("bodies[{i}]"), spec, None, DVec3::ZERO)?;
    }
    for (i, g) in file.generators.iter().enumerate() {
        b.generator(&format!("generators[{i}]"), g)?;
    }
    for (i, r) in file.ragdolls.iter().enumerate() {
        b.ragdoll(&format!("ragdolls[{i}]"), r)?;
    }
    let generated = std::mem::take(&mut b.pending_joints);
    for j in generated {
        b.joint(j)?;
    }
    for (i, j) in file.joints.iter().enumerate() {
        let at = format!("joints[{i}]");
        let pending = b.joint_spec(&at, j)?;
        b.joint(pending)?;
    }
    for (i, r) in file.ropes.iter().enumerate() {
        b.rope(&format!("ropes[{i}]"), r)?;
    }
    for (i, c) in file.cloths.iter().enumerate() {
        b.cloth(&format!("cloths[{i}]"), c)?;
    }
    for (i, s) in file.soft_bodies.iter().enumerate() {
        b.soft_body(&format!("soft_bodies[{i}]"), s)?;
    }
    for (i, f) in file.fluids.iter().enumerate() {
        b.fluid(&format!("fluids[{i}]"), f)?;
    }
    for (i, f) in file.forces.iter().enumerate() {
        b.force(&format!("forces[{i}]"), f)?;
    }
    Ok(BuiltScene {
        world: b.world,
        entities: b.entities,
        bodies_by_name: b.names,
        soft_bodies_by_name: b.soft_bodies,
        fluids_by_name: b.fluids,
        spawn_points,
        name: file.name.clone(),
    })
}
