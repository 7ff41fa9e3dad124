//! Constraints sorted into colours: no two constraints of one colour move
//! the same particle, so a colour's constraints are projected in parallel
//! and the result is the same on any number of threads (Gauss–Seidel from
//! colour to colour, in a fixed order).
//!
//! The colouring is greedy, in the order the constraints were made: each
//! takes the lowest of 64 colours that none of its movable particles has
//! yet. Constraints that find all 64 taken go to one last colour that is
//! projected on one thread, in order. Particles that cannot move (pinned:
//! inverse mass 0) are never written, so they join no conflict; a cloth
//! hanging from one pinned row colours like a free one.

/// Most colours projected in parallel; the rest share one last colour
/// projected in order.
pub(crate) const PARALLEL_COLOURS: usize = 64;

/// Most constraints per parallel work item.
const CHUNK: usize = 1024;
/// Fewest constraints per parallel work item.
const MIN_CHUNK: usize = 256;

/// Constraints per work item for a colour of `n`: a quarter of the colour
/// within `MIN_CHUNK..=CHUNK`, a multiple of four (whole lane groups), so
/// that colours of a few thousand (a tetrahedral mesh has many) still
/// split across threads. A function of the colour alone, never of the
/// thread count.
fn chunk_for(n: usize) -> usize {
    (n / 4).clamp(MIN_CHUNK, CHUNK).next_multiple_of(4)
}

/// A constraint's particles.
pub(crate) trait Touches {
    /// The particles the constraint moves (and reads).
    fn particles(&self) -> &[u32];
}

/// Constraints of one kind in colour order.
#[derive(Debug, Clone, PartialEq)]
pub(crate) struct Coloured<C> {
    /// The constraints, colour after colour.
    pub(crate) items: Vec<C>,
    /// Where each colour ends in `items`.
    pub(crate) ends: Vec<u32>,
    /// Whether the last colour is the overflow colour, projected in order.
    pub(crate) overflow: bool,
}

impl<C> Default for Coloured<C> {
    fn default() -> Self {
        Self {
            items: Vec::new(),
            ends: Vec::new(),
            overflow: false,
        }
    }
}

/// The constraints one thread projects at a time: a piece of a colour.
pub(crate) struct Block<'a, C> {
    items: &'a [C],
    /// The overflow colour: its constraints share particles, so they are
    /// projected one at a time, in order.
    in_order: bool,
}

impl<C> Block<'_, C> {
    /// Runs `one` on every constraint, in order.
    pub(crate) fn project(&self, one: impl Fn(&C)) {
        self.items.iter().for_each(one);
    }

    /// Runs `four` on four constraints at a time where they are
    /// independent, `one` on the rest.
    pub(crate) fn project_lanes(&self, four: impl Fn(&[C; 4]), one: impl Fn(&C)) {
        if self.in_order {
            return self.project(one);
        }
        let mut quads = self.items.chunks_exact(4);
        for q in &mut quads {
            four(q.try_into().expect("chunks of four"));
        }
        quads.remainder().iter().for_each(one);
    }
}

impl<C: Touches + Clone + Sync> Coloured<C> {
    /// Colours `items` (in their order) for particles whose inverse masses
    /// are `w`.
    pub(crate) fn new(items: Vec<C>, w: &[f32]) -> Self {
        let mut used = vec![0u64; w.len()];
        let mut colour_of = Vec::with_capacity(items.len());
        let mut counts = [0u32; PARALLEL_COLOURS + 1];
        for c in &items {
            let mut taken = 0u64;
            for &p in c.particles() {
                if w[p as usize] > 0.0 {
                    taken |= used[p as usize];
                }
            }
            let colour = (!taken).trailing_zeros() as usize;
            if colour < PARALLEL_COLOURS {
                for &p in c.particles() {
                    if w[p as usize] > 0.0 {
                        used[p as usize] |= 1 << colour;
                    }
                }
            }
            colour_of.push(colour.min(PARALLEL_COLOURS) as u8);
            counts[colour.min(PARALLEL_COLOURS)] += 1;
        }
        let overflow = counts[PARALLEL_COLOURS] > 0;
        let last = counts.iter().rposition(|&n| n > 0).map_or(0, |k| k + 1);
        let mut starts = vec![0u32; last];
        let mut ends = Vec::with_capacity(last);
        let mut at = 0u32;
        for k in 0..last {
            starts[k] = at;
            at += counts[k];
            ends.push(at);
        }
        let mut sorted: Vec<Option<C>> = vec![None; items.len()];
        for (c, colour) in items.into_iter().zip(colour_of) {
            let slot = &mut starts[colour as usize];
            sorted[*slot as usize] = Some(c);
            *slot += 1;
        }
        // Empty colours (below the overflow) are dropped.
        let items: Vec<C> = sorted.into_iter().flatten().collect();
        let mut kept = Vec::with_capacity(ends.len());
        let mut prev = 0;
        for &e in &ends {
            if e > prev {
                kept.push(e);
            }
            prev = e;
        }
        Self {
            items,
            ends: kept,
            overflow,
        }
    }

    /// Rebuilds from saved parts, checking that every colour but an
    /// overflow one moves each particle at most once. `None` if not.
    pub(crate) fn from_parts(
        items: Vec<C>,
        ends: Vec<u32>,
        overflow: bool,
        w: &[f32],
    ) -> Option<Self> {
        let mut prev = 0u32;
        for &e in &ends {
            if e <= prev || e as usize > items.len() {
                return None;
            }
            prev = e;
        }
        if prev as usize != items.len() || (overflow && ends.is_empty()) {
            return None;
        }
        let s = Self {
            items,
            ends,
            overflow,
        };
        let mut seen = vec![u32::MAX; w.len()];
        for (k, colour) in s.colours().enumerate() {
            if s.overflow && k + 1 == s.ends.len() {
                break;
            }
            for c in colour {
                for &p in c.particles() {
                    let p = p as usize;
                    if p >= w.len() {
                        return None;
                    }
                    if w[p] > 0.0 {
                        if seen[p] == k as u32 {
                            return None;
                        }
                        seen[p] = k as u32;
                    }
                }
            }
        }
        Some(s)
    }

    /// The colours, in solve order.
    pub(crate) fn colours(&self) -> impl Iterator<Item = &[C]> {
        let mut start = 0usize;
        self.ends.iter().map(move |&e| {
            let c = &self.items[start..e as usize];
            start = e as usize;
            c
        })
    }

    /// Appends the number of blocks of each colour to `blocks`, one stage
    /// per colour for [`for_each_stage_block`]: a colour cut into pieces
    /// of [`chunk_for`] constraints, the overflow colour in one piece.
    ///
    /// [`for_each_stage_block`]: crate::parallel::for_each_stage_block
    pub(crate) fn stages(&self, blocks: &mut Vec<usize>) {
        let n = self.ends.len();
        for (k, colour) in self.colours().enumerate() {
            if self.overflow && k + 1 == n {
                blocks.push(1);
            } else {
                blocks.push(colour.len().div_ceil(chunk_for(colour.len())));
            }
        }
    }

    /// Block `b` of colour `k`, as counted by [`Coloured::stages`].
    pub(crate) fn block(&self, k: usize, b: usize) -> Block<'_, C> {
        let start = if k == 0 { 0 } else { self.ends[k - 1] as usize };
        let end = self.ends[k] as usize;
        if self.overflow && k + 1 == self.ends.len() {
            return Block {
                items: &self.items[start..end],
                in_order: true,
            };
        }
        let chunk = chunk_for(end - start);
        let from = (start + b * chunk).min(end);
        Block {
            items: &self.items[from..(from + chunk).min(end)],
            in_order: false,
        }
    }

    /// Keeps the constraints for which `keep` is true; the colouring stays
    /// valid (a subset of a colour moves each particle at most once).
    pub(crate) fn retain(&mut self, mut keep: impl FnMut(&C) -> bool) {
        let mut items = Vec::with_capacity(self.items.len());
        let mut ends = Vec::with_capacity(self.ends.len());
        let n = self.ends.len();
        let mut overflow = false;
        for (k, colour) in self.colours().enumerate() {
            let before = items.len();
            items.extend(colour.iter().filter(|c| keep(c)).cloned());
            if items.len() > before {
                ends.push(items.len() as u32);
                overflow = self.overflow && k + 1 == n;
            }
        }
        self.items = items;
        self.ends = ends;
        self.overflow = overflow;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, Clone, PartialEq)]
    struct Pair([u32; 2]);

    impl Touches for Pair {
        fn particles(&self) -> &[u32] {
            &self.0
        }
    }

    #[test]
    fn a_colour_moves_each_particle_once() {
        // A chain 0-1-2-...-9 and a star around 0.
        let mut items: Vec<Pair> = (0..9).map(|i| Pair([i, i + 1])).collect();
        items.extend((2..10).map(|i| Pair([0, i])));
        let w = vec![1.0; 10];
        let c = Coloured::new(items.clone(), &w);
        assert_eq!(c.items.len(), items.len());
        assert!(!c.overflow);
        assert!(Coloured::from_parts(c.items.clone(), c.ends.clone(), false, &w).is_some());
        // Particle 0 is in 9 constraints: at least 9 colours.
        assert!(c.ends.len() >= 9);
    }

    #[test]
    fn pinned_particles_join_no_conflict() {
        let items: Vec<Pair> = (1..10).map(|i| Pair([0, i])).collect();
        let mut w = vec![1.0; 10];
        w[0] = 0.0;
        let c = Coloured::new(items, &w);
        assert_eq!(c.ends, vec![9], "all in one colour");
    }

    #[test]
    fn more_than_64_constraints_on_one_particle_overflow_into_an_ordered_colour() {
        let items: Vec<Pair> = (1..100).map(|i| Pair([0, i])).collect();
        let w = vec![1.0; 100];
        let c = Coloured::new(items, &w);
        assert!(c.overflow);
        assert_eq!(c.ends.len(), 65);
        assert_eq!(*c.ends.last().unwrap(), 99);
        let again = Coloured::from_parts(c.items.clone(), c.ends.clone(), true, &w);
        assert!(again.is_some());
        assert!(Coloured::from_parts(c.items.clone(), c.ends.clone(), false, &w).is_none());
    }

    #[test]
    fn retain_keeps_a_valid_colouring() {
        let items: Vec<Pair> = (0..9).map(|i| Pair([i, i + 1])).collect();
        let w = vec![1.0; 10];
        let mut c = Coloured::new(items, &w);
        c.retain(|p| p.0[0] != 3);
        assert_eq!(c.items.len(), 8);
        assert!(Coloured::from_parts(c.items.clone(), c.ends.clone(), c.overflow, &w).is_some());
    }
}
