//! One client's inputs on the server: each sequence once, in order,
//! within a bounded window.

use std::collections::BTreeMap;

use super::PlayerInput;

use super::InputDatagram;

/// How far ahead of the next input due an [`InputBuffer`] accepts an
/// input, sequences (18 minutes of inputs at 60 Hz).
pub const INPUT_WINDOW: u32 = 1 << 16;

/// What an [`InputBuffer`] did with the inputs it was given.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct InputBufferStats {
    /// Inputs stored for the first time.
    pub accepted: u64,
    /// Copies of inputs already stored.
    pub duplicates: u64,
    /// Inputs older than the next one due (already handed on or skipped).
    pub too_old: u64,
    /// Inputs dropped because the buffer was full.
    pub overflowed: u64,
    /// Inputs at least [`INPUT_WINDOW`] ahead of the next one due.
    pub too_far: u64,
    /// Sequences never received, passed over by [`InputBuffer::pop`].
    pub skipped: u64,
}

/// One client's inputs on the server: takes decoded datagrams, keeps each
/// input sequence once, and hands them on in sequence order, each exactly
/// once. Bounded: at most `capacity` inputs wait.
///
/// Sequences are compared with wrapping arithmetic: an input less than
/// 2³¹ behind the next one due is old and dropped; one at least
/// [`INPUT_WINDOW`] ahead is refused too, so a client cannot make the
/// server leap over most of the sequence space.
#[derive(Debug, Clone)]
pub struct InputBuffer {
    capacity: usize,
    /// The next sequence due, unwrapped to 64 bits; `None` before the
    /// first input.
    next: Option<u64>,
    /// Waiting inputs by unwrapped sequence.
    pending: BTreeMap<u64, PlayerInput>,
    stats: InputBufferStats,
}

impl InputBuffer {
    /// An empty buffer holding at most `capacity` waiting inputs (a few
    /// ticks' worth is plenty: the server takes one per tick).
    pub fn new(capacity: usize) -> Self {
        Self {
            capacity,
            next: None,
            pending: BTreeMap::new(),
            stats: InputBufferStats::default(),
        }
    }

    /// Takes every input of a datagram. The first datagram ever seen sets
    /// where the sequence starts: its oldest input.
    pub fn push_datagram(&mut self, datagram: &InputDatagram) {
        if self.next.is_none() {
            // The oldest by wrapping order: the one furthest behind the
            // newest.
            if let Some(newest) = datagram.inputs.first() {
                let oldest = datagram
                    .inputs
                    .iter()
                    .max_by_key(|i| newest.sequence.wrapping_sub(i.sequence))
                    .map_or(newest.sequence, |i| i.sequence);
                self.next = Some(u64::from(oldest));
            }
        }
        for input in datagram.inputs.iter().rev() {
            self.push(*input);
        }
    }

    /// Takes one input.
    pub fn push(&mut self, input: PlayerInput) {
        let next = *self.next.get_or_insert(u64::from(input.sequence));
        let ahead = input.sequence.wrapping_sub(next as u32) as i32;
        if ahead < 0 {
            self.stats.too_old += 1;
            return;
        }
        if ahead >= INPUT_WINDOW as i32 {
            self.stats.too_far += 1;
            return;
        }
        let key = next + ahead as u64;
        if self.pending.contains_key(&key) {
            self.stats.duplicates += 1;
            return;
        }
        if self.pending.len() >= self.capacity {
            self.stats.overflowed += 1;
            // Keep the oldest inputs: they are due first.
            match self.pending.last_key_value() {
                Some((&newest, _)) if newest > key => {
                    self.pending.remove(&newest);
                }
                _ => return,
            }
        }
        self.pending.insert(key, input);
        self.stats.accepted += 1;
    }

    /// The next input in sequence order, passing over sequences that never
    /// arrived; `None` when nothing waits.
    pub fn pop(&mut self) -> Option<PlayerInput> {
        let (key, input) = self.pending.pop_first()?;
        if let Some(next) = self.next {
            self.stats.skipped += key - next;
        }
        self.next = Some(key + 1);
        Some(input)
    }

    /// Inputs waiting.
    pub fn len(&self) -> usize {
        self.pending.len()
    }

    /// True when nothing waits.
    pub fn is_empty(&self) -> bool {
        self.pending.is_empty()
    }

    /// The sequence due next, once any input has arrived.
    pub fn next_sequence(&self) -> Option<u32> {
        self.next.map(|n| n as u32)
    }

    /// What the buffer has done so far.
    pub fn stats(&self) -> InputBufferStats {
        self.stats
    }
}
