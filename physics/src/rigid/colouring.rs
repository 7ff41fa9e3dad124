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

/// Sorts `items` by colour (stable: constraint order within a colour) and
/// returns the range of each colour, then the overflow's range.
pub(crate) fn group<T>(items: Vec<T>, colours: &[u8]) -> (Vec<T>, Vec<Range<usize>>) {
    let mut order: Vec<usize> = (0..items.len()).collect();
    order.sort_by_key(|&k| colours[k]);
    let mut slots: Vec<Option<T>> = items.into_iter().map(Some).collect();
    let sorted: Vec<T> = order
        .iter()
        .map(|&k| slots[k].take().expect("each index once"))
        .collect();
    let mut ranges = Vec::new();
    let mut start = 0;
    while start < order.len() {
        let c = colours[order[start]];
        let mut end = start;
        while end < order.len() && colours[order[end]] == c {
            end += 1;
        }
        ranges.push(start..end);
        start = end;
    }
    (sorted, ranges)
}

/// The solver bodies, lent to the workers of one colour at a time.
struct SharedBodies<'a> {
    ptr: *mut SolverBody,
    len: usize,
    _lifetime: PhantomData<&'a mut [SolverBody]>,
}

// SAFETY: `SharedBodies` only hands out a `&mut` to a movable body to the
// one constraint of the current colour that names it (see `run_colour`),
// and only copies of bodies that are never written; so sharing it between
// the threads of a colour creates no aliasing `&mut`.
unsafe impl Sync for SharedBodies<'_> {}

impl<'a> SharedBodies<'a> {
    fn new(bodies: &'a mut [SolverBody]) -> Self {
        Self {
            ptr: bodies.as_mut_ptr(),
            len: bodies.len(),
            _lifetime: PhantomData,
        }
    }

    /// A copy of body `i` (for bodies no constraint writes).
    fn read(&self, i: usize) -> SolverBody {
        assert!(i < self.len, "body {i} out of {}", self.len);
        // SAFETY: `i` is in bounds; bodies that are read this way are never
        // written while a colour runs (they are not movable), so the read
        // races with no write.
        unsafe { *self.ptr.add(i) }
    }

    /// The movable body `i`, exclusively.
    ///
    /// # Safety
    /// No other reference to body `i` may exist while the result lives: the
    /// caller guarantees that `i` is named by one constraint of the colour
    /// being solved.
    #[allow(clippy::mut_from_ref)]
    unsafe fn get(&self, i: usize) -> &mut SolverBody {
        assert!(i < self.len, "body {i} out of {}", self.len);
        // SAFETY: in bounds (checked above); exclusive by the caller's
        // guarantee.
        unsafe { &mut *self.ptr.add(i) }
    }
}

/// Runs `f(constraint, body_a, body_b)` over every constraint, colour by
/// colour (the ranges from [`group`]); within a colour, in parallel. The
/// overflow (the last range, if its colour is [`MAX_COLOURS`]) runs on the
/// calling thread. Immovable bodies are passed as copies, so what `f` does
/// to them is dropped.
pub(crate) fn solve_coloured<C, F>(
    constraints: &mut [C],
    ranges: &[Range<usize>],
    ends: impl Fn(&C) -> (usize, usize) + Sync,
    bodies: &mut [SolverBody],
    movable: &[bool],
    f: F,
) where
    C: Send,
    F: Fn(&mut C, &mut SolverBody, &mut SolverBody) + Sync,
{
    let shared = SharedBodies::new(bodies);
    let one = |c: &mut C| {
        let (a, b) = ends(c);
        assert_ne!(a, b, "a constraint joins two different bodies");
        let (mut copy_a, mut copy_b);
        let body_a = if movable[a] {
            // SAFETY: within one colour a movable body is named by one
            // constraint only (`colour`), and `a != b`; the overflow runs
            // alone, one constraint at a time.
            unsafe { shared.get(a) }
        } else {
            copy_a = shared.read(a);
            &mut copy_a
        };
        let body_b = if movable[b] {
            // SAFETY: as for `a`.
            unsafe { shared.get(b) }
        } else {
            copy_b = shared.read(b);
            &mut copy_b
        };
        f(c, body_a, body_b);
    };
    for range in ranges {
        crate::parallel::for_each_chunk(&mut constraints[range.clone()], ITEM, |chunk| {
            chunk.iter_mut().for_each(one);
        });
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
        let (sorted, ranges) = group(ends.to_vec(), &colours);
        assert_eq!(sorted.len(), ends.len());
        assert_eq!(ranges.iter().map(|r| r.len()).sum::<usize>(), ends.len());
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
