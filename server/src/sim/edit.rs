//! Live edits of the world by an operator (spawn, despawn, impulse). Each
//! goes into the tick's journal, so replays and seeks apply it again at
//! the same point.

use inertia_physics::glam::{DQuat, DVec3};
use inertia_physics::rigid::body::RigidBodyDesc;
use inertia_physics::rigid::pose::Pose;
use inertia_protocol::admin::{MassSpec, SpawnDesc};
use inertia_protocol::engine_shape::body_shape;
use inertia_protocol::{EntityId, EntityKind};

use super::Simulation;
use crate::replay::{JournalEntry, WorldEdit};
use crate::rules::{ContextError, EntityLook, RemovalReason};

/// Why an edit was refused (nothing changed).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum EditError {
    /// No such entity.
    #[error("no entity {0}")]
    UnknownEntity(EntityId),
    /// The description is not a body the engine can make.
    #[error("cannot spawn that: {0}")]
    Invalid(String),
    /// History is shown; edits go to the live world only.
    #[error(
        "history is being shown (tick {shown}, live tick {live}); seek to the live tick first"
    )]
    NotLive {
        /// The tick shown.
        shown: u64,
        /// The live tick.
        live: u64,
    },
    /// The rules' context refused.
    #[error(transparent)]
    Context(#[from] ContextError),
}

/// What an edit did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum EditOutcome {
    /// A body was added.
    Spawned(EntityId),
    /// An entity was removed.
    Despawned,
    /// This impulse was applied (after the rules' limits), N·s.
    Impulse(DVec3),
}

/// The body a spawn description asks for.
pub fn body_from_spawn(desc: &SpawnDesc) -> Result<RigidBodyDesc, String> {
    let shape = body_shape(&desc.shape).map_err(|e| e.to_string())?;
    let [x, y, z, w] = desc.rotation;
    let q = DQuat::from_xyzw(x, y, z, w);
    let position = DVec3::from_array(desc.position);
    let velocity = DVec3::from_array(desc.velocity);
    let angular = DVec3::from_array(desc.angular_velocity);
    if !q.is_finite() || q.length() < 1e-9 {
        return Err("the rotation is not a rotation".into());
    }
    if !position.is_finite() || !velocity.is_finite() || !angular.is_finite() {
        return Err("position and velocities must be finite".into());
    }
    let pose = Pose {
        translation: position,
        rotation: q.normalize(),
    };
    let mut body = match desc.kind {
        EntityKind::Dynamic | EntityKind::Avatar => {
            let density = match desc.mass {
                MassSpec::Density(d) => d,
                MassSpec::Mass(_) => 1000.0,
            };
            if !(density.is_finite() && density > 0.0) {
                return Err(format!("density must be above zero, got {density}"));
            }
            let mut b = RigidBodyDesc::dynamic(shape, density, pose).map_err(|e| e.to_string())?;
            if let MassSpec::Mass(m) = desc.mass {
                if !(m.is_finite() && m > 0.0) {
                    return Err(format!("mass must be above zero, got {m}"));
                }
                let k = m / b.mass_properties.mass;
                b.mass_properties.mass = m;
                b.mass_properties.inertia *= k;
            }
            b
        }
        EntityKind::Kinematic => RigidBodyDesc::kinematic(shape, pose),
        EntityKind::Static | EntityKind::Water => RigidBodyDesc::fixed(shape, pose),
        EntityKind::SoftBody | EntityKind::Fluid => {
            return Err("soft bodies and fluids are not spawned as bodies".into())
        }
    };
    body.linear_velocity = velocity;
    body.angular_velocity = angular;
    Ok(body)
}

impl Simulation {
    /// Applies an operator's edit to the live world and notes it in the
    /// journal. Refused, changing nothing, while history is shown.
    pub fn edit(&mut self, edit: WorldEdit) -> Result<EditOutcome, EditError> {
        if self.timelines.past.is_some() {
            return Err(EditError::NotLive {
                shown: self.shown().world.tick(),
                live: self.live_tick(),
            });
        }
        let outcome = self.edit_here(&edit)?;
        self.journal_push(JournalEntry::Edit(Box::new(edit)));
        Ok(outcome)
    }

    /// Applies an edit to the shown state.
    pub(super) fn edit_here(&mut self, edit: &WorldEdit) -> Result<EditOutcome, EditError> {
        let outcome = match edit {
            WorldEdit::Despawn { id } => {
                let id = *id;
                if !self.with_ctx(|_, ctx| ctx.despawn(id)) {
                    return Err(EditError::UnknownEntity(id));
                }
                self.removed.push((id, RemovalReason::Despawned));
                self.tell_removed();
                EditOutcome::Despawned
            }
            WorldEdit::Impulse { id, impulse, point } => {
                let (id, impulse) = (*id, DVec3::from_array(*impulse));
                let point = point.map(DVec3::from_array);
                let j = self.with_ctx(|_, ctx| {
                    let point = match point {
                        Some(p) => p,
                        None => ctx
                            .body(id)
                            .map(|b| b.center_of_mass())
                            .ok_or(ContextError::UnknownEntity(id))?,
                    };
                    ctx.apply_impulse(id, impulse, point)
                });
                EditOutcome::Impulse(j.map_err(|e| match e {
                    ContextError::UnknownEntity(id) => EditError::UnknownEntity(id),
                    e => EditError::Context(e),
                })?)
            }
            WorldEdit::Spawn { desc } => {
                let body = body_from_spawn(desc).map_err(EditError::Invalid)?;
                let look = EntityLook {
                    kind: desc.kind,
                    color: desc.color,
                    owner: None,
                    name: desc.name.clone(),
                };
                // The engine checks its bounds (mass, size, speed) as it
                // adds the body, as for a scene file: out of them is a
                // body it cannot make.
                let id = self
                    .with_ctx(|_, ctx| ctx.spawn(&body, look))
                    .map_err(|e| match e {
                        ContextError::Physics(e) => EditError::Invalid(e.to_string()),
                        e => EditError::Context(e),
                    })?;
                EditOutcome::Spawned(id)
            }
        };
        self.collect_messages();
        self.update_gauges();
        Ok(outcome)
    }
}
