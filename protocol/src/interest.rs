//! Interest management: how much each entity matters to one client, by
//! distance from the client's point of interest (after Glenn Fiedler's
//! "State Synchronization", gafferongames.com, 2015, where priority is
//! scaled by relevance to the viewer).
//!
//! An entity within `radius_full` of the point has weight 1; between
//! `radius_full` and `radius_max` the weight falls linearly towards 0;
//! beyond `radius_max` it is 0 and the entity is not sent at all (the
//! client is told to hide it). Entities in `always_relevant` (the
//! client's avatar, a ball every player must see) weigh 1 wherever they
//! are.

use std::collections::BTreeSet;

use glam::DVec3;

use crate::entity::EntityId;

/// One client's interest in the world.
#[derive(Debug, Clone, PartialEq)]
pub struct Interest {
    /// Where the client looks from (its camera or avatar), m.
    pub point: DVec3,
    /// Within this distance of `point` everything has weight 1, m.
    pub radius_full: f64,
    /// Beyond this distance nothing is sent, m (at least `radius_full`;
    /// infinite for no limit).
    pub radius_max: f64,
    /// Entities that weigh 1 wherever they are.
    pub always_relevant: BTreeSet<EntityId>,
}

impl Default for Interest {
    /// Everything, everywhere, with weight 1.
    fn default() -> Self {
        Self::everything()
    }
}

impl Interest {
    /// Every entity with weight 1, wherever it is.
    pub fn everything() -> Self {
        Self::around(DVec3::ZERO, f64::INFINITY, f64::INFINITY)
    }

    /// Weight 1 within `radius_full` m of `point`, falling to 0 at
    /// `radius_max` m.
    pub fn around(point: DVec3, radius_full: f64, radius_max: f64) -> Self {
        Self {
            point,
            radius_full,
            radius_max,
            always_relevant: BTreeSet::new(),
        }
    }

    /// How much entity `id` at `position` (m) matters: 1 near, falling
    /// linearly to 0 at `radius_max`, 0 beyond (and for a non-finite
    /// position), 1 for the always relevant. Within `radius_max` the weight
    /// is never 0, so every entity in range is eventually sent.
    pub fn weight(&self, id: EntityId, position: DVec3) -> f64 {
        if self.always_relevant.contains(&id) {
            return 1.0;
        }
        self.distance_weight(position)
    }

    /// How much an entity at `position` (m) matters by its distance alone
    /// (what [`Self::weight`] gives one not always relevant).
    pub fn distance_weight(&self, position: DVec3) -> f64 {
        // Squared first: most entities of most worlds fall inside the full
        // radius (all of them with no limit), and need no square root.
        let d2 = position.distance_squared(self.point);
        if d2.is_nan() {
            return 0.0;
        }
        if d2 <= self.radius_full * self.radius_full {
            return 1.0;
        }
        let d = d2.sqrt();
        if d <= self.radius_full {
            1.0
        } else if d >= self.radius_max {
            0.0
        } else if self.radius_max.is_infinite() {
            // No outer limit: fall off as full / distance instead.
            (self.radius_full / d).max(f64::MIN_POSITIVE)
        } else {
            ((self.radius_max - d) / (self.radius_max - self.radius_full)).max(f64::MIN_POSITIVE)
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn weight_is_one_near_falls_off_and_is_zero_beyond() {
        let mut i = Interest::around(DVec3::new(10.0, 0.0, 0.0), 5.0, 15.0);
        i.always_relevant.insert(7);
        let at = |x: f64| DVec3::new(10.0 + x, 0.0, 0.0);
        assert_eq!(i.weight(1, at(0.0)), 1.0);
        assert_eq!(i.weight(1, at(5.0)), 1.0);
        assert!((i.weight(1, at(10.0)) - 0.5).abs() < 1e-12);
        assert!(i.weight(1, at(14.999_999)) > 0.0);
        assert_eq!(i.weight(1, at(15.0)), 0.0);
        assert_eq!(i.weight(1, at(1e9)), 0.0);
        assert_eq!(i.weight(7, at(1e9)), 1.0);
        assert_eq!(i.weight(1, DVec3::NAN), 0.0);
        assert_eq!(Interest::everything().weight(1, at(1e12)), 1.0);
    }
}
