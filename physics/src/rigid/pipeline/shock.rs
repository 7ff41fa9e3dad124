//! Which contacts the shock pass solves, and in what order (see
//! [`ContactConstraint::solve_held`]).
//!
//! Bodies get a *level*: 0 for those no constraint moves (static, asleep,
//! kinematic), then one more than the lowest level among the bodies they
//! touch (a breadth-first walk over the contacts from the level-0 ones):
//! how many contacts away from solid ground a body rests. A contact
//! between levels `L` and `L + 1` has its lower body at `L`.
//!
//! The pass is for stacks with a heavy body over a lighter one (more than
//! [`HEAVY_OVER_LIGHT`] times its mass), which the solve passes cannot
//! hold up: every such contact, and every contact below its lower body
//! down to the ground, is solved once more per substep, lowest level
//! first, each with its lower body held still, and those contacts'
//! resting points measure their soft give from the load they carried at
//! the start of the step (`NormalRows::carried`). Stacks of
//! like masses never enter it, so they cost nothing more and move as
//! before.

use crate::rigid::solver::{pair, ContactConstraint, ContactPass, SolverBody};

/// How many times heavier than the body under it a body must be for its
/// contact to need the shock pass.
pub(crate) const HEAVY_OVER_LIGHT: f64 = 4.0;

/// The contacts of the shock pass in the order it solves them.
#[derive(Debug, Default)]
pub(crate) struct Shock {
    /// Each contact (its place in the stored constraints) with whether its
    /// lower body is A, lowest level first.
    order: Vec<(u32, bool)>,
    /// Tangential speed below which a contact sticks, m/s.
    stick_speed: f64,
}

impl Shock {
    /// The shock pass over `constraints` (as stored) between bodies whose
    /// `movable` flags and inverse masses (`bodies`) are given by slot.
    pub(crate) fn new(
        constraints: &mut [ContactConstraint],
        bodies: &[SolverBody],
        movable: &[bool],
        stick_speed: f64,
    ) -> Self {
        // The upper body more than `HEAVY_OVER_LIGHT` times the lower's
        // mass, both movable (by inverse masses: no division a contact).
        let heavy_over_light = |lower: usize, upper: usize| {
            let (lower, upper) = (bodies[lower].inv_mass, bodies[upper].inv_mass);
            upper > 0.0 && lower > HEAVY_OVER_LIGHT * upper
        };
        // Most worlds have no pair of touching bodies that far apart in
        // mass: then there is nothing to order.
        let lopsided =
            |c: &ContactConstraint| heavy_over_light(c.a, c.b) || heavy_over_light(c.b, c.a);
        if !constraints.iter().any(lopsided) {
            return Self {
                order: Vec::new(),
                stick_speed,
            };
        }
        let level = levels(constraints, movable);
        let lower_is_a = |c: &ContactConstraint| level[c.a] < level[c.b];
        let stacked = |c: &ContactConstraint| {
            level[c.a] != level[c.b] && level[c.a].max(level[c.b]) != u32::MAX
        };
        // Bodies carrying a heavier one, found from the top down: the lower
        // body of a heavy-over-light contact, and every body under one.
        let mut carrying = vec![false; movable.len()];
        let mut by_level: Vec<u32> = (0..constraints.len() as u32)
            .filter(|&k| stacked(&constraints[k as usize]))
            .collect();
        let lower_level = |k: &u32| {
            let c = &constraints[*k as usize];
            level[c.a].min(level[c.b])
        };
        by_level.sort_by_key(|k| std::cmp::Reverse(lower_level(k)));
        let mut order = Vec::new();
        for k in by_level {
            let c = &constraints[k as usize];
            let (lower, upper) = if lower_is_a(c) {
                (c.a, c.b)
            } else {
                (c.b, c.a)
            };
            if carrying[upper] || heavy_over_light(lower, upper) {
                carrying[lower] = true;
                order.push((k, lower_is_a(c)));
            }
        }
        // Lowest level first (the walk above went from the top).
        order.reverse();
        for &(k, _) in &order {
            constraints[k as usize].carry_load();
        }
        Self { order, stick_speed }
    }

    /// Whether the pass has no contacts.
    pub(crate) fn is_empty(&self) -> bool {
        self.order.is_empty()
    }

    /// The pass's contacts (their places in the stored constraints).
    pub(crate) fn contacts(&self) -> impl Iterator<Item = usize> + '_ {
        self.order.iter().map(|&(k, _)| k as usize)
    }

    /// Solves the pass's contacts in order, on the calling thread.
    pub(crate) fn run(
        &self,
        constraints: &mut [ContactConstraint],
        bodies: &mut [SolverBody],
        pass: &ContactPass,
    ) {
        for &(k, hold_a) in &self.order {
            let c = &mut constraints[k as usize];
            let (a, b) = pair(bodies, c.a, c.b);
            c.solve_held(a, b, hold_a, self.stick_speed, pass);
        }
    }
}

/// Each body's level (see the module note); `u32::MAX` for bodies no chain
/// of contacts joins to a level-0 one.
fn levels(constraints: &[ContactConstraint], movable: &[bool]) -> Vec<u32> {
    let n = movable.len();
    // Each body's contacts, as a compressed adjacency list.
    let mut first = vec![0u32; n + 1];
    for c in constraints {
        first[c.a + 1] += 1;
        first[c.b + 1] += 1;
    }
    for i in 0..n {
        first[i + 1] += first[i];
    }
    let mut next = first.clone();
    let mut other = vec![0u32; first[n] as usize];
    for c in constraints {
        for (from, to) in [(c.a, c.b), (c.b, c.a)] {
            other[next[from] as usize] = to as u32;
            next[from] += 1;
        }
    }
    let mut level: Vec<u32> = movable
        .iter()
        .map(|&m| if m { u32::MAX } else { 0 })
        .collect();
    let mut queue: std::collections::VecDeque<usize> = (0..n).filter(|&i| level[i] == 0).collect();
    while let Some(u) = queue.pop_front() {
        for &v in &other[first[u] as usize..first[u + 1] as usize] {
            let v = v as usize;
            if level[v] == u32::MAX {
                level[v] = level[u] + 1;
                queue.push_back(v);
            }
        }
    }
    level
}
