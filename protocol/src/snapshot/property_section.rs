//! The properties section of a snapshot (see [`crate::property`]): what
//! changed against the baseline's view, written and read.

use std::sync::Arc;

use crate::bits::{BitReader, BitWriter};
use crate::entity::{EntityId, MAX_ENTITIES};
use crate::property::{
    changed_mask, raw_at, PropertyDecl, PropertyRow, PropertySchema, PropertyValue, PropertyView,
};

use super::code::{read_varuint, varuint_bits, write_varuint, COUNT_CLASSES, ID_CLASSES};
use super::SnapshotError;

/// Bits the section takes whatever changed: the match's changed bit and
/// the entity count at its widest (none for a schema without either).
pub(crate) fn section_bound_bits(schema: &PropertySchema) -> usize {
    usize::from(!schema.match_state.is_empty())
        + if schema.entity.is_empty() {
            0
        } else {
            varuint_bits(MAX_ENTITIES as u64, &COUNT_CLASSES)
        }
}

/// Codes a snapshot's property changes for one schema.
#[derive(Debug, Clone, Copy)]
pub(crate) struct SectionWriter<'a> {
    schema: &'a PropertySchema,
}

/// Bits of the values `mask` names, and the mask itself, in `decls`.
fn change_bits(decls: &[PropertyDecl], mask: u64) -> usize {
    decls.len()
        + decls
            .iter()
            .enumerate()
            .filter(|(i, _)| mask >> i & 1 == 1)
            .map(|(_, d)| d.kind.bits() as usize)
            .sum::<usize>()
}

fn write_change(w: &mut BitWriter, decls: &[PropertyDecl], mask: u64, row: Option<&PropertyRow>) {
    w.write(mask, decls.len() as u32);
    for (i, d) in decls.iter().enumerate() {
        if mask >> i & 1 == 1 {
            w.write(raw_at(row, i), d.kind.bits());
        }
    }
}

impl<'a> SectionWriter<'a> {
    pub(crate) fn new(schema: &'a PropertySchema) -> Self {
        Self { schema }
    }

    /// Whether the schema declares any property.
    pub(crate) fn is_empty(&self) -> bool {
        self.schema.is_empty()
    }

    /// The match's change against the baseline's: its mask (0: none) and
    /// the bits it takes beyond the changed bit.
    pub(crate) fn match_change(
        &self,
        now: Option<&PropertyRow>,
        before: Option<&PropertyRow>,
    ) -> (u64, usize) {
        let decls = &self.schema.match_state;
        let mask = changed_mask(now, before, decls.len());
        (
            mask,
            if mask == 0 {
                0
            } else {
                change_bits(decls, mask)
            },
        )
    }

    /// An entity's change against the baseline's row: its mask (0: none)
    /// and the bits its entry takes beyond its id gap.
    pub(crate) fn entity_change(
        &self,
        now: Option<&PropertyRow>,
        before: Option<&PropertyRow>,
    ) -> (u64, usize) {
        let decls = &self.schema.entity;
        let mask = changed_mask(now, before, decls.len());
        (
            mask,
            if mask == 0 {
                0
            } else {
                change_bits(decls, mask)
            },
        )
    }

    /// The most bits an entity entry's id gap takes (its whole id).
    pub(crate) fn id_bound_bits(id: EntityId) -> usize {
        varuint_bits(u64::from(id), &ID_CLASSES)
    }

    /// Writes the section: the match's change (`mask` 0: none) and the
    /// entities' changes, ascending by id, each with its row now.
    pub(crate) fn write(
        &self,
        w: &mut BitWriter,
        match_state: (u64, Option<&PropertyRow>),
        entities: &[(EntityId, u64, Option<PropertyRow>)],
    ) {
        if !self.schema.match_state.is_empty() {
            let (mask, row) = match_state;
            w.write_bool(mask != 0);
            if mask != 0 {
                write_change(w, &self.schema.match_state, mask, row);
            }
        }
        if !self.schema.entity.is_empty() {
            write_varuint(w, entities.len() as u64, &COUNT_CLASSES);
            let mut prev: Option<EntityId> = None;
            for (id, mask, row) in entities {
                let gap = prev.map_or(u64::from(*id), |p| u64::from(id - p - 1));
                write_varuint(w, gap, &ID_CLASSES);
                write_change(w, &self.schema.entity, *mask, row.as_ref());
                prev = Some(*id);
            }
        }
    }
}

/// Reads one change of `decls` onto `before` (a missing row is zeros):
/// the new row.
fn read_change(
    r: &mut BitReader<'_>,
    decls: &[PropertyDecl],
    before: Option<&PropertyRow>,
) -> Result<PropertyRow, SnapshotError> {
    let mask = r.read(decls.len() as u32)?;
    if mask == 0 {
        return Err(SnapshotError::Malformed(
            "a property change that changes nothing",
        ));
    }
    let mut row: Vec<u64> = (0..decls.len()).map(|i| raw_at(before, i)).collect();
    for (i, d) in decls.iter().enumerate() {
        if mask >> i & 1 == 1 {
            let raw = r.read(d.kind.bits())?;
            if !PropertyValue::raw_is_valid(d.kind, raw) {
                return Err(SnapshotError::Malformed("a property value out of its kind"));
            }
            if raw == raw_at(before, i) {
                return Err(SnapshotError::Malformed(
                    "a property change to the same value",
                ));
            }
            row[i] = raw;
        }
    }
    Ok(Arc::from(row))
}

/// What a snapshot's property section said: the rows that changed, in
/// full, ascending by id, and the match's when it changed.
pub(crate) type SectionChanges = (Vec<(EntityId, PropertyRow)>, Option<PropertyRow>);

/// Reads a snapshot's property section against `base` (the baseline's
/// properties). Every entity named must be in the snapshot's view
/// (`in_view`); ids ascend; every change changes something; floats are
/// finite. Nothing is read for a schema without properties.
pub(crate) fn read_section(
    r: &mut BitReader<'_>,
    schema: &PropertySchema,
    base: &PropertyView,
    mut in_view: impl FnMut(EntityId) -> bool,
) -> Result<SectionChanges, SnapshotError> {
    let mut match_state = None;
    if !schema.match_state.is_empty() && r.read_bool()? {
        match_state = Some(read_change(r, &schema.match_state, base.match_state())?);
    }
    let mut updated = Vec::new();
    if !schema.entity.is_empty() {
        // Each entry takes its id gap (2 bits at least) and its mask.
        let bound = MAX_ENTITIES.min(r.bits_left() / (2 + schema.entity.len()));
        let count = read_varuint(r, &COUNT_CLASSES)?;
        if count > bound as u64 {
            return Err(SnapshotError::Malformed("count above its bound"));
        }
        updated.reserve(count as usize);
        let mut prev: Option<EntityId> = None;
        for _ in 0..count {
            let gap = read_varuint(r, &ID_CLASSES)?;
            let id = prev.map_or(Some(gap), |p| u64::from(p).checked_add(1 + gap));
            let id = id
                .and_then(|id| EntityId::try_from(id).ok())
                .ok_or(SnapshotError::Malformed("entity id overflows"))?;
            if !in_view(id) {
                return Err(SnapshotError::Malformed(
                    "properties of an entity not in view",
                ));
            }
            updated.push((id, read_change(r, &schema.entity, base.entity(id))?));
            prev = Some(id);
        }
    }
    Ok((updated, match_state))
}
