//! Visiting the entries of an id-keyed map that a snapshot's states name.
//! The decoder yields them ascending by id, so when they are many of the
//! map's entries the map's range between the first and the last is walked
//! beside them; when they are few (a snapshot of a thousand-entity world
//! carries a hundred or so, spread over every id), each is looked up.

use std::collections::BTreeMap;

use inertia_protocol::snapshot::ViewEntity;
use inertia_protocol::EntityId;

/// Below one state for this many entries of the map, the states are
/// looked up one by one rather than walked beside (a walk steps through
/// every entry between the first state and the last).
const WALK_FRACTION: usize = 4;

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
    if states.len() * WALK_FRACTION < map.len() {
        let mut prev = None;
        for &state in states {
            if prev.is_some_and(|p| p >= state.id) {
                // Out of order: the rest are the caller's.
                break;
            }
            prev = Some(state.id);
            if let Some(entry) = map.get_mut(&state.id) {
                visit(entry, state);
                visited += 1;
            }
        }
        return visited;
    }
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
