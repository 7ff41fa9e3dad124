//! Visiting, in one walk, the entries of an id-keyed map that a snapshot's
//! states name: the decoder yields them ascending by id, so the map's
//! range between the first and the last is walked beside them instead of
//! searched once per state.

use std::collections::BTreeMap;

use inertia_protocol::snapshot::ViewEntity;
use inertia_protocol::EntityId;

/// Calls `visit` with the entry of `map` and the state, for every state
/// in `states` (ascending by id) that has an entry; returns how many had
/// one. States out of order, or without an entry, are not visited: when
/// the count falls short of `states.len()` the caller takes the rest one
/// by one.
pub(crate) fn visit_beside<V>(
    map: &mut BTreeMap<EntityId, V>,
    states: &[ViewEntity],
    mut visit: impl FnMut(&mut V, ViewEntity),
) -> usize {
    let (Some(first), Some(last)) = (states.first(), states.last()) else {
        return 0;
    };
    if first.id > last.id {
        return 0;
    }
    let mut visited = 0;
    let mut rest = states.iter().peekable();
    for (&id, entry) in map.range_mut(first.id..=last.id) {
        while rest.next_if(|s| s.id < id).is_some() {}
        if let Some(&state) = rest.next_if(|s| s.id == id) {
            visit(entry, state);
            visited += 1;
        }
    }
    visited
}
