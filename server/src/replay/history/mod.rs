//! [`History`]: a recording held in memory for seeking — every tick's
//! hash, every journal entry, and keyframes and checkpoints within a
//! memory budget.
//!
//! The live server builds one as it records (so a seek never waits on the
//! disk), and `--resume` or a tool loads one from a recording directory.
//!
//! Between keyframes the live server also holds **checkpoints**: the
//! whole state every few ticks ([`crate::sim::SimConfig::checkpoint_ticks`]),
//! in memory only, each packed with zstd against the keyframe before it
//! (a raw-content dictionary: what did not change since the keyframe costs
//! almost nothing). A seek then re-simulates at most that many ticks
//! instead of up to a keyframe interval; the disk keeps only the sparse
//! keyframes. When keyframes and checkpoints pass the memory budget every
//! second checkpoint is dropped, oldest first, then every second keyframe
//! (never a session's first) with the checkpoints packed against it:
//! seeks then re-simulate further, but every recorded tick stays
//! reachable.
//!
//! # Loading a damaged recording
//!
//! [`History::load`] refuses a damaged recording. [`History::salvage`]
//! (what `--resume` uses) loads what can be trusted and reports the rest
//! ([`Damage`]):
//!
//! - a damaged frame (a checksum that fails, an impossible header) or a
//!   journal that does not decode ends what is read of its segment: the
//!   records after it there are not used, since nothing says where they
//!   begin or that none is missing. Loading goes on with the next segment,
//!   but only from a point replay can start again at — a session start, or
//!   a keyframe taken right after its tick's step (nothing of its tick's
//!   journal in it), which then starts a session of its own — so no seek
//!   or resume re-simulates across the gap;
//! - a keyframe whose frame is intact but whose state does not unpack or
//!   read is left out; everything around it is used;
//! - a torn tail at the end of the newest segment ends the records.
//!
//! # Memory
//!
//! Every buffer is counted by its capacity, not its length, and held
//! exactly sized: a checkpoint is packed into a scratch buffer sized for
//! the whole state (what zstd asks for) and copied out at its packed
//! length, and a keyframe's spare capacity is given back as it is taken
//! in. [`History::held`] reports the bytes by part.
//!
//! * **Within the budget:** keyframes and checkpoints. Thinning keeps
//!   them under it, except that the newest keyframe and each session's
//!   first are always held (a budget smaller than those is exceeded by
//!   them).
//! * **Outside it, growing with the recording:** every tick's hash
//!   ([`HASH_BYTES_PER_TICK`] = 8 bytes, in runs of [`HASH_RUN`]: about
//!   1.7 MB an hour at 60 Hz, idle or not) and every journal entry
//!   ([`JOURNAL_BYTES_PER_ENTRY`] = 48 bytes, and
//!   [`JOURNAL_BYTES_PER_TICK`] = 64 for each tick that has any: nothing
//!   for an idle world; at 60 Hz about 14 MB an hour while anyone sends
//!   inputs, and 10 MB an hour more for each client sending one every
//!   tick). Seeking needs all of them, so they are not thinned; they are
//!   counted in [`History::held`] (the map overheads are estimates).
//! * **Outside it, fixed:** the packer's queue (at most [`PACK_QUEUE`]
//!   unpacked states, plus the one being packed), its scratch buffer (one
//!   state) and its prepared dictionary (in zstd's own heap: a copy of the
//!   keyframe and its match tables).

use std::collections::{BTreeMap, BTreeSet};
use std::ops::Bound;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use super::journal::{self, JournalEntry};
use super::state::{SimState, StateError};
use crate::record::{Corruption, Record, RecordReader, Salvaged, SegmentDamage};
pub use packer::PACK_QUEUE;
use packer::{PackJob, Packer};

mod packer;
#[cfg(test)]
mod tests;

/// Default memory budget for keyframes and checkpoints held for seeking,
/// bytes (1 GiB: ten minutes of a thousand moving bodies, checkpointed
/// every 10 ticks).
pub const DEFAULT_KEYFRAME_BUDGET: usize = 1024 * 1024 * 1024;

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

/// A checkpoint held in memory, packed against a keyframe.
#[derive(Debug, Clone)]
struct Checkpoint {
    /// The key of the keyframe it is packed against.
    base: (u64, u32),
    /// Its length unpacked, bytes.
    len: usize,
    /// The zstd frame, exactly sized.
    packed: Vec<u8>,
}

/// What a [`History`] holds, by part, bytes (buffer capacities, and for
/// the tables the per-entry figures below). See the module docs.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct HeldBytes {
    /// Keyframes (within the budget).
    pub keyframes: usize,
    /// Packed checkpoints (within the budget).
    pub checkpoints: usize,
    /// Every tick's hash (outside the budget).
    pub hashes: usize,
    /// Every journal entry (outside the budget).
    pub journal: usize,
}

impl HeldBytes {
    /// Each part by its metric label, bytes.
    pub fn parts(&self) -> [(&'static str, usize); 4] {
        [
            ("keyframes", self.keyframes),
            ("checkpoints", self.checkpoints),
            ("hashes", self.hashes),
            ("journal", self.journal),
        ]
    }

    /// The bytes the budget bounds: keyframes and checkpoints.
    pub fn budgeted(&self) -> usize {
        self.keyframes + self.checkpoints
    }
}

/// Hashes of consecutive ticks are held in runs of this many (each run's
/// buffer is made at this capacity).
pub const HASH_RUN: usize = 4096;

/// Bytes held for each tick's hash (runs of [`HASH_RUN`] are made whole,
/// and each also counts [`HASH_RUN_OVERHEAD`] for its map entry).
pub const HASH_BYTES_PER_TICK: usize = std::mem::size_of::<u64>();

/// Bytes counted for each hash run beyond its buffer (its map entry).
pub const HASH_RUN_OVERHEAD: usize = 128;

/// Bytes counted for each journal entry held (its size in memory; an
/// operator edit's boxed details are counted at their inline size).
pub const JOURNAL_BYTES_PER_ENTRY: usize = std::mem::size_of::<JournalEntry>();

/// Bytes counted for each tick with journal entries beyond the entries
/// themselves (its map entry and list header).
pub const JOURNAL_BYTES_PER_TICK: usize = 64;

/// A recording in memory. See the module docs.
pub struct History {
    /// Ticks at which recording sessions started (a session's ticks can be
    /// re-simulated only from its own keyframes).
    sessions: BTreeSet<u64>,
    keyframes: BTreeMap<(u64, u32), Arc<Vec<u8>>>,
    /// Capacity of the keyframes held, bytes.
    keyframe_bytes: usize,
    budget: usize,
    journal: BTreeMap<u64, Vec<JournalEntry>>,
    /// Bytes counted for the journal (see [`JOURNAL_BYTES_PER_ENTRY`]).
    journal_bytes: usize,
    /// Runs of consecutive ticks' hashes, by their first tick (never
    /// empty, at most [`HASH_RUN`] long, made at that capacity).
    hashes: BTreeMap<u64, Vec<u64>>,
    /// Bytes of the hash runs (their capacity, and the overhead of each).
    hash_bytes: usize,
    hashed_ticks: usize,
    journal_entries: u64,
    checkpoints: BTreeMap<u64, Checkpoint>,
    /// Capacity of the packed checkpoints held, bytes.
    checkpoint_bytes: usize,
    /// The thread that packs checkpoints (started with the first).
    packer: Option<Packer>,
}

impl std::fmt::Debug for History {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("History")
            .field("range", &self.range())
            .field("keyframes", &self.keyframes.len())
            .field("checkpoints", &self.checkpoints.len())
            .field("bytes", &self.held())
            .finish()
    }
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

/// Damage [`History::salvage`] found: where, and what it means for what
/// was loaded (see [`DamageKind`]).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
#[error("{}: byte {offset}: {why}", path.display())]
pub struct Damage {
    /// The segment file.
    pub path: PathBuf,
    /// Byte offset of the damaged frame, or of the record that does not
    /// decode, in the file.
    pub offset: u64,
    /// What is wrong there.
    pub why: DamageKind,
}

/// What is wrong where a [`Damage`] is.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum DamageKind {
    /// The frame is damaged. Reading went on at the next intact frame in
    /// the same file (`read_on_at`), or, when none could be found, with the
    /// next segment; what lies between is skipped, and replay starts again
    /// at the next keyframe.
    #[error("{why}; {}", match read_on_at {
        Some(at) => format!("read on at byte {at}"),
        None => "the rest of the segment skipped".to_string(),
    })]
    Frame {
        /// What is wrong.
        why: Corruption,
        /// Where reading went on in the same file, bytes.
        read_on_at: Option<u64>,
    },
    /// The frame is intact but the keyframe's state does not unpack, read
    /// or restore: that keyframe is not used.
    #[error("the keyframe of tick {tick} does not decode: {error}")]
    Keyframe {
        /// Its tick.
        tick: u64,
        /// Why.
        error: StateError,
    },
    /// The frame is intact but the journal does not decode: nothing after
    /// it in that segment is used.
    #[error("the journal of tick {tick} does not decode: {error}")]
    Journal {
        /// Its tick.
        tick: u64,
        /// Why.
        error: journal::JournalError,
    },
}

/// What [`History::salvage`] found besides the history.
#[derive(Debug, Clone, Default)]
pub struct SalvageReport {
    /// Damage, oldest first.
    pub damage: Vec<Damage>,
    /// The torn tail the newest segment ends in (a crash mid-append), if
    /// any: the records end before it.
    pub torn_tail: Option<SegmentDamage>,
    /// Where each keyframe loaded is: its segment file and frame offset,
    /// by its tick and applied count.
    pub keyframes: BTreeMap<(u64, u32), (PathBuf, u64)>,
}

impl Default for History {
    fn default() -> Self {
        Self::new(DEFAULT_KEYFRAME_BUDGET)
    }
}

impl History {
    /// An empty history holding at most `budget` bytes of keyframes and
    /// checkpoints.
    pub fn new(budget: usize) -> Self {
        History {
            sessions: BTreeSet::new(),
            keyframes: BTreeMap::new(),
            keyframe_bytes: 0,
            budget: budget.max(1),
            journal: BTreeMap::new(),
            journal_bytes: 0,
            hashes: BTreeMap::new(),
            hash_bytes: 0,
            hashed_ticks: 0,
            journal_entries: 0,
            checkpoints: BTreeMap::new(),
            checkpoint_bytes: 0,
            packer: None,
        }
    }

    /// A recording session starts at `tick` (its keyframe follows).
    pub fn start_session(&mut self, tick: u64) {
        self.sessions.insert(tick);
    }

    /// Holds a keyframe (thinning older ones past the budget). Its spare
    /// capacity is given back when no one else holds it.
    pub fn add_keyframe(&mut self, tick: u64, applied: u32, mut bytes: Arc<Vec<u8>>) {
        if let Some(v) = Arc::get_mut(&mut bytes) {
            v.shrink_to_fit();
        }
        self.keyframe_bytes += bytes.capacity();
        if let Some(old) = self.keyframes.insert((tick, applied), bytes) {
            self.keyframe_bytes -= old.capacity();
        }
        self.thin();
    }

    /// Holds a checkpoint of `tick` (`raw`: an encoded [`SimState`] with
    /// nothing of its tick's journal applied), packed against the newest
    /// keyframe before it in its session, on the packer thread: it can be
    /// seeked from a tick or so later. Not held when there is no keyframe
    /// before it (or the packer is behind).
    pub fn add_checkpoint(&mut self, tick: u64, raw: Vec<u8>) {
        self.collect_packed();
        let Some(session) = self.session_of(tick) else {
            return;
        };
        let Some((&key, bytes)) = self.keyframes.range((session, 0)..(tick, 0)).next_back() else {
            return;
        };
        let packer = self.packer.get_or_insert_with(Packer::start);
        packer.send(PackJob {
            tick,
            base: key,
            dictionary: bytes.clone(),
            raw,
        });
    }

    /// Takes in what the packer thread has packed so far.
    pub fn collect_packed(&mut self) {
        let Some(packer) = &self.packer else { return };
        let done: Vec<(u64, Checkpoint)> = packer.done.try_iter().collect();
        for (tick, checkpoint) in done {
            if !self.keyframes.contains_key(&checkpoint.base) {
                continue; // its keyframe was thinned meanwhile
            }
            self.checkpoint_bytes += checkpoint.packed.capacity();
            if let Some(old) = self.checkpoints.insert(tick, checkpoint) {
                self.checkpoint_bytes -= old.packed.capacity();
            }
        }
        self.thin();
    }

    /// What is held, by part (see the module docs).
    pub fn held(&self) -> HeldBytes {
        HeldBytes {
            keyframes: self.keyframe_bytes,
            checkpoints: self.checkpoint_bytes,
            hashes: self.hash_bytes,
            journal: self.journal_bytes,
        }
    }

    /// Bytes of keyframes and checkpoints held (what the budget bounds).
    fn bytes_held(&self) -> usize {
        self.keyframe_bytes + self.checkpoint_bytes
    }

    /// Brings the memory held under budget: every second checkpoint
    /// (oldest first), then every second keyframe that does not start a
    /// session, with the checkpoints packed against it (the newest
    /// keyframe always stays).
    fn thin(&mut self) {
        if self.bytes_held() <= self.budget {
            return;
        }
        let target = self.budget / 2;
        let ticks: Vec<u64> = self.checkpoints.keys().copied().collect();
        let mut drop = false;
        for tick in ticks {
            if self.bytes_held() <= target {
                return;
            }
            if drop {
                if let Some(c) = self.checkpoints.remove(&tick) {
                    self.checkpoint_bytes -= c.packed.capacity();
                }
            }
            drop = !drop;
        }
        let keys: Vec<(u64, u32)> = self.keyframes.keys().copied().collect();
        let last = keys.last().copied();
        let mut drop = false;
        for key in keys {
            if self.bytes_held() <= target {
                break;
            }
            if Some(key) == last || (self.sessions.contains(&key.0) && key.1 == 0) {
                continue;
            }
            if drop {
                self.drop_keyframe(key);
            }
            drop = !drop;
        }
    }

    /// The checkpoint of `tick` unpacked, if held.
    fn checkpoint_state(&self, tick: u64) -> Option<Vec<u8>> {
        let c = self.checkpoints.get(&tick)?;
        let dict = self.keyframes.get(&c.base)?;
        let mut d = zstd::bulk::Decompressor::with_dictionary(dict).ok()?;
        d.decompress(&c.packed, c.len).ok()
    }

    /// Appends entries applied while the world stood at `tick`.
    pub fn add_journal(&mut self, tick: u64, entries: &[JournalEntry]) {
        if entries.is_empty() {
            return;
        }
        self.journal_entries += entries.len() as u64;
        let held = self.journal.entry(tick).or_default();
        if held.is_empty() {
            self.journal_bytes += JOURNAL_BYTES_PER_TICK;
        }
        self.journal_bytes -= held.capacity() * JOURNAL_BYTES_PER_ENTRY;
        held.reserve_exact(entries.len());
        held.extend_from_slice(entries);
        self.journal_bytes += held.capacity() * JOURNAL_BYTES_PER_ENTRY;
    }

    /// Notes the state hash after `tick`.
    pub fn add_hash(&mut self, tick: u64, hash: u64) {
        self.put_hash(tick, hash);
        self.collect_packed();
    }

    /// Puts `hash` in the run holding `tick`, at the end of the run before
    /// it when it follows on and there is room, or in a new run. (Runs do
    /// not overlap: a run starting at `tick` would be the one found.)
    fn put_hash(&mut self, tick: u64, hash: u64) {
        if let Some((&start, run)) = self.hashes.range_mut(..=tick).next_back() {
            let i = (tick - start) as usize;
            if let Some(held) = run.get_mut(i) {
                *held = hash;
                return;
            }
            if i == run.len() && run.len() < HASH_RUN {
                run.push(hash);
                self.hashed_ticks += 1;
                return;
            }
        }
        let mut run = Vec::with_capacity(HASH_RUN);
        run.push(hash);
        self.hash_bytes += run.capacity() * HASH_BYTES_PER_TICK + HASH_RUN_OVERHEAD;
        self.hashes.insert(tick, run);
        self.hashed_ticks += 1;
    }

    /// The recorded state hash after `tick`.
    pub fn hash_at(&self, tick: u64) -> Option<u64> {
        let (&start, run) = self.hashes.range(..=tick).next_back()?;
        run.get((tick - start) as usize).copied()
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
            .last_hashed()
            .unwrap_or(first)
            .max(self.keyframes.last_key_value().map_or(first, |(k, _)| k.0));
        Some((first, last))
    }

    /// Whether `tick` can be shown: it was hashed, or a session started
    /// at it.
    pub fn reachable(&self, tick: u64) -> bool {
        self.hash_at(tick).is_some() || self.sessions.contains(&tick)
    }

    /// The session `tick` belongs to: the newest start at or before it.
    pub fn session_of(&self, tick: u64) -> Option<u64> {
        self.sessions.range(..=tick).next_back().copied()
    }

    /// The keyframe to re-simulate `target` from: the newest of its
    /// session taken before `target`'s step was done with, i.e. at an
    /// earlier tick, or at `target` with nothing of its journal applied.
    /// A checkpoint held in memory counts as a keyframe here.
    pub fn base_for(&self, target: u64) -> Option<HeldKeyframe> {
        let session = self.session_of(target)?;
        let keyframe = self
            .keyframes
            .range((session, 0)..=(target, 0))
            .next_back()
            .map(|(&(tick, applied), bytes)| HeldKeyframe {
                tick,
                applied,
                bytes: bytes.clone(),
            });
        let checkpoint = self
            .checkpoints
            .range(session..=target)
            .next_back()
            .map(|(&t, _)| t)
            .filter(|&t| keyframe.as_ref().is_none_or(|k| t > k.tick));
        if let Some(tick) = checkpoint {
            if let Some(bytes) = self.checkpoint_state(tick) {
                return Some(HeldKeyframe {
                    tick,
                    applied: 0,
                    bytes: Arc::new(bytes),
                });
            }
        }
        keyframe
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

    /// Every keyframe held, newest first.
    pub fn keyframes_newest_first(&self) -> Vec<HeldKeyframe> {
        self.keyframes
            .iter()
            .rev()
            .map(|(&(tick, applied), bytes)| HeldKeyframe {
                tick,
                applied,
                bytes: bytes.clone(),
            })
            .collect()
    }

    /// Lets go of a keyframe (one that does not restore), and of the
    /// checkpoints packed against it.
    pub fn remove_keyframe(&mut self, tick: u64, applied: u32) {
        self.drop_keyframe((tick, applied));
    }

    /// Lets go of the keyframe `key` and of the checkpoints packed against
    /// it, counting their capacity back.
    fn drop_keyframe(&mut self, key: (u64, u32)) {
        if let Some(bytes) = self.keyframes.remove(&key) {
            self.keyframe_bytes -= bytes.capacity();
        }
        let orphans: Vec<u64> = self
            .checkpoints
            .iter()
            .filter(|(_, c)| c.base == key)
            .map(|(&t, _)| t)
            .collect();
        for t in orphans {
            if let Some(c) = self.checkpoints.remove(&t) {
                self.checkpoint_bytes -= c.packed.capacity();
            }
        }
    }

    /// The last tick hashed from `tick` on within the session `tick`
    /// belongs to: up to the next session's start, inclusive (a session
    /// that carries on from a resume starts at the tick the one before it
    /// last hashed).
    pub fn last_hashed_from(&self, tick: u64) -> Option<u64> {
        let next = self
            .sessions
            .range((Bound::Excluded(tick), Bound::Unbounded))
            .next()
            .copied();
        // Hashes are held in runs of consecutive ticks: the last run that
        // starts by the bound, cut at it.
        let upper = next.unwrap_or(u64::MAX);
        let (&start, run) = self.hashes.range(..=upper).next_back()?;
        let last = (start + run.len() as u64 - 1).min(upper);
        (last >= tick).then_some(last)
    }

    /// The last tick hashed, if any.
    pub fn last_hashed(&self) -> Option<u64> {
        self.hashes
            .last_key_value()
            .map(|(&start, run)| start + run.len() as u64 - 1)
    }

    /// Keyframes held, and their bytes (capacity).
    pub fn keyframe_stats(&self) -> (usize, usize) {
        (self.keyframes.len(), self.keyframe_bytes)
    }

    /// Checkpoints held, and their packed bytes (capacity).
    pub fn checkpoint_stats(&self) -> (usize, usize) {
        (self.checkpoints.len(), self.checkpoint_bytes)
    }

    /// Journal entries held.
    pub fn journal_entries(&self) -> u64 {
        self.journal_entries
    }

    /// Ticks hashed.
    pub fn hashed_ticks(&self) -> usize {
        self.hashed_ticks
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
        h.start_orphan_session();
        Ok(h)
    }

    /// Reads a recording directory into memory as far as it can be
    /// trusted, reading past damage (see the module docs); fails only on
    /// I/O errors. Returns the history and what was found.
    pub fn salvage(dir: &Path, budget: usize) -> Result<(History, SalvageReport), HistoryError> {
        let reader = RecordReader::open(dir)?;
        let files = reader.segment_files();
        let mut h = History::new(budget);
        let mut report = SalvageReport::default();
        // After damage, records are not used until replay can start again.
        let mut resync = false;
        let mut records = reader.salvage();
        while let Some(item) = records.next() {
            let (segment, offset, record) = match item? {
                Salvaged::Record {
                    segment,
                    offset,
                    record,
                } => (segment, offset, record),
                Salvaged::Damaged { damage, read_on_at } => {
                    report.damage.push(Damage {
                        path: damage.path,
                        offset: damage.offset,
                        why: DamageKind::Frame {
                            why: damage.why,
                            read_on_at,
                        },
                    });
                    resync = true;
                    continue;
                }
                Salvaged::TornTail(d) => {
                    report.torn_tail = Some(d);
                    continue;
                }
            };
            let path = || files[segment].path.clone();
            match record {
                Record::SessionStart { tick, .. } => {
                    h.start_session(tick);
                    resync = false;
                }
                Record::Keyframe { tick, state } => match SimState::peek(&state) {
                    Ok((_, applied)) => {
                        if resync {
                            if applied != 0 {
                                continue;
                            }
                            h.start_session(tick);
                            resync = false;
                        }
                        report.keyframes.insert((tick, applied), (path(), offset));
                        h.add_keyframe(tick, applied, Arc::new(state));
                    }
                    Err(error) => report.damage.push(Damage {
                        path: path(),
                        offset,
                        why: DamageKind::Keyframe { tick, error },
                    }),
                },
                _ if resync => {}
                Record::Journal { tick, entries } => match journal::decode(tick, &entries) {
                    Ok(entries) => h.add_journal(tick, &entries),
                    Err(error) => {
                        report.damage.push(Damage {
                            path: path(),
                            offset,
                            why: DamageKind::Journal { tick, error },
                        });
                        records.skip_rest_of_segment();
                        resync = true;
                    }
                },
                Record::TickHash { tick, hash } => h.add_hash(tick, hash),
                Record::Inputs { .. } | Record::AdminEdit { .. } => {}
            }
        }
        h.start_orphan_session();
        Ok((h, report))
    }

    /// A directory whose first segment retention removed starts at a
    /// keyframe without its session start: that keyframe starts one.
    fn start_orphan_session(&mut self) {
        if let Some((&(tick, _), _)) = self.keyframes.first_key_value() {
            if self.session_of(tick).is_none() {
                self.start_session(tick);
            }
        }
    }
}
