//! The priority accumulator (after Glenn Fiedler's "State
//! Synchronization", gafferongames.com, 2015): each snapshot adds every
//! waiting entity's priority to what it has accumulated, the encoder sends
//! the highest first until the budget is spent, and what was sent starts
//! again from zero. An entity left out keeps growing until it outranks the
//! rest, so nothing that differs from the client's view waits forever.
//!
//! The per-snapshot priority is a base by kind of motion (the always
//! relevant highest, moving bodies high, resting ones low) times the
//! entity's [`Interest`] weight.

use glam::DVec3;
use rustc_hash::FxHashMap;

use crate::entity::EntityId;
use crate::interest::Interest;

/// Per-snapshot priority by kind of motion (dimensionless; only ratios
/// matter).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PriorityWeights {
    /// Entities in [`Interest::always_relevant`] (avatars).
    pub always_relevant: f64,
    /// Awake bodies.
    pub moving: f64,
    /// Sleeping bodies (their state changed once, as they settled).
    pub at_rest: f64,
}

impl Default for PriorityWeights {
    /// 1000 : 10 : 1. An avatar goes out in every snapshot; a settling body
    /// waits at most about ten snapshots behind moving ones.
    fn default() -> Self {
        Self {
            always_relevant: 1000.0,
            moving: 10.0,
            at_rest: 1.0,
        }
    }
}

/// Accumulated priority of every entity waiting to be sent to one client.
#[derive(Debug, Clone, Default)]
pub struct PriorityAccumulator {
    weights: PriorityWeights,
    interest: Interest,
    accumulated: FxHashMap<EntityId, f64>,
}

impl PriorityAccumulator {
    /// An accumulator with default weights, interested in `interest`.
    pub fn new(interest: Interest) -> Self {
        Self::with_weights(interest, PriorityWeights::default())
    }

    /// An accumulator with the given weights.
    pub fn with_weights(interest: Interest, weights: PriorityWeights) -> Self {
        Self {
            weights,
            interest,
            accumulated: FxHashMap::default(),
        }
    }

    /// The client's interest.
    pub fn interest(&self) -> &Interest {
        &self.interest
    }

    /// The client's interest, to change in place.
    pub fn interest_mut(&mut self) -> &mut Interest {
        &mut self.interest
    }

    /// Changes the client's interest (its camera moved).
    pub fn set_interest(&mut self, interest: Interest) {
        self.interest = interest;
    }

    /// How much entity `id` at `position` (m) matters to this client, 0
    /// (not sent) to 1.
    pub fn relevance(&self, id: EntityId, position: DVec3) -> f64 {
        self.interest.weight(id, position)
    }

    /// Adds one snapshot's priority of entity `id` (sleeping when
    /// `asleep`, of relevance `relevance`) and returns its accumulated
    /// priority.
    pub fn accumulate(&mut self, id: EntityId, asleep: bool, relevance: f64) -> f64 {
        let base = if self.interest.always_relevant.contains(&id) {
            self.weights.always_relevant
        } else if asleep {
            self.weights.at_rest
        } else {
            self.weights.moving
        };
        let p = self.accumulated.entry(id).or_insert(0.0);
        *p += base * relevance;
        *p
    }

    /// `id` was sent: it starts again from zero.
    pub fn sent(&mut self, id: EntityId) {
        self.accumulated.remove(&id);
    }

    /// The accumulated priority of `id` (0 when not waiting).
    pub fn accumulated(&self, id: EntityId) -> f64 {
        self.accumulated.get(&id).copied().unwrap_or(0.0)
    }

    /// Keeps only the entities for which `keep` holds (the others are in
    /// sync, out of view or gone).
    pub fn retain(&mut self, mut keep: impl FnMut(EntityId) -> bool) {
        self.accumulated.retain(|&id, _| keep(id));
    }

    /// Entities waiting.
    pub fn waiting(&self) -> usize {
        self.accumulated.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::entity::EntityState;
    use glam::DQuat;

    fn state(id: EntityId, asleep: bool) -> EntityState {
        EntityState {
            id,
            position: DVec3::ZERO,
            rotation: DQuat::IDENTITY,
            linear_velocity: DVec3::ZERO,
            angular_velocity: DVec3::ZERO,
            asleep,
        }
    }

    #[test]
    fn unsent_entities_accumulate_until_they_outrank_the_rest() {
        let mut p = PriorityAccumulator::new(Interest::everything());
        let (moving, resting) = (state(1, false), state(2, true));
        // One slot a snapshot: the resting body gets it within ten or so.
        let mut resting_sent_after = None;
        for k in 0..20 {
            let a = p.accumulate(moving.id, moving.asleep, 1.0);
            let b = p.accumulate(resting.id, resting.asleep, 1.0);
            if b > a {
                p.sent(2);
                resting_sent_after = Some(k);
                break;
            }
            p.sent(1);
        }
        assert_eq!(resting_sent_after, Some(10));
        assert_eq!(p.accumulated(2), 0.0);
        p.retain(|id| id == 2);
        assert_eq!(p.waiting(), 0);
    }
}
