//! The entity table as stored beside a saved world, and read back with
//! every bound checked.

use inertia_physics::{BodyHandle, FluidHandle, ParticleHandle, SoftBodyHandle};
use inertia_protocol::{EntityDesc, EntityId};

use super::*;

/// Largest stored entity table [`EntityTable::from_bytes`] accepts, bytes.
pub const MAX_TABLE_BYTES: usize = 256 * 1024 * 1024;

/// An entity as stored beside a saved world (field order is the format:
/// postcard writes by position).
#[derive(serde::Serialize, serde::Deserialize)]
struct StoredEntity {
    #[serde(deserialize_with = "inertia_protocol::control::deserialize_entity")]
    desc: EntityDesc,
    /// 0 a body `[index, generation, 0, 0]`; 1 a particle
    /// `[system index, system generation, slot, generation]`; 2 a soft
    /// body and 3 a fluid, `[index, generation, 0, 0]`.
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
                        EntitySource::SoftBody(h) => {
                            let [i, g] = h.to_raw();
                            (2, [i, g, 0, 0])
                        }
                        EntitySource::Fluid(h) => {
                            let [i, g] = h.to_raw();
                            (3, [i, g, 0, 0])
                        }
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
                2 => EntitySource::SoftBody(SoftBodyHandle::from_raw([e.source[0], e.source[1]])),
                3 => EntitySource::Fluid(FluidHandle::from_raw([e.source[0], e.source[1]])),
                k => return Err(TableError(format!("entity {id}: unknown source kind {k}"))),
            };
            let clash = match source {
                EntitySource::Body(h) => table.by_body.insert(h, id).is_some(),
                EntitySource::Particle(h) => table.by_particle.insert(h, id).is_some(),
                EntitySource::SoftBody(h) => table.by_soft_body.insert(h, id).is_some(),
                EntitySource::Fluid(h) => table.by_fluid.insert(h, id).is_some(),
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
        // A point set's points take the ids after its own: no entity may
        // have one of them.
        let mut taken_to = 0u64;
        for (&id, e) in &table.entries {
            if u64::from(id) <= taken_to {
                return Err(TableError(format!(
                    "entity id {id} is a point of the set before it"
                )));
            }
            taken_to = u64::from(id) + e.desc.ids_taken() - 1;
        }
        Ok(table)
    }
}
