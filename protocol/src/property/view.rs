//! Property values as views hold them: a row of raw values per entity,
//! and one for the match.

use std::sync::Arc;

use crate::entity::EntityId;

/// One entity's (or the match's) property values, raw, in schema order
/// (see [`super::PropertyValue::to_raw`]). Shared: a row that did not
/// change is the same allocation in every view that holds it.
pub type PropertyRow = Arc<[u64]>;

/// The raw value `i` of `row`, 0 where the row is missing or shorter
/// (every kind's default).
pub(crate) fn raw_at(row: Option<&PropertyRow>, i: usize) -> u64 {
    row.and_then(|r| r.get(i)).copied().unwrap_or(0)
}

/// The mask of the values that differ between two rows of `n` values (a
/// missing row is all zeros).
pub(crate) fn changed_mask(
    now: Option<&PropertyRow>,
    before: Option<&PropertyRow>,
    n: usize,
) -> u64 {
    if let (Some(a), Some(b)) = (now, before) {
        if Arc::ptr_eq(a, b) {
            return 0;
        }
    }
    (0..n).fold(0, |mask, i| {
        if raw_at(now, i) != raw_at(before, i) {
            mask | 1 << i
        } else {
            mask
        }
    })
}

/// The properties of a view: a row per entity that has one, ascending by
/// id, and the match's.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct PropertyView {
    pub(crate) entities: Vec<(EntityId, PropertyRow)>,
    pub(crate) match_state: Option<PropertyRow>,
}

impl PropertyView {
    /// An entity's row, if it has one (none: all defaults).
    pub fn entity(&self, id: EntityId) -> Option<&PropertyRow> {
        self.entities
            .binary_search_by_key(&id, |e| e.0)
            .ok()
            .map(|i| &self.entities[i].1)
    }

    /// Every entity's row, ascending by id.
    pub fn entities(&self) -> &[(EntityId, PropertyRow)] {
        &self.entities
    }

    /// The match's row (none: all defaults).
    pub fn match_state(&self) -> Option<&PropertyRow> {
        self.match_state.as_ref()
    }

    /// Whether it holds nothing.
    pub fn is_empty(&self) -> bool {
        self.entities.is_empty() && self.match_state.is_none()
    }

    /// This view with the rows of `removed` entities gone, `updated` rows
    /// put in (both ascending by id) and the match's replaced when given.
    pub(crate) fn apply(
        &self,
        removed: &[EntityId],
        updated: &[(EntityId, PropertyRow)],
        match_state: Option<&PropertyRow>,
    ) -> PropertyView {
        let mut entities = Vec::with_capacity(self.entities.len() + updated.len());
        let (mut r, mut u) = (0, 0);
        for (id, row) in &self.entities {
            while u < updated.len() && updated[u].0 < *id {
                entities.push(updated[u].clone());
                u += 1;
            }
            while r < removed.len() && removed[r] < *id {
                r += 1;
            }
            if u < updated.len() && updated[u].0 == *id {
                entities.push(updated[u].clone());
                u += 1;
            } else if !(r < removed.len() && removed[r] == *id) {
                entities.push((*id, row.clone()));
            }
        }
        entities.extend_from_slice(&updated[u..]);
        PropertyView {
            entities,
            match_state: match_state.cloned().or_else(|| self.match_state.clone()),
        }
    }
}

/// The properties of one published frame, as the server's rules left
/// them: a row per entity that has one set, ascending by id, and the
/// match's.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct FrameProperties {
    /// Rows by entity, ascending by id.
    pub entities: Vec<(EntityId, PropertyRow)>,
    /// The match's row.
    pub match_state: Option<PropertyRow>,
}

impl FrameProperties {
    /// An entity's row, if it has one.
    pub fn entity(&self, id: EntityId) -> Option<&PropertyRow> {
        self.entities
            .binary_search_by_key(&id, |e| e.0)
            .ok()
            .map(|i| &self.entities[i].1)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(v: &[u64]) -> PropertyRow {
        v.into()
    }

    #[test]
    fn a_view_takes_removals_updates_and_the_match() {
        let base = PropertyView {
            entities: vec![(1, row(&[1])), (3, row(&[3])), (5, row(&[5]))],
            match_state: Some(row(&[7, 7])),
        };
        let next = base.apply(&[3], &[(0, row(&[9])), (5, row(&[6]))], None);
        assert_eq!(
            next.entities,
            vec![(0, row(&[9])), (1, row(&[1])), (5, row(&[6]))]
        );
        assert_eq!(next.match_state, Some(row(&[7, 7])));
        let scored = next.apply(&[], &[], Some(&row(&[8, 7])));
        assert_eq!(scored.match_state(), Some(&row(&[8, 7])));
        assert_eq!(
            changed_mask(Some(&row(&[8, 7])), Some(&row(&[7, 7])), 2),
            0b01
        );
        assert_eq!(changed_mask(None, Some(&row(&[0, 4])), 2), 0b10);
        assert_eq!(changed_mask(None, None, 2), 0);
    }
}
