//! Entity deltas coded once per frame and reused by every client that
//! needs the same one.
//!
//! How an entity is coded depends only on its state in the frame and its
//! state in the client's baseline (or on there being none). Clients that
//! received the same update of an entity hold the same baseline state of
//! it, so their deltas of it are the same bits: [`DeltaCache`] keeps,
//! for one [`QuantizedFrame`], each delta sized so far (every client sizes
//! every changed entity to fill its budget) and, once some client sends
//! it, its bits (packed in one buffer of words, with a range per delta),
//! and hands both to the next client with the same baseline state. In the
//! spirit of bevy_replicon's serialized data (one buffer for a tick's
//! replication messages, with each client's ranges into it). A client's
//! datagram is the same byte for byte whether its deltas were coded for
//! it or reused.

use crate::bits::{BitWriter, WordPacker};

use super::code::{write_body, BitCount, BitSink};
use super::frame::QuantizedFrame;
use super::view::QuantizedEntity;
use super::SnapshotConfig;

/// No delta (the end of an entity's list).
const NONE: u32 = u32::MAX;

/// One coded delta of one entity.
#[derive(Debug, Clone, Copy)]
struct Delta {
    /// The baseline state it was coded against (`None`: no baseline).
    base: Option<QuantizedEntity>,
    /// The entity's index in the frame.
    index: u32,
    /// Its bits, a range of words of [`DeltaCache::words`]; [`NONE`]
    /// until a client first writes it (most deltas are sized, for the budget, by
    /// far more clients than send them).
    start: u32,
    end: u32,
    /// Its size, bits.
    bits: u32,
}

/// A delta as a lookup walks it: a digest of its baseline state and the
/// entity's previous delta (a list per entity), or [`NONE`]. Kept apart
/// from [`Delta`], 16 bytes to its 60, so walking a list reads little.
#[derive(Debug, Clone, Copy)]
struct DeltaLink {
    digest: u64,
    next: u32,
}

/// A digest of a baseline state: equal states have equal digests, so a
/// walk compares whole states only where the digests agree.
fn digest(base: Option<&QuantizedEntity>) -> u64 {
    let Some(q) = base else {
        return 0;
    };
    let mut h: u64 = 0x9E37_79B9_7F4A_7C15;
    let mut mix = |x: u64| h = (h ^ x).wrapping_mul(0x1000_0000_01B3).rotate_left(29);
    for p in q.position {
        mix(u64::from(p));
    }
    mix(u64::from(q.rotation.largest) | u64::from(q.at_rest) << 8);
    for r in q.rotation.small {
        mix(u64::from(r));
    }
    match q.velocity {
        Some(v) => v.iter().for_each(|&x| mix(u64::from(x) | 1 << 32)),
        None => mix(2 << 32),
    }
    h | 1
}

/// The deltas of one frame's entities coded so far, for every client's
/// encoder of that frame (see the module docs). Made once and kept: it
/// empties itself when handed a different frame.
#[derive(Debug, Clone, Default)]
pub(crate) struct DeltaCache {
    /// The frame the deltas are of ([`QuantizedFrame::serial`]).
    frame: Option<u64>,
    /// Each entity's newest delta, by index into the frame, or [`NONE`].
    heads: Vec<u32>,
    deltas: Vec<Delta>,
    /// Each delta's [`DeltaLink`], by the same index.
    links: Vec<DeltaLink>,
    /// Every written delta's bits, packed least significant first as a
    /// [`BitWriter`] packs them, each delta from a fresh word.
    words: Vec<u64>,
    /// Lookups answered from a delta coded before.
    reused: u64,
}

/// A handle to one coded delta.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct DeltaRef(u32);

/// Packs a delta's bits into words, for clients to copy a word at a time
/// (a delta is a dozen writes of a few bits each; copied, two or three).
struct DeltaRecorder<'a> {
    words: &'a mut Vec<u64>,
    packer: WordPacker,
    bits: u32,
}

impl BitSink for DeltaRecorder<'_> {
    fn put(&mut self, value: u64, bits: u32) {
        if bits == 0 {
            return;
        }
        self.bits += bits;
        if let Some(word) = self.packer.put(value, bits) {
            self.words.push(word);
        }
    }
}

impl DeltaRecorder<'_> {
    /// Pushes the last, partial word.
    fn finish(self) {
        let (word, bits) = self.packer.rest();
        if bits > 0 {
            self.words.push(word);
        }
    }
}

impl DeltaCache {
    /// Deltas handed out that had been coded before (for another client
    /// with the same baseline state), since this was made.
    pub(crate) fn reused(&self) -> u64 {
        self.reused
    }

    /// Deltas coded for the current frame.
    pub(crate) fn coded(&self) -> usize {
        self.deltas.len()
    }

    /// Makes the deltas those of `frame`, emptying them if they were of
    /// another.
    pub(crate) fn start(&mut self, frame: &QuantizedFrame) {
        if self.frame != Some(frame.serial()) {
            self.frame = Some(frame.serial());
            self.heads.clear();
            self.heads.resize(frame.len(), NONE);
            self.deltas.clear();
            self.links.clear();
            self.words.clear();
        }
    }

    /// The delta of entity `i` of the frame against `base`, coded now if
    /// no client needed it before; with its size in bits. Call
    /// [`Self::start`] with the frame first.
    pub(crate) fn delta(
        &mut self,
        frame: &QuantizedFrame,
        i: usize,
        base: Option<&QuantizedEntity>,
        config: &SnapshotConfig,
    ) -> (DeltaRef, usize) {
        let key = digest(base);
        let mut at = self.heads[i];
        while at != NONE {
            let link = self.links[at as usize];
            if link.digest == key {
                let d = &self.deltas[at as usize];
                if d.base.as_ref() == base {
                    self.reused += 1;
                    return (DeltaRef(at), d.bits as usize);
                }
            }
            at = link.next;
        }
        let mut size = BitCount::default();
        write_body(&mut size, &frame.state(i), base, config);
        let bits = size.0 as u32;
        let index = self.deltas.len() as u32;
        self.deltas.push(Delta {
            base: base.copied(),
            index: i as u32,
            start: NONE,
            end: NONE,
            bits,
        });
        self.links.push(DeltaLink {
            digest: key,
            next: self.heads[i],
        });
        self.heads[i] = index;
        (DeltaRef(index), bits as usize)
    }

    /// Writes delta `d` of `frame` into `w`, coding its bits the first
    /// time a client sends it and copying them after.
    pub(crate) fn write(
        &mut self,
        frame: &QuantizedFrame,
        d: DeltaRef,
        config: &SnapshotConfig,
        w: &mut BitWriter,
    ) {
        let delta = self.deltas[d.0 as usize];
        let (start, end) = if delta.start == NONE {
            let start = self.words.len();
            let mut recorder = DeltaRecorder {
                words: &mut self.words,
                packer: WordPacker::default(),
                bits: 0,
            };
            let q = frame.state(delta.index as usize);
            write_body(&mut recorder, &q, delta.base.as_ref(), config);
            debug_assert_eq!(recorder.bits, delta.bits);
            recorder.finish();
            let end = self.words.len();
            let slot = &mut self.deltas[d.0 as usize];
            (slot.start, slot.end) = (start as u32, end as u32);
            (start, end)
        } else {
            (delta.start as usize, delta.end as usize)
        };
        let mut left = delta.bits;
        for &word in &self.words[start..end] {
            let bits = left.min(64);
            w.write(word, bits);
            left -= bits;
        }
    }
}
