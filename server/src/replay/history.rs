//! [`History`]: a recording held in memory for seeking — every tick's
//! hash, every journal entry, and keyframes within a memory budget.
//!
//! The live server builds one as it records (so a seek never waits on the
//! disk), and `--resume` or a tool loads one from a recording directory.
//! When the keyframes pass the budget every second one is dropped (never
//! a session's first): seeks then re-simulate further, but every recorded
//! tick stays reachable.

use std::collections::{BTreeMap, BTreeSet};
use std::path::Path;
use std::sync::Arc;

use super::journal::{self, JournalEntry};
use super::state::SimState;
use crate::record::{Record, RecordReader};

/// Default memory budget for keyframes held for seeking, bytes (256 MiB).
pub const DEFAULT_KEYFRAME_BUDGET: usize = 256 * 1024 * 1024;

/// A keyframe held in memory: the encoded [`SimState`].
#[derive(Debug, Clone)]
pub struct HeldKeyframe {
    /// Its tick.
    pub tick: u64,
    /// Journal entries of that tick already in it.
    pub applied: u32,
    /// The encoded state.
    pub bytes: Arc<Vec<u8>>,
}

/// A recording in memory. See the module docs.
#[derive(Debug, Clone)]
pub struct History {
    /// Ticks at which recording sessions started (a session's ticks can be
    /// re-simulated only from its own keyframes).
    sessions: BTreeSet<u64>,
    keyframes: BTreeMap<(u64, u32), Arc<Vec<u8>>>,
    keyframe_bytes: usize,
    budget: usize,
    journal: BTreeMap<u64, Vec<JournalEntry>>,
    hashes: BTreeMap<u64, u64>,
    journal_entries: u64,
}

/// Why a recording could not be loaded into a [`History`].
#[derive(Debug, thiserror::Error)]
pub enum HistoryError {
    /// The store refused (I/O, corruption).
    #[error(transparent)]
    Record(#[from] crate::record::RecordError),
    /// A journal record does not decode.
    #[error("tick {tick}: {error}")]
    Journal {
        /// Its tick.
        tick: u64,
        /// What is wrong.
        error: journal::JournalError,
    },
    /// A keyframe is not a saved simulation state.
    #[error("keyframe at tick {tick}: {error}")]
    Keyframe {
        /// Its tick.
        tick: u64,
        /// What is wrong.
        error: super::state::StateError,
    },
}

impl Default for History {
    fn default() -> Self {
        Self::new(DEFAULT_KEYFRAME_BUDGET)
    }
}

impl History {
    /// An empty history holding at most `budget` bytes of keyframes.
    pub fn new(budget: usize) -> Self {
        History {
            sessions: BTreeSet::new(),
            keyframes: BTreeMap::new(),
            keyframe_bytes: 0,
            budget: budget.max(1),
            journal: BTreeMap::new(),
            hashes: BTreeMap::new(),
            journal_entries: 0,
        }
    }

    /// A recording session starts at `tick` (its keyframe follows).
    pub fn start_session(&mut self, tick: u64) {
        self.sessions.insert(tick);
    }

    /// Holds a keyframe (thinning older ones past the budget).
    pub fn add_keyframe(&mut self, tick: u64, applied: u32, bytes: Arc<Vec<u8>>) {
        self.keyframe_bytes += bytes.len();
        if let Some(old) = self.keyframes.insert((tick, applied), bytes) {
            self.keyframe_bytes -= old.len();
        }
        if self.keyframe_bytes > self.budget {
            self.thin();
        }
    }

    /// Drops every second keyframe that does not start a session, oldest
    /// first, until under budget (the newest is always kept).
    fn thin(&mut self) {
        let keys: Vec<(u64, u32)> = self.keyframes.keys().copied().collect();
        let last = keys.last().copied();
        let mut drop = false;
        for key in keys {
            if self.keyframe_bytes <= self.budget / 2 {
                break;
            }
            if Some(key) == last || (self.sessions.contains(&key.0) && key.1 == 0) {
                continue;
            }
            if drop {
                if let Some(b) = self.keyframes.remove(&key) {
                    self.keyframe_bytes -= b.len();
                }
            }
            drop = !drop;
        }
    }

    /// Appends entries applied while the world stood at `tick`.
    pub fn add_journal(&mut self, tick: u64, entries: &[JournalEntry]) {
        if entries.is_empty() {
            return;
        }
        self.journal_entries += entries.len() as u64;
        self.journal
            .entry(tick)
            .or_default()
            .extend_from_slice(entries);
    }

    /// Notes the state hash after `tick`.
    pub fn add_hash(&mut self, tick: u64, hash: u64) {
        self.hashes.insert(tick, hash);
    }

    /// The recorded state hash after `tick`.
    pub fn hash_at(&self, tick: u64) -> Option<u64> {
        self.hashes.get(&tick).copied()
    }

    /// The journal of `tick` (empty when nothing happened).
    pub fn journal_at(&self, tick: u64) -> &[JournalEntry] {
        self.journal.get(&tick).map_or(&[], Vec::as_slice)
    }

    /// The first and last tick a seek can reach (a session's first tick,
    /// through the last tick hashed).
    pub fn range(&self) -> Option<(u64, u64)> {
        let first = *self.sessions.first()?;
        let last = self
            .hashes
            .last_key_value()
            .map_or(first, |(&t, _)| t)
            .max(self.keyframes.last_key_value().map_or(first, |(k, _)| k.0));
        Some((first, last))
    }

    /// Whether `tick` can be shown: it was hashed, or a session started
    /// at it.
    pub fn reachable(&self, tick: u64) -> bool {
        self.hashes.contains_key(&tick) || self.sessions.contains(&tick)
    }

    /// The session `tick` belongs to: the newest start at or before it.
    pub fn session_of(&self, tick: u64) -> Option<u64> {
        self.sessions.range(..=tick).next_back().copied()
    }

    /// The keyframe to re-simulate `target` from: the newest of its
    /// session taken before `target`'s step was done with, i.e. at an
    /// earlier tick, or at `target` with nothing of its journal applied.
    pub fn base_for(&self, target: u64) -> Option<HeldKeyframe> {
        let session = self.session_of(target)?;
        self.keyframes
            .range((session, 0)..=(target, 0))
            .next_back()
            .map(|(&(tick, applied), bytes)| HeldKeyframe {
                tick,
                applied,
                bytes: bytes.clone(),
            })
    }

    /// The newest keyframe (what `--resume` starts from).
    pub fn latest_keyframe(&self) -> Option<HeldKeyframe> {
        self.keyframes
            .last_key_value()
            .map(|(&(tick, applied), bytes)| HeldKeyframe {
                tick,
                applied,
                bytes: bytes.clone(),
            })
    }

    /// The last tick hashed, if any.
    pub fn last_hashed(&self) -> Option<u64> {
        self.hashes.last_key_value().map(|(&t, _)| t)
    }

    /// The last tick with journal entries, if any.
    pub fn last_journal_tick(&self) -> Option<u64> {
        self.journal.last_key_value().map(|(&t, _)| t)
    }

    /// Keyframes held, and their bytes.
    pub fn keyframe_stats(&self) -> (usize, usize) {
        (self.keyframes.len(), self.keyframe_bytes)
    }

    /// Journal entries held.
    pub fn journal_entries(&self) -> u64 {
        self.journal_entries
    }

    /// Ticks hashed.
    pub fn hashed_ticks(&self) -> usize {
        self.hashes.len()
    }

    /// Reads a recording directory into memory.
    pub fn load(dir: &Path, budget: usize) -> Result<History, HistoryError> {
        let reader = RecordReader::open(dir)?;
        let mut h = History::new(budget);
        for record in reader.iter() {
            match record? {
                Record::SessionStart { tick, .. } => h.start_session(tick),
                Record::Keyframe { tick, state } => {
                    let (_, applied) = SimState::peek(&state)
                        .map_err(|error| HistoryError::Keyframe { tick, error })?;
                    h.add_keyframe(tick, applied, Arc::new(state));
                }
                Record::Journal { tick, entries } => {
                    let entries = journal::decode(tick, &entries)
                        .map_err(|error| HistoryError::Journal { tick, error })?;
                    h.add_journal(tick, &entries);
                }
                Record::TickHash { tick, hash } => h.add_hash(tick, hash),
                Record::Inputs { .. } | Record::AdminEdit { .. } => {}
            }
        }
        // A directory whose first segment retention removed starts at a
        // keyframe without its session start: that keyframe starts one.
        if let Some((&(tick, _), _)) = h.keyframes.first_key_value() {
            if h.session_of(tick).is_none() {
                h.start_session(tick);
            }
        }
        Ok(h)
    }
}
