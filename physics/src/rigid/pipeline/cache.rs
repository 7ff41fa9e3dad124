//! The contact cache: each manifold of the last step with its impulses,
//! in key order (world state: saved and hashed in that order).
//!
//! It is rebuilt every step from the manifolds found, which come in pair
//! order, so in key order already: a sorted vector takes them as they are
//! (a tree would allocate a node for every few of them and move each
//! entry in), and the narrow phase's lookups, also in key order, walk it
//! front to back.

use std::collections::BTreeMap;

use super::{CachedManifold, ContactKey, PairContact};
use crate::arena::Arena;
use crate::handle::BodyHandle;
use crate::rigid::body::RigidBody;

/// Each manifold of the last step, in increasing key order, keys unique.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct ContactCache {
    entries: Vec<(ContactKey, CachedManifold)>,
}

impl ContactCache {
    /// The cache of `entries`; sorted by key first where they are not (a
    /// later entry wins over an earlier one with the same key).
    pub(crate) fn new(mut entries: Vec<(ContactKey, CachedManifold)>) -> Self {
        if !entries.is_sorted_by(|x, y| x.0 < y.0) {
            // Stable: entries with the same key keep their order, so the
            // last of them is the one kept.
            entries.sort_by_key(|e| e.0);
            entries.reverse();
            entries.dedup_by_key(|e| e.0);
            entries.reverse();
        }
        Self { entries }
    }

    /// Number of manifolds.
    pub(crate) fn len(&self) -> usize {
        self.entries.len()
    }

    /// The manifolds in key order.
    pub(crate) fn iter(&self) -> impl Iterator<Item = (&ContactKey, &CachedManifold)> {
        self.entries.iter().map(|(k, m)| (k, m))
    }

    /// Keeps the manifolds whose key `keep` accepts (asked in key order).
    pub(crate) fn retain(&mut self, mut keep: impl FnMut(&ContactKey) -> bool) {
        self.entries.retain(|(k, _)| keep(k));
    }

    /// Adds `fresh` (in key order, keys not in the cache), keeping the key
    /// order: one merge of the two.
    pub(crate) fn merge(&mut self, fresh: Vec<(ContactKey, CachedManifold)>) {
        if fresh.is_empty() {
            return;
        }
        let old = std::mem::take(&mut self.entries);
        let mut out = Vec::with_capacity(old.len() + fresh.len());
        let mut fresh = fresh.into_iter().peekable();
        for entry in old {
            while let Some(f) = fresh.next_if(|f| f.0 < entry.0) {
                out.push(f);
            }
            if fresh.peek().is_some_and(|f| f.0 == entry.0) {
                // A key in both: the fresh manifold replaces the old one.
                continue;
            }
            out.push(entry);
        }
        out.extend(fresh);
        self.entries = out;
    }

    /// A cursor from the first key not below `from`.
    pub(crate) fn cursor_from(&self, from: &ContactKey) -> Cursor<'_> {
        Cursor::from(&self.entries, from)
    }
}

/// The pairs of bodies that `manifolds` (in key order) join, each with
/// what its manifolds found at the step that last solved them: their
/// impulses summed, their smallest separation, their points counted, and
/// the normal of the one that pushed hardest (of the deepest while none
/// has pushed), turned with A as it stands in `bodies`.
pub(crate) fn pair_contacts<'a>(
    manifolds: impl Iterator<Item = (&'a ContactKey, &'a CachedManifold)> + 'a,
    bodies: &'a Arena<RigidBody>,
) -> impl Iterator<Item = PairContact> + 'a {
    let handle = |(index, generation): (u32, u32)| BodyHandle { index, generation };
    let normal = move |k: &ContactKey, m: &CachedManifold| {
        let n = m.normal_a.as_dvec3();
        match bodies.get(k.a.0, k.a.1) {
            Some(a) => (a.rotation * n).normalize(),
            None => n,
        }
    };
    let mut manifolds = manifolds.peekable();
    std::iter::from_fn(move || {
        let (key, first) = manifolds.next()?;
        let mut pair = PairContact {
            a: handle(key.a),
            b: handle(key.b),
            normal: normal(key, first),
            separation: f64::from(first.separation),
            impulse: f64::from(first.impulse),
            points: first.points.len(),
        };
        // The impulse of the hardest-pushing manifold so far, N·s.
        let mut hardest = pair.impulse;
        while let Some((k, m)) = manifolds.next_if(|(k, _)| (k.a, k.b) == (key.a, key.b)) {
            let (impulse, separation) = (f64::from(m.impulse), f64::from(m.separation));
            let harder = impulse > hardest;
            let deeper = hardest == 0.0 && impulse == 0.0 && separation < pair.separation;
            if harder || deeper {
                pair.normal = normal(k, m);
            }
            hardest = hardest.max(impulse);
            pair.impulse += impulse;
            pair.separation = pair.separation.min(separation);
            pair.points += m.points.len();
        }
        Some(pair)
    })
}

impl From<BTreeMap<ContactKey, CachedManifold>> for ContactCache {
    fn from(map: BTreeMap<ContactKey, CachedManifold>) -> Self {
        Self {
            entries: map.into_iter().collect(),
        }
    }
}

/// Walks entries in key order (the cache's, or the separating axes')
/// alongside a run of pairs, which ask for keys in increasing order: each
/// lookup is a step or two instead of a search.
pub(crate) struct Cursor<'a, V = CachedManifold> {
    rest: &'a [(ContactKey, V)],
}

impl<'a, V> Cursor<'a, V> {
    /// A cursor over `entries` (in increasing key order) from the first
    /// key not below `from`.
    pub(crate) fn from(entries: &'a [(ContactKey, V)], from: &ContactKey) -> Self {
        let at = entries.partition_point(|(k, _)| k < from);
        Cursor {
            rest: &entries[at..],
        }
    }

    /// The entry of `key` (keys asked for must not decrease).
    pub(crate) fn get(&mut self, key: &ContactKey) -> Option<&'a V> {
        while let Some(((k, _), rest)) = self.rest.split_first() {
            if k >= key {
                break;
            }
            self.rest = rest;
        }
        match self.rest.first() {
            Some((k, m)) if k == key => {
                self.rest = &self.rest[1..];
                Some(m)
            }
            _ => None,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn key(a: u32, child: u32) -> ContactKey {
        ContactKey {
            a: (a, 0),
            b: (a + 1, 0),
            child_a: child,
            child_b: 0,
        }
    }

    fn manifold(x: f32) -> CachedManifold {
        CachedManifold {
            normal_a: glam::Vec3::new(x, 0.0, 0.0),
            ..CachedManifold::default()
        }
    }

    #[test]
    fn unsorted_entries_are_sorted_and_the_last_of_a_key_wins() {
        let c = ContactCache::new(vec![
            (key(3, 0), manifold(1.0)),
            (key(1, 0), manifold(2.0)),
            (key(3, 0), manifold(3.0)),
        ]);
        let got: Vec<(u32, f32)> = c.iter().map(|(k, m)| (k.a.0, m.normal_a.x)).collect();
        assert_eq!(got, [(1, 2.0), (3, 3.0)]);
    }

    #[test]
    fn merging_keeps_key_order_and_fresh_entries_replace_old_ones() {
        let mut c = ContactCache::new(vec![(key(1, 0), manifold(1.0)), (key(5, 0), manifold(5.0))]);
        c.merge(vec![
            (key(0, 0), manifold(0.5)),
            (key(5, 0), manifold(50.0)),
            (key(9, 0), manifold(9.0)),
        ]);
        let got: Vec<(u32, f32)> = c.iter().map(|(k, m)| (k.a.0, m.normal_a.x)).collect();
        assert_eq!(got, [(0, 0.5), (1, 1.0), (5, 50.0), (9, 9.0)]);
    }

    /// A compound pressed on through several manifolds reports the normal
    /// of the one that pushed hardest, not of the first whose impulse
    /// outgrew the sum so far; the pair's impulse is their sum, its
    /// separation their smallest, and the next pair starts afresh.
    #[test]
    fn issue_13_a_pair_contact_takes_the_normal_of_its_hardest_manifold() {
        let mut bodies = Arena::default();
        let body = || {
            crate::rigid::body::RigidBodyDesc::fixed(
                crate::rigid::shape::Shape::sphere(1.0).unwrap(),
                crate::rigid::pose::Pose::IDENTITY,
            )
            .build()
            .unwrap()
        };
        for _ in 0..3 {
            bodies.insert(body());
        }
        let pressed = |child: u32, normal: glam::Vec3, impulse: f32, separation: f32| {
            let key = ContactKey {
                a: (1, 0),
                b: (2, 0),
                child_a: child,
                child_b: 0,
            };
            let m = CachedManifold {
                normal_a: normal,
                impulse,
                separation,
                points: vec![Default::default(); 2],
                ..CachedManifold::default()
            };
            (key, m)
        };
        let mut found = vec![
            pressed(0, glam::Vec3::X, 1.0, -0.01),
            pressed(1, glam::Vec3::Y, 1.5, 0.0),
            pressed(2, glam::Vec3::Z, 2.0, -0.02),
        ];
        let mut other = pressed(0, glam::Vec3::NEG_X, 0.0, 0.01);
        other.0.b = (0, 0);
        other.0.a = (0, 0);
        found.insert(0, other);
        let cache = ContactCache::new(found);
        let pairs: Vec<PairContact> = pair_contacts(cache.iter(), &bodies).collect();
        assert_eq!(pairs.len(), 2);
        assert_eq!(pairs[0].normal, glam::DVec3::NEG_X);
        let p = pairs[1];
        assert_eq!((p.a.index, p.b.index), (1, 2));
        assert_eq!(p.normal, glam::DVec3::Z);
        assert_eq!(p.impulse, 4.5);
        assert_eq!(p.separation, f64::from(-0.02f32));
        assert_eq!(p.points, 6);
    }

    #[test]
    fn a_cursor_finds_keys_asked_in_order() {
        let c = ContactCache::new(
            (0..10)
                .map(|i| (key(2 * i, 0), manifold(i as f32)))
                .collect(),
        );
        let mut cursor = c.cursor_from(&key(3, 0));
        assert!(cursor.get(&key(3, 0)).is_none());
        assert_eq!(cursor.get(&key(4, 0)).map(|m| m.normal_a.x), Some(2.0));
        assert!(cursor.get(&key(4, 1)).is_none());
        assert_eq!(cursor.get(&key(18, 0)).map(|m| m.normal_a.x), Some(9.0));
        assert!(cursor.get(&key(19, 0)).is_none());
    }
}
