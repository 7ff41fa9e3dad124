//! The separating-axis cache: for each pair of shapes the last step found
//! farther apart than their speculative distance, the axis that showed it
//! (see [`crate::rigid::narrow::Apart`]), in A's body frame so that it
//! turns with A.
//!
//! Most pairs the broad phase hands over are apart (about three in four in
//! a falling pile of hulls), and stay apart for many steps. Projecting
//! both shapes on the old axis costs two support queries where GJK takes
//! several iterations and the separating-axis test every face; Box3D's
//! hull cache (`b3SATCache`) and Bullet's cached separating axis exit
//! early the same way.
//!
//! The axes only ever skip a test whose answer is "apart", so no result
//! depends on them: they are derived, neither saved nor hashed, and are
//! forgotten with the broad phase (after a restore or a removal).

use glam::DVec3;

use super::cache::Cursor;
use super::ContactKey;

/// Each pair found apart by the last step, with its axis, in increasing
/// key order (keys unique).
#[derive(Debug, Clone, Default)]
pub(crate) struct SeparatingAxes {
    entries: Vec<(ContactKey, DVec3)>,
    /// An empty list with the memory of the step before's, for the narrow
    /// phase to fill (tens of thousands of pairs in a pile: not allocated
    /// and faulted in anew every step).
    spare: Vec<(ContactKey, DVec3)>,
}

impl SeparatingAxes {
    /// The axes of `entries`, which must be in increasing key order (the
    /// narrow phase finds them in pair order, which is key order).
    #[cfg(test)]
    fn new(entries: Vec<(ContactKey, DVec3)>) -> Self {
        let mut axes = Self::default();
        axes.replace(entries);
        axes
    }

    /// Number of pairs with an axis.
    #[cfg(test)]
    fn len(&self) -> usize {
        self.entries.len()
    }

    /// A cursor from the first key not below `from`.
    pub(crate) fn cursor_from(&self, from: &ContactKey) -> Cursor<'_, DVec3> {
        Cursor::from(&self.entries, from)
    }

    /// An empty list to fill with this step's axes, taken out (emptied
    /// where [`Self::replace`] put it aside).
    pub(crate) fn take_spare(&mut self) -> Vec<(ContactKey, DVec3)> {
        std::mem::take(&mut self.spare)
    }

    /// This step's axes replace the last step's (`entries` in increasing
    /// key order, as the narrow phase finds them: pair order is key order).
    pub(crate) fn replace(&mut self, entries: Vec<(ContactKey, DVec3)>) {
        debug_assert!(entries.is_sorted_by(|x, y| x.0 < y.0));
        self.spare = std::mem::replace(&mut self.entries, entries);
        self.spare.clear();
    }

    /// Forgets every axis.
    pub(crate) fn clear(&mut self) {
        self.entries.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(a: u32) -> ContactKey {
        ContactKey {
            a: (a, 0),
            b: (a + 1, 0),
            child_a: 0,
            child_b: 0,
        }
    }

    #[test]
    fn a_cursor_finds_the_axes_of_pairs_asked_in_order() {
        let axes = SeparatingAxes::new((0..5).map(|i| (key(2 * i), DVec3::X * i as f64)).collect());
        assert_eq!(axes.len(), 5);
        let mut cursor = axes.cursor_from(&key(1));
        assert!(cursor.get(&key(1)).is_none());
        assert_eq!(cursor.get(&key(2)), Some(&DVec3::X));
        assert_eq!(cursor.get(&key(8)), Some(&(DVec3::X * 4.0)));
        let mut axes = axes;
        axes.clear();
        assert!(axes.cursor_from(&key(0)).get(&key(0)).is_none());
    }
}
