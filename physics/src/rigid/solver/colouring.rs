//! Graph colouring of the constraints, so one colour's constraints can be
//! solved in parallel.
//!
//! Two constraints that move a common body cannot be solved at the same
//! time. Giving each constraint a colour such that no two constraints of a
//! colour share a *movable* body (bodies that never move — static, asleep,
//! kinematic — may be shared: the solver only reads them) lets the solver
//! run colour after colour, with every colour's constraints spread over the
//! threads. The colouring is greedy, in constraint order, so it is a fixed
//! function of the constraint list: the solve order, and so every bit of the
//! result, does not depend on the number of threads. Constraints that find
//! no free colour among [`MAX_COLOURS`] go to an overflow set solved on one
//! thread after the colours (Box2D v3 does the same).

use std::marker::PhantomData;
use std::ops::Range;

use crate::rigid::solver::SolverBody;

/// Colours tried before a constraint overflows (one bit each in a `u64`).
pub(crate) const MAX_COLOURS: usize = 64;

/// Constraints per parallel work item; a colour smaller than two items
/// runs on the calling thread.
const ITEM: usize = 64;

/// The colour of each constraint, or [`MAX_COLOURS`] for the overflow.
///
/// `ends[k]` are the two bodies of constraint `k`; `movable[i]` says whether
/// body `i` can be moved by a constraint (only those count as shared).
pub(crate) fn colour(ends: &[(usize, usize)], movable: &[bool]) -> Vec<u8> {
    let mut used = vec![0u64; movable.len()];
    ends.iter()
        .map(|&(a, b)| {
            let mask = |i: usize| if movable[i] { used[i] } else { 0 };
            let free = !(mask(a) | mask(b));
            if free == 0 {
                return MAX_COLOURS as u8;
            }
            let c = free.trailing_zeros();
            for i in [a, b] {
                if movable[i] {
                    used[i] |= 1 << c;
                }
            }
            c as u8
        })
        .collect()
}

/// The constraints in solve order (colour by colour, constraint order
/// within a colour) and the range of `order` each colour takes, the
/// overflow last.
#[derive(Debug, Default)]
pub(crate) struct Groups {
    pub(crate) order: Vec<u32>,
    pub(crate) ranges: Vec<Range<usize>>,
}

/// Groups the constraints by their colours (a counting sort: stable).
pub(crate) fn group(colours: &[u8]) -> Groups {
    let mut count = [0usize; MAX_COLOURS + 1];
    for &c in colours {
        count[c as usize] += 1;
    }
    let mut start = [0usize; MAX_COLOURS + 1];
    let mut ranges = Vec::new();
    let mut at = 0;
    for (c, &n) in count.iter().enumerate() {
        start[c] = at;
        if n > 0 {
            ranges.push(at..at + n);
        }
        at += n;
    }
    let mut order = vec![0u32; colours.len()];
    for (k, &c) in colours.iter().enumerate() {
        order[start[c as usize]] = k as u32;
        start[c as usize] += 1;
    }
    Groups { order, ranges }
}

/// A slice lent to the workers of one colour at a time: each worker takes
/// the elements its constraints own.
pub(crate) struct Shared<'a, T> {
    ptr: *mut T,
    len: usize,
    _lifetime: PhantomData<&'a mut [T]>,
}

// SAFETY: `Shared` only hands out a `&mut` to an element to the one
// constraint of the current colour that owns it (see `solve_coloured`), and
// only copies of elements that nobody writes while the colour runs; so
// sharing it between the threads of a colour creates no aliasing `&mut`.
unsafe impl<T: Send> Sync for Shared<'_, T> {}

impl<'a, T> Shared<'a, T> {
    pub(crate) fn new(items: &'a mut [T]) -> Self {
        Self {
            ptr: items.as_mut_ptr(),
            len: items.len(),
            _lifetime: PhantomData,
        }
    }

    /// A copy of element `i` (one that nobody writes while this runs).
    pub(crate) fn read(&self, i: usize) -> T
    where
        T: Copy,
    {
        assert!(i < self.len, "index {i} out of {}", self.len);
        // SAFETY: `i` is in bounds; elements read this way are never written
        // while a colour runs, so the read races with no write.
        unsafe { *self.ptr.add(i) }
    }

    /// Element `i`, exclusively.
    ///
    /// # Safety
    /// No other reference to element `i` may exist while the result lives.
    #[allow(clippy::mut_from_ref)]
    pub(crate) unsafe fn get(&self, i: usize) -> &mut T {
        assert!(i < self.len, "index {i} out of {}", self.len);
        // SAFETY: in bounds (checked above); exclusive by the caller's
        // guarantee.
        unsafe { &mut *self.ptr.add(i) }
    }

    /// Elements `start..start + len`, exclusively.
    ///
    /// # Safety
    /// No other reference to any of them may exist while the result lives.
    #[allow(clippy::mut_from_ref)]
    pub(crate) unsafe fn get_range(&self, start: usize, len: usize) -> &mut [T] {
        assert!(
            start <= self.len && len <= self.len - start,
            "range {start}+{len} out of {}",
            self.len
        );
        // SAFETY: in bounds (checked above); exclusive by the caller's
        // guarantee.
        unsafe { std::slice::from_raw_parts_mut(self.ptr.add(start), len) }
    }
}

/// Runs `f(constraint, body_a, body_b)` over every constraint in the order
/// of `groups`: colour by colour, each colour in parallel; the overflow
/// (colour [`MAX_COLOURS`]) on the calling thread. Immovable bodies are
/// passed as copies, so what `f` does to them is dropped.
pub(crate) fn solve_coloured<C, F>(
    constraints: &mut [C],
    groups: &Groups,
    colours: &[u8],
    ends: impl Fn(&C) -> (usize, usize) + Sync,
    bodies: &mut [SolverBody],
    movable: &[bool],
    f: F,
) where
    C: Send,
    F: Fn(&mut C, &mut SolverBody, &mut SolverBody) + Sync,
{
    assert_eq!(groups.order.len(), constraints.len());
    let shared_bodies = Shared::new(bodies);
    let shared_constraints = Shared::new(constraints);
    let one = |k: u32| {
        // SAFETY: `order` names every constraint exactly once (a
        // permutation from `group`), so constraint `k` is solved by this
        // call only.
        let c = unsafe { shared_constraints.get(k as usize) };
        let (a, b) = ends(c);
        assert_ne!(a, b, "a constraint joins two different bodies");
        let (mut copy_a, mut copy_b);
        let body_a = if movable[a] {
            // SAFETY: within one colour a movable body is named by one
            // constraint only (`colour`), and `a != b`; the overflow runs
            // alone, one constraint at a time.
            unsafe { shared_bodies.get(a) }
        } else {
            copy_a = shared_bodies.read(a);
            &mut copy_a
        };
        let body_b = if movable[b] {
            // SAFETY: as for `a`.
            unsafe { shared_bodies.get(b) }
        } else {
            copy_b = shared_bodies.read(b);
            &mut copy_b
        };
        f(c, body_a, body_b);
    };
    for range in &groups.ranges {
        let ks = &groups.order[range.clone()];
        let overflow = colours[ks[0] as usize] as usize == MAX_COLOURS;
        if overflow {
            ks.iter().copied().for_each(one);
        } else {
            crate::parallel::for_each_item(ks, ITEM, |chunk| chunk.iter().copied().for_each(one));
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn no_colour_shares_a_movable_body() {
        // A chain 0-1-2-3 with a static body 4 touching everything.
        let ends = [
            (0, 1),
            (1, 2),
            (2, 3),
            (4, 0),
            (4, 1),
            (4, 2),
            (4, 3),
            (0, 2),
        ];
        let movable = [true, true, true, true, false];
        let colours = colour(&ends, &movable);
        for (i, &(a, b)) in ends.iter().enumerate() {
            for (j, &(c, d)) in ends.iter().enumerate().skip(i + 1) {
                if colours[i] == colours[j] {
                    for x in [a, b] {
                        assert!(!movable[x] || (x != c && x != d), "{i} and {j} share {x}");
                    }
                }
            }
        }
        let groups = group(&colours);
        let mut seen = groups.order.clone();
        seen.sort_unstable();
        assert_eq!(seen, (0..ends.len() as u32).collect::<Vec<_>>());
        for r in &groups.ranges {
            let c = colours[groups.order[r.start] as usize];
            assert!(groups.order[r.clone()]
                .iter()
                .all(|&k| colours[k as usize] == c));
            assert!(groups.order[r.clone()].windows(2).all(|w| w[0] < w[1]));
        }
    }

    #[test]
    fn a_body_with_too_many_contacts_overflows() {
        let ends: Vec<(usize, usize)> = (1..=70).map(|k| (0, k)).collect();
        let movable = vec![true; 71];
        let colours = colour(&ends, &movable);
        assert_eq!(
            colours
                .iter()
                .filter(|&&c| c as usize == MAX_COLOURS)
                .count(),
            6
        );
    }
}
