//! The bodies of one step numbered `0..n` in handle order: the slots the
//! solver's arrays, the contacts and the islands are indexed by.

use crate::arena::Arena;
use crate::handle::BodyHandle;
use crate::rigid::body::RigidBody;

/// The bodies of this step numbered `0..n` in handle order (their *slots*,
/// the index of each body in the solver's arrays).
#[derive(Debug)]
pub(crate) struct BodyIndex {
    /// Handle of each slot.
    pub(crate) handles: Vec<BodyHandle>,
    /// Slot of each arena index, or `u32::MAX` for a free arena entry.
    slot_of: Vec<u32>,
}

impl BodyIndex {
    pub(crate) fn new(bodies: &Arena<RigidBody>) -> Self {
        let handles: Vec<BodyHandle> = bodies
            .iter()
            .map(|(index, generation, _)| BodyHandle { index, generation })
            .collect();
        let mut slot_of = vec![u32::MAX; bodies.entries.len()];
        for (k, h) in handles.iter().enumerate() {
            slot_of[h.index as usize] = k as u32;
        }
        Self { handles, slot_of }
    }

    /// The slot of the body at arena index `index` (a broad-phase key).
    #[inline]
    pub(crate) fn slot_of_index(&self, index: u32) -> Option<usize> {
        match self.slot_of.get(index as usize) {
            Some(&k) if k != u32::MAX => Some(k as usize),
            _ => None,
        }
    }

    /// The slot of a live body.
    #[inline]
    pub(crate) fn slot(&self, h: BodyHandle) -> Option<usize> {
        self.slot_of_index(h.index)
            .filter(|&k| self.handles[k] == h)
    }
}
