//! The game's replicated state as a timeline holds it: each entity's
//! properties and the match's ([`PropertyStore`]), set only by the rules
//! (through [`crate::rules::SimContext`]), saved with every keyframe and
//! checkpoint, folded into the state hash, and published with each frame
//! for the snapshots ([`inertia_protocol::property`]).
//!
//! # Saved form
//!
//! Little-endian ([`inertia_codec`]): `u16` entity properties n, `u16`
//! match properties m, m × `u64` the match's values, `u32` rows, then each
//! row: `u32` entity id, n × `u64` values. Rows ascend by id. The schema
//! is the rules' and is not saved: bytes of another schema's counts are
//! refused.

use std::collections::BTreeMap;
use std::sync::Arc;

use inertia_codec::{ByteReader, ByteWriter};
use inertia_physics::saved_state::hash::StateHasher;
use inertia_protocol::property::{
    FrameProperties, PropertyDecl, PropertyError, PropertyRow, PropertySchema, PropertyValue,
};
use inertia_protocol::EntityId;

/// Declaration `index` of `list`, or why there is none.
fn decl(list: &[PropertyDecl], index: usize) -> Result<&PropertyDecl, PropertyError> {
    list.get(index).ok_or(PropertyError::NoSuchProperty {
        index,
        count: list.len(),
    })
}

/// Every property of one timeline: rows of raw values by entity (only
/// entities with a value set) and the match's row.
#[derive(Debug, Clone, PartialEq)]
pub struct PropertyStore {
    schema: Arc<PropertySchema>,
    entities: BTreeMap<EntityId, PropertyRow>,
    match_state: PropertyRow,
    /// Bumped by every change, for the publication.
    version: u64,
}

impl PropertyStore {
    /// All defaults under `schema`.
    pub fn new(schema: Arc<PropertySchema>) -> Self {
        let match_state = vec![0; schema.match_state.len()].into();
        Self {
            schema,
            entities: BTreeMap::new(),
            match_state,
            version: 0,
        }
    }

    /// The schema.
    pub fn schema(&self) -> &Arc<PropertySchema> {
        &self.schema
    }

    /// Whether the game declares no property.
    pub fn is_empty(&self) -> bool {
        self.schema.is_empty()
    }

    /// Bumped by every change.
    pub fn version(&self) -> u64 {
        self.version
    }

    /// Entity property `index` of `entity` (its default when never set).
    pub fn get(&self, entity: EntityId, index: usize) -> Result<PropertyValue, PropertyError> {
        let decl = self
            .schema
            .entity
            .get(index)
            .ok_or(PropertyError::NoSuchProperty {
                index,
                count: self.schema.entity.len(),
            })?;
        let raw = self.entities.get(&entity).map_or(0, |r| r[index]);
        Ok(PropertyValue::from_raw(decl.kind, raw))
    }

    /// Sets entity property `index` of `entity` (whose existence the
    /// caller checked). Refused, changing nothing, for an index the schema
    /// lacks or a value not of its kind.
    pub fn set(
        &mut self,
        entity: EntityId,
        index: usize,
        value: PropertyValue,
    ) -> Result<(), PropertyError> {
        let n = self.schema.entity.len();
        let raw = value.to_raw(decl(&self.schema.entity, index)?.kind)?;
        let row = self
            .entities
            .entry(entity)
            .or_insert_with(|| vec![0; n].into());
        if row[index] != raw {
            Arc::make_mut(row)[index] = raw;
            self.version += 1;
        }
        Ok(())
    }

    /// Match property `index` (its default when never set).
    pub fn get_match(&self, index: usize) -> Result<PropertyValue, PropertyError> {
        let decl = decl(&self.schema.match_state, index)?;
        Ok(PropertyValue::from_raw(decl.kind, self.match_state[index]))
    }

    /// Sets match property `index`; refused, changing nothing, as
    /// [`Self::set`].
    pub fn set_match(&mut self, index: usize, value: PropertyValue) -> Result<(), PropertyError> {
        let raw = value.to_raw(decl(&self.schema.match_state, index)?.kind)?;
        if self.match_state[index] != raw {
            Arc::make_mut(&mut self.match_state)[index] = raw;
            self.version += 1;
        }
        Ok(())
    }

    /// `entity` left the world: its properties go with it.
    pub fn forget(&mut self, entity: EntityId) {
        if self.entities.remove(&entity).is_some() {
            self.version += 1;
        }
    }

    /// The values as a frame publishes them.
    pub fn frame(&self) -> FrameProperties {
        FrameProperties {
            entities: self
                .entities
                .iter()
                .map(|(id, row)| (*id, row.clone()))
                .collect(),
            match_state: (!self.schema.match_state.is_empty()).then(|| self.match_state.clone()),
        }
    }

    /// A hash of every value (0 for a game without properties), folded
    /// into the state hash: a seek that reproduces the recorded hash
    /// reproduced the properties too.
    pub fn hash(&self) -> u64 {
        if self.is_empty() {
            return 0;
        }
        // Over the values as the saved form lists them, without making it.
        let mut h = StateHasher::default();
        self.match_state.iter().for_each(|&v| h.write_u64(v));
        for (id, row) in &self.entities {
            h.write_u64(u64::from(*id));
            row.iter().for_each(|&v| h.write_u64(v));
        }
        h.finish()
    }

    /// The saved form (see the module docs); empty for a game without
    /// properties.
    pub fn to_bytes(&self) -> Vec<u8> {
        if self.is_empty() {
            return Vec::new();
        }
        let n = self.schema.entity.len();
        let mut out =
            Vec::with_capacity(8 + 8 * self.match_state.len() + self.entities.len() * (4 + 8 * n));
        let mut w = ByteWriter::new(&mut out);
        w.u16(n as u16);
        w.u16(self.match_state.len() as u16);
        for &v in self.match_state.iter() {
            w.u64(v);
        }
        w.u32(self.entities.len() as u32);
        for (id, row) in &self.entities {
            w.u32(*id);
            for &v in row.iter() {
                w.u64(v);
            }
        }
        out
    }

    /// Replaces the values with saved ones of the same schema's counts;
    /// empty bytes are all defaults. On error nothing changes.
    pub fn restore(&mut self, bytes: &[u8]) -> Result<(), String> {
        let mut fresh = PropertyStore::new(self.schema.clone());
        if bytes.is_empty() {
            fresh.version = self.version + 1;
            *self = fresh;
            return Ok(());
        }
        let err = |e: inertia_codec::CodecError| format!("properties: {e}");
        let mut r = ByteReader::new(bytes);
        let (n, m) = (
            usize::from(r.u16().map_err(err)?),
            usize::from(r.u16().map_err(err)?),
        );
        if n != self.schema.entity.len() || m != self.schema.match_state.len() {
            return Err(format!(
                "properties saved for {n} entity and {m} match properties; these rules declare {} and {}",
                self.schema.entity.len(),
                self.schema.match_state.len()
            ));
        }
        let check = |kind, raw: u64| {
            let value = PropertyValue::from_raw(kind, raw);
            match value.to_raw(kind) {
                Ok(back) if back == raw => Ok(()),
                _ => Err(format!("a saved property value {raw:#x} out of {kind:?}")),
            }
        };
        let mut match_state = Vec::with_capacity(m);
        for decl in &self.schema.match_state {
            let raw = r.u64().map_err(err)?;
            check(decl.kind, raw)?;
            match_state.push(raw);
        }
        fresh.match_state = match_state.into();
        let rows = r.u32().map_err(err)? as usize;
        if rows.saturating_mul(4 + 8 * n) > r.remaining() {
            return Err(format!("{rows} property rows cannot fit"));
        }
        let mut last: Option<EntityId> = None;
        for _ in 0..rows {
            let id = r.u32().map_err(err)?;
            if last.is_some_and(|l| l >= id) {
                return Err("property rows out of order".into());
            }
            last = Some(id);
            let mut row = Vec::with_capacity(n);
            for decl in &self.schema.entity {
                let raw = r.u64().map_err(err)?;
                check(decl.kind, raw)?;
                row.push(raw);
            }
            fresh.entities.insert(id, row.into());
        }
        if !r.is_empty() {
            return Err(format!("properties: {} trailing bytes", r.remaining()));
        }
        fresh.version = self.version + 1;
        *self = fresh;
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use inertia_protocol::property::{PropertyDecl, PropertyKind};

    use super::*;

    fn schema() -> Arc<PropertySchema> {
        Arc::new(PropertySchema {
            entity: vec![
                PropertyDecl::new("health", PropertyKind::UInt { bits: 7 }),
                PropertyDecl::new("heading", PropertyKind::Int { bits: 10 }),
            ],
            match_state: vec![PropertyDecl::new("clock", PropertyKind::F32)],
        })
    }

    #[test]
    fn values_are_set_checked_saved_restored_and_hashed() {
        let mut s = PropertyStore::new(schema());
        assert_eq!(s.get(4, 0), Ok(PropertyValue::UInt(0)));
        s.set(4, 0, PropertyValue::UInt(100)).unwrap();
        s.set(9, 1, PropertyValue::Int(-300)).unwrap();
        s.set_match(0, PropertyValue::F32(12.5)).unwrap();
        assert!(
            s.set(4, 0, PropertyValue::UInt(128)).is_err(),
            "past 7 bits"
        );
        assert!(
            s.set(4, 2, PropertyValue::UInt(1)).is_err(),
            "no property 2"
        );
        assert!(s.set(4, 1, PropertyValue::UInt(1)).is_err(), "another kind");
        assert_eq!(s.get(4, 0), Ok(PropertyValue::UInt(100)));
        let hash = s.hash();
        assert_ne!(hash, 0);

        let bytes = s.to_bytes();
        let mut back = PropertyStore::new(schema());
        back.restore(&bytes).unwrap();
        assert_eq!(back.frame(), s.frame());
        assert_eq!(back.hash(), hash);
        s.forget(9);
        assert_ne!(s.hash(), hash);
        // Another schema's bytes, a cut, and trailing bytes are refused,
        // changing nothing.
        let other = PropertyStore::new(Arc::new(PropertySchema::default()));
        let mut kept = back.clone();
        assert!(
            kept.restore(&other.to_bytes()[..]).is_ok(),
            "empty: defaults"
        );
        let mut kept = back.clone();
        for cut in 1..bytes.len() {
            assert!(kept.restore(&bytes[..cut]).is_err(), "cut at {cut}");
            assert_eq!(kept.frame(), back.frame());
        }
        let mut long = bytes.clone();
        long.push(0);
        assert!(kept.restore(&long).is_err());
        assert_eq!(PropertyStore::new(Arc::default()).hash(), 0);
    }
}
