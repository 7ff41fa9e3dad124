//! Lines of simulated time: the live one players are in and, while an
//! operator looks at history, the one shown in its place (see
//! [`time_travel`](super::time_travel)).

use std::collections::BTreeSet;

use inertia_physics::glam::DVec3;
use inertia_physics::World;

use super::time_travel::ShownHistory;
use crate::clock::Clock;
use crate::pose_history::PoseHistory;
use crate::properties::PropertyStore;
use crate::rules::ClientId;
use crate::scene::EntityTable;

/// One line of simulated time: the world and what the clock and the
/// server keep beside it.
#[derive(Debug)]
pub(crate) struct Timeline {
    pub(super) world: World,
    pub(super) entities: EntityTable,
    pub(super) clients: BTreeSet<ClientId>,
    pub(super) spawn_points: Vec<DVec3>,
    pub(super) clock: Clock,
    /// The moving bodies' poses over the last ticks, for lag
    /// compensation ([`crate::pose_history`]).
    pub(super) poses: PoseHistory,
    /// The game's properties ([`crate::properties`]).
    pub(super) properties: PropertyStore,
}

impl Timeline {
    /// The state hash of this timeline under rules whose state hashes to
    /// `rules` ([`crate::rules::GameRules::state_hash`]): see
    /// [`state_hash`].
    pub(super) fn state_hash(&self, rules: u64) -> u64 {
        state_hash(self.world.state_hash(), self.properties.hash(), rules)
    }
}

/// The hash a recording keeps for a tick: the world's, with the game's
/// properties and the rules' own state folded in (0 each for a game
/// without properties and rules that remember nothing, so such a game
/// hashes as its world alone).
pub(super) fn state_hash(world: u64, properties: u64, rules: u64) -> u64 {
    world ^ properties.rotate_left(21) ^ rules.rotate_left(42)
}

/// The live timeline and the history shown instead of it, if any.
pub(super) struct Timelines {
    /// What players are in. While history is shown it stands still, and
    /// joins and leaves still reach it.
    pub(super) live: Timeline,
    /// History shown instead of the live timeline, if any.
    pub(super) past: Option<ShownHistory>,
}

impl Timelines {
    /// The timeline shown, ticked and streamed: history while it is
    /// shown, else the live one.
    pub(super) fn shown(&self) -> &Timeline {
        match &self.past {
            Some(view) => &view.shown,
            None => &self.live,
        }
    }

    /// [`Self::shown`], to change.
    pub(super) fn shown_mut(&mut self) -> &mut Timeline {
        match &mut self.past {
            Some(view) => &mut view.shown,
            None => &mut self.live,
        }
    }

    /// Whether the live timeline is shown.
    pub(super) fn is_live(&self) -> bool {
        self.past.is_none()
    }
}
