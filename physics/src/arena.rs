//! A small generational arena: stable indices, reuse of freed slots, and
//! iteration in index order (never hash order), so that everything built on
//! it steps deterministically.

#[derive(Debug, Clone)]
pub(crate) enum Entry<T> {
    Occupied { generation: u32, value: T },
    Vacant { generation: u32 },
}

/// Slots of `T` addressed by `(index, generation)`.
#[derive(Debug)]
pub(crate) struct Arena<T> {
    pub(crate) entries: Vec<Entry<T>>,
    /// Freed indices, reused last-in first-out.
    pub(crate) free: Vec<u32>,
    len: usize,
    /// Changes whenever the contents may have (see [`Revision`]).
    revision: Revision,
}

/// Names what an arena holds: any mutable access gives the arena a new
/// revision, and no two arenas (clones included) share one. Derived work
/// remembered with a revision (what a world at rest would compute again)
/// stays valid while the arena's revision is the same.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct Revision {
    /// This arena, among every arena made in the process.
    arena: u64,
    /// Mutable accesses so far.
    edits: u64,
}

impl Revision {
    fn fresh() -> Self {
        static ARENAS: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        Self {
            arena: ARENAS.fetch_add(1, std::sync::atomic::Ordering::Relaxed),
            edits: 0,
        }
    }
}

impl<T> Default for Arena<T> {
    fn default() -> Self {
        Self {
            entries: Vec::new(),
            free: Vec::new(),
            len: 0,
            revision: Revision::fresh(),
        }
    }
}

impl<T: Clone> Clone for Arena<T> {
    /// The same contents under a revision of its own.
    fn clone(&self) -> Self {
        Self {
            entries: self.entries.clone(),
            free: self.free.clone(),
            len: self.len,
            revision: Revision::fresh(),
        }
    }
}

impl<T> Arena<T> {
    /// Rebuilds an arena from its parts (used by restore). Returns `None` if
    /// the free list does not name exactly the vacant entries.
    pub(crate) fn from_parts(entries: Vec<Entry<T>>, free: Vec<u32>) -> Option<Self> {
        let vacant = entries
            .iter()
            .filter(|e| matches!(e, Entry::Vacant { .. }))
            .count();
        if vacant != free.len() {
            return None;
        }
        let mut seen = vec![false; entries.len()];
        for &f in &free {
            let f = f as usize;
            if f >= entries.len() || seen[f] || !matches!(entries[f], Entry::Vacant { .. }) {
                return None;
            }
            seen[f] = true;
        }
        let len = entries.len() - vacant;
        Some(Self {
            entries,
            free,
            len,
            revision: Revision::fresh(),
        })
    }

    pub(crate) fn len(&self) -> usize {
        self.len
    }

    /// The contents' revision.
    pub(crate) fn revision(&self) -> Revision {
        self.revision
    }

    /// Notes a mutable access.
    fn edit(&mut self) {
        self.revision.edits += 1;
    }

    /// Inserts `value`, returning `(index, generation)`.
    pub(crate) fn insert(&mut self, value: T) -> (u32, u32) {
        self.edit();
        self.len += 1;
        if let Some(index) = self.free.pop() {
            let entry = &mut self.entries[index as usize];
            let generation = match entry {
                Entry::Vacant { generation } => *generation,
                Entry::Occupied { .. } => unreachable!("free list names an occupied slot"),
            };
            *entry = Entry::Occupied { generation, value };
            (index, generation)
        } else {
            let index = u32::try_from(self.entries.len()).expect("more than u32::MAX entries");
            self.entries.push(Entry::Occupied {
                generation: 0,
                value,
            });
            (index, 0)
        }
    }

    pub(crate) fn get(&self, index: u32, generation: u32) -> Option<&T> {
        match self.entries.get(index as usize)? {
            Entry::Occupied {
                generation: g,
                value,
            } if *g == generation => Some(value),
            _ => None,
        }
    }

    pub(crate) fn get_mut(&mut self, index: u32, generation: u32) -> Option<&mut T> {
        self.edit();
        match self.entries.get_mut(index as usize)? {
            Entry::Occupied {
                generation: g,
                value,
            } if *g == generation => Some(value),
            _ => None,
        }
    }

    pub(crate) fn remove(&mut self, index: u32, generation: u32) -> Option<T> {
        self.edit();
        let entry = self.entries.get_mut(index as usize)?;
        match entry {
            Entry::Occupied { generation: g, .. } if *g == generation => {
                let next = Entry::Vacant {
                    generation: generation.wrapping_add(1),
                };
                let old = std::mem::replace(entry, next);
                self.free.push(index);
                self.len -= 1;
                match old {
                    Entry::Occupied { value, .. } => Some(value),
                    Entry::Vacant { .. } => None,
                }
            }
            _ => None,
        }
    }

    /// Occupied entries in index order: `(index, generation, value)`.
    pub(crate) fn iter(&self) -> impl Iterator<Item = (u32, u32, &T)> {
        self.entries
            .iter()
            .enumerate()
            .filter_map(|(i, e)| match e {
                Entry::Occupied { generation, value } => Some((i as u32, *generation, value)),
                Entry::Vacant { .. } => None,
            })
    }

    /// Occupied entries in index order, mutably.
    pub(crate) fn iter_mut(&mut self) -> impl Iterator<Item = (u32, u32, &mut T)> {
        self.edit();
        self.entries
            .iter_mut()
            .enumerate()
            .filter_map(|(i, e)| match e {
                Entry::Occupied { generation, value } => Some((i as u32, *generation, value)),
                Entry::Vacant { .. } => None,
            })
    }

    /// Removes every occupied entry for which `keep` returns false.
    pub(crate) fn retain(&mut self, mut keep: impl FnMut(&T) -> bool) {
        let doomed: Vec<(u32, u32)> = self
            .iter()
            .filter(|(_, _, v)| !keep(v))
            .map(|(i, g, _)| (i, g))
            .collect();
        for (i, g) in doomed {
            self.remove(i, g);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn stale_handles_miss() {
        let mut a = Arena::default();
        let (i, g) = a.insert(5);
        assert_eq!(a.get(i, g), Some(&5));
        assert_eq!(a.remove(i, g), Some(5));
        assert_eq!(a.get(i, g), None);
        let (i2, g2) = a.insert(7);
        assert_eq!(i2, i);
        assert_ne!(g2, g);
        assert_eq!(a.get(i, g), None);
        assert_eq!(a.get(i2, g2), Some(&7));
        assert_eq!(a.get(99, 0), None);
    }
}
