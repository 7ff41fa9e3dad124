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

/// What an entity is to one client, which sets the base of its
/// per-snapshot priority ([`PriorityWeights`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Standing {
    /// In the client's [`Interest::always_relevant`].
    AlwaysRelevant,
    /// An awake body.
    Moving,
    /// A sleeping body.
    AtRest,
}

impl Standing {
    /// The standing of an entity in the always relevant or not, asleep or
    /// not (the always relevant rank first, asleep or not).
    pub fn new(always_relevant: bool, asleep: bool) -> Self {
        if always_relevant {
            Self::AlwaysRelevant
        } else if asleep {
            Self::AtRest
        } else {
            Self::Moving
        }
    }
}

/// Accumulated priority of every entity waiting to be sent to one client.
///
/// One snapshot is one *round*: the encoder accumulates the entities that
/// differ from the client's view in ascending id order (each step a walk
/// forwards, no lookup), ends the round, and marks what it sent. Entities
/// not accumulated in a round stop waiting (they are in sync, out of view
/// or gone).
#[derive(Debug, Clone, Default)]
pub struct PriorityAccumulator {
    weights: PriorityWeights,
    interest: Interest,
    /// Waiting entities and what they have accumulated, ascending by id
    /// (a sent one holds 0 until the next round drops or restarts it).
    waiting: Vec<(EntityId, f64)>,
    /// The round being accumulated, ascending by id.
    round: Vec<(EntityId, f64)>,
    /// How far the round's walk through `waiting` has come.
    cursor: usize,
    /// A round is being accumulated.
    open: bool,
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
            ..Self::default()
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

    /// Adds this round's priority of entity `id` (sleeping when `asleep`,
    /// of relevance `relevance`) and returns its accumulated priority.
    /// Called in ascending id order within a round it is a step forwards;
    /// out of order, a search.
    pub fn accumulate(&mut self, id: EntityId, asleep: bool, relevance: f64) -> f64 {
        let standing = Standing::new(self.interest.always_relevant.contains(&id), asleep);
        self.accumulate_as(id, standing, relevance)
    }

    /// [`Self::accumulate`] for a caller that knows the entity's
    /// [`Standing`] already (the encoder walks the always relevant beside
    /// the frame, in id order, instead of looking each entity up). Inlined
    /// into the encoder's walk, which calls it for every entity of every
    /// snapshot: as a call its entry and exit took a quarter of its
    /// instructions.
    #[inline(always)]
    pub fn accumulate_as(&mut self, id: EntityId, standing: Standing, relevance: f64) -> f64 {
        let base = match standing {
            Standing::AlwaysRelevant => self.weights.always_relevant,
            Standing::Moving => self.weights.moving,
            Standing::AtRest => self.weights.at_rest,
        };
        let add = base * relevance;
        if !self.open {
            self.open = true;
            self.round.clear();
            self.cursor = 0;
        }
        if self.round.last().is_some_and(|&(last, _)| last >= id) {
            return self.accumulate_out_of_order(id, add);
        }
        while self.waiting.get(self.cursor).is_some_and(|&(w, _)| w < id) {
            self.cursor += 1;
        }
        let old = match self.waiting.get(self.cursor) {
            Some(&(w, p)) if w == id => p,
            _ => 0.0,
        };
        self.round.push((id, old + add));
        old + add
    }

    /// [`Self::accumulate_as`] of an id at or below the last of the round:
    /// a search.
    #[cold]
    fn accumulate_out_of_order(&mut self, id: EntityId, add: f64) -> f64 {
        match self.round.binary_search_by_key(&id, |e| e.0) {
            Ok(i) => {
                self.round[i].1 += add;
                self.round[i].1
            }
            Err(i) => {
                let p = self.waiting_value(id) + add;
                self.round.insert(i, (id, p));
                p
            }
        }
    }

    /// Ends the round: the entities accumulated in it are the ones
    /// waiting now; the rest stop waiting. (Without a round since the
    /// last, nothing waits.)
    pub fn end_round(&mut self) {
        if !self.open {
            self.round.clear();
        }
        std::mem::swap(&mut self.waiting, &mut self.round);
        self.round.clear();
        self.open = false;
    }

    /// `id` was sent: it starts again from zero.
    pub fn sent(&mut self, id: EntityId) {
        let table = if self.open {
            &mut self.round
        } else {
            &mut self.waiting
        };
        if let Ok(i) = table.binary_search_by_key(&id, |e| e.0) {
            table[i].1 = 0.0;
        }
    }

    fn waiting_value(&self, id: EntityId) -> f64 {
        self.waiting
            .binary_search_by_key(&id, |e| e.0)
            .map_or(0.0, |i| self.waiting[i].1)
    }

    /// The accumulated priority of `id` (0 when not waiting), as of the
    /// round being accumulated if one is.
    pub fn accumulated(&self, id: EntityId) -> f64 {
        let table = if self.open {
            &self.round
        } else {
            &self.waiting
        };
        table
            .binary_search_by_key(&id, |e| e.0)
            .map_or(0.0, |i| table[i].1)
    }

    /// Entities waiting (with a priority above zero).
    pub fn waiting(&self) -> usize {
        let table = if self.open {
            &self.round
        } else {
            &self.waiting
        };
        table.iter().filter(|e| e.1 > 0.0).count()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::entity::EntityState;
    use glam::{DQuat, DVec3};

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
            p.end_round();
            if b > a {
                p.sent(2);
                resting_sent_after = Some(k);
                break;
            }
            p.sent(1);
        }
        assert_eq!(resting_sent_after, Some(10));
        assert_eq!(p.accumulated(2), 0.0);
        assert_eq!(p.waiting(), 1, "the moving body still waits");
        // A round without it: it is in sync and waits no more.
        p.accumulate(2, true, 1.0);
        p.end_round();
        assert_eq!(p.accumulated(1), 0.0);
        assert_eq!(p.waiting(), 1);
    }

    #[test]
    fn a_known_standing_accumulates_as_a_looked_up_one() {
        let mut interest = Interest::everything();
        interest.always_relevant.insert(4);
        let mut looked_up = PriorityAccumulator::new(interest.clone());
        let mut known = PriorityAccumulator::new(interest);
        for (id, asleep, standing) in [
            (1, false, Standing::Moving),
            (4, true, Standing::AlwaysRelevant),
            (9, true, Standing::AtRest),
        ] {
            let a = looked_up.accumulate(id, asleep, 0.5);
            let b = known.accumulate_as(id, standing, 0.5);
            assert_eq!(a, b, "entity {id}");
        }
        assert_eq!(known.accumulated(4), 500.0);
    }

    #[test]
    fn out_of_order_accumulation_gives_the_same_totals() {
        let mut a = PriorityAccumulator::new(Interest::everything());
        let mut b = PriorityAccumulator::new(Interest::everything());
        for _ in 0..3 {
            for id in [1, 4, 9] {
                a.accumulate(id, false, 0.5);
            }
            for id in [9, 1, 4] {
                b.accumulate(id, false, 0.5);
            }
            a.end_round();
            b.end_round();
        }
        for id in [1, 4, 9] {
            assert_eq!(a.accumulated(id), 15.0);
            assert_eq!(b.accumulated(id), 15.0);
        }
    }
}
