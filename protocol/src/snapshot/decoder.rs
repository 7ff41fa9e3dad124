//! The client's half: [`SnapshotDecoder`] turns untrusted datagrams back
//! into views and says what to acknowledge.

use std::sync::Arc;

use crate::bits::BitReader;
use crate::entity::EntityId;
use crate::property::{PropertyRow, PropertySchema};

use super::property_section::read_section;

use super::code::{read_body, read_varuint, COUNT_CLASSES, ID_CLASSES, TICK_CLASSES};
use super::view::{QuantizedEntity, Ring, View, ViewEntity};
use super::{
    sequence_newer, SnapshotConfig, SnapshotConfigError, SnapshotError, MAX_ENTITIES,
    MAX_TIME_SCALE, RING, SNAPSHOT_TAG,
};

/// The fewest bits one listed entity takes (id gap, at-rest bit, position
/// class, rotation-changed bit): bounds a claimed count by the bytes.
const MIN_ENTITY_BITS: usize = 6;

/// One decoded snapshot.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct DecodedSnapshot {
    /// Its sequence number.
    pub sequence: u16,
    /// The view it was coded against, if any.
    pub baseline: Option<u16>,
    /// False when a newer snapshot had already arrived (it arrived out of
    /// order; a client interpolating may still place it in its buffer).
    pub newest: bool,
    /// The tick it describes.
    pub tick: u64,
    /// The server clock's time scale (1 = real time, 0 = stopped, negative
    /// while history plays backwards), finite, |scale| ≤ [`MAX_TIME_SCALE`].
    pub time_scale: f32,
    /// Whether the server's clock is paused.
    pub paused: bool,
    /// The entities this snapshot carried (their state changed since the
    /// baseline, or they entered the view), ascending by id, in world
    /// units. The rest of the view is as the baseline had it: no news of
    /// this tick ([`SnapshotDecoder::entities`] gives the whole view).
    pub updated: Vec<ViewEntity>,
    /// Ids that left the view (despawned or out of interest), ascending;
    /// their properties left with them.
    pub removed: Vec<EntityId>,
    /// The property rows this snapshot changed (whole, raw, in the
    /// schema's order), ascending by id: the game's properties of these
    /// entities as of `tick`.
    pub properties: Vec<(EntityId, PropertyRow)>,
    /// The match's properties, when this snapshot changed them.
    pub match_state: Option<PropertyRow>,
}

/// Counts of what arrived, by outcome.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct DecodeStats {
    /// Snapshots decoded.
    pub decoded: u64,
    /// Dropped: coded against a view not held.
    pub missing_baseline: u64,
    /// Dropped: already received.
    pub duplicate: u64,
    /// Dropped: older than the ring.
    pub stale: u64,
    /// Dropped: not a snapshot, too long, truncated or malformed.
    pub malformed: u64,
}

/// Decodes one server's snapshots for one client.
#[derive(Debug, Clone)]
pub struct SnapshotDecoder {
    config: SnapshotConfig,
    received: Ring,
    newest: Option<u16>,
    /// Bit `i`: snapshot `newest - 1 - i` was decoded.
    ack_bits: u32,
    stats: DecodeStats,
    /// The entities of the datagram being decoded, as coded (kept for
    /// its memory).
    updated: Vec<(EntityId, QuantizedEntity)>,
    /// The removals of the datagram being decoded (kept for its memory).
    removed: Vec<EntityId>,
    /// The game's properties (none by default).
    schema: Arc<PropertySchema>,
}

impl SnapshotDecoder {
    /// A decoder that has received nothing.
    pub fn new(config: SnapshotConfig) -> Result<Self, SnapshotConfigError> {
        config.validate()?;
        Ok(Self {
            config,
            received: Ring::new(),
            newest: None,
            ack_bits: 0,
            stats: DecodeStats::default(),
            updated: Vec::new(),
            removed: Vec::new(),
            schema: Arc::default(),
        })
    }

    /// The same decoder, reading the game's properties of `schema` (the
    /// server's, from its welcome).
    pub fn with_properties(mut self, schema: Arc<PropertySchema>) -> Self {
        self.schema = schema;
        self
    }

    /// The game's properties it reads.
    pub fn schema(&self) -> &PropertySchema {
        &self.schema
    }

    /// The configuration.
    pub fn config(&self) -> &SnapshotConfig {
        &self.config
    }

    /// What to acknowledge: the newest snapshot decoded and a bitfield of
    /// the 32 before it (bit `i` set: `newest - 1 - i` was decoded).
    pub fn ack_state(&self) -> (Option<u16>, u32) {
        (self.newest, self.ack_bits)
    }

    /// Counts so far.
    pub fn stats(&self) -> DecodeStats {
        self.stats
    }

    /// The view snapshot `sequence` described, while held.
    pub fn view(&self, sequence: u16) -> Option<&View> {
        self.received.get(sequence)
    }

    /// The whole view snapshot `sequence` described, in world units,
    /// ascending by id, while held.
    pub fn entities(&self, sequence: u16) -> Option<Vec<ViewEntity>> {
        let config = self.config;
        self.received.get(sequence).map(|view| {
            view.entities()
                .iter()
                .map(|(id, q)| q.dequantize(*id, &config))
                .collect()
        })
    }

    /// Decodes one datagram. On any error nothing changes but the counts.
    pub fn decode(&mut self, bytes: &[u8]) -> Result<DecodedSnapshot, SnapshotError> {
        let mut out = DecodedSnapshot::default();
        self.decode_into(bytes, &mut out).map(|()| out)
    }

    /// [`Self::decode`] into `out`, reusing its memory: a client decoding
    /// 30 snapshots a second of a thousand entities allocates nothing once
    /// `out` has grown. On any error nothing changes but the counts, `out`
    /// included.
    pub fn decode_into(
        &mut self,
        bytes: &[u8],
        out: &mut DecodedSnapshot,
    ) -> Result<(), SnapshotError> {
        let result = self.decode_inner(bytes, out);
        let s = &mut self.stats;
        match &result {
            Ok(_) => s.decoded += 1,
            Err(SnapshotError::MissingBaseline { .. }) => s.missing_baseline += 1,
            Err(SnapshotError::Duplicate { .. }) => s.duplicate += 1,
            Err(SnapshotError::Stale { .. }) => s.stale += 1,
            Err(_) => s.malformed += 1,
        }
        result
    }

    fn decode_inner(
        &mut self,
        bytes: &[u8],
        out: &mut DecodedSnapshot,
    ) -> Result<(), SnapshotError> {
        let config = self.config;
        if bytes.len() > config.max_datagram {
            return Err(SnapshotError::TooLong {
                len: bytes.len(),
                max: config.max_datagram,
            });
        }
        let mut r = BitReader::new(bytes);
        let tag = r.read(8)? as u8;
        if tag != SNAPSHOT_TAG {
            return Err(SnapshotError::WrongKind { tag });
        }
        let sequence = r.read(16)? as u16;
        if self.received.get(sequence).is_some() {
            return Err(SnapshotError::Duplicate { sequence });
        }
        if let Some(newest) = self.newest {
            if sequence_newer(newest, sequence)
                && usize::from(newest.wrapping_sub(sequence)) >= RING
            {
                return Err(SnapshotError::Stale { sequence, newest });
            }
        }
        let baseline = if r.read_bool()? {
            let b = r.read(16)? as u16;
            if !sequence_newer(sequence, b) || usize::from(sequence.wrapping_sub(b)) > RING {
                return Err(SnapshotError::Malformed(
                    "baseline not within the ring before the snapshot",
                ));
            }
            Some(b)
        } else {
            None
        };
        let empty = View::default();
        let base = match baseline {
            Some(b) => self.received.get(b).ok_or(SnapshotError::MissingBaseline {
                sequence,
                baseline: b,
            })?,
            None => &empty,
        };
        let tick = if r.read_bool()? {
            if baseline.is_none() {
                return Err(SnapshotError::Malformed("relative tick without a baseline"));
            }
            base.tick
                .checked_add(read_varuint(&mut r, &TICK_CLASSES)?)
                .ok_or(SnapshotError::Malformed("tick overflows"))?
        } else {
            r.read(64)?
        };
        let time_scale = if r.read_bool()? {
            1.0
        } else {
            f32::from_bits(r.read(32)? as u32)
        };
        if !(time_scale.is_finite() && time_scale.abs() <= MAX_TIME_SCALE) {
            return Err(SnapshotError::Malformed(
                "time scale not finite or beyond ±MAX_TIME_SCALE",
            ));
        }
        let paused = r.read_bool()?;

        read_entities(&mut r, base, &config, &mut self.removed, &mut self.updated)?;
        let (removed, updated) = (&self.removed, &self.updated);
        let (properties, match_state) =
            read_section(&mut r, &self.schema, base.properties(), |id| {
                updated.binary_search_by_key(&id, |e| e.0).is_ok()
                    || (base.get(id).is_some() && removed.binary_search(&id).is_err())
            })?;
        if r.bits_left() >= 8 {
            return Err(SnapshotError::Malformed("trailing bytes"));
        }
        let spare = self.received.spare_for(sequence, baseline);
        let base = match baseline {
            Some(b) => self.received.get(b).expect("found above"),
            None => &empty,
        };
        let mut view = base.apply_into(tick, &self.removed, &self.updated, spare);
        if !(properties.is_empty() && match_state.is_none() && view.properties.is_empty()) {
            view.properties =
                view.properties
                    .apply(&self.removed, &properties, match_state.as_ref());
        }
        self.received.insert(sequence, view);
        out.properties = properties;
        out.match_state = match_state;
        out.updated.clear();
        out.updated.extend(
            self.updated
                .iter()
                .map(|(id, q)| q.dequantize(*id, &config)),
        );
        out.removed.clone_from(&self.removed);
        out.newest = self.note_received(sequence);
        out.sequence = sequence;
        out.baseline = baseline;
        out.tick = tick;
        out.time_scale = time_scale;
        out.paused = paused;
        Ok(())
    }

    /// Records `sequence` for acknowledgement; whether it is the newest.
    fn note_received(&mut self, sequence: u16) -> bool {
        match self.newest {
            Some(n) if !sequence_newer(sequence, n) => {
                let back = u32::from(n.wrapping_sub(sequence));
                if (1..=32).contains(&back) {
                    self.ack_bits |= 1 << (back - 1);
                }
                false
            }
            Some(n) => {
                let ahead = u32::from(sequence.wrapping_sub(n));
                self.ack_bits = if ahead > 32 {
                    0
                } else {
                    ((u64::from(self.ack_bits) << ahead) | (1u64 << (ahead - 1))) as u32
                };
                self.newest = Some(sequence);
                true
            }
            None => {
                self.newest = Some(sequence);
                true
            }
        }
    }
}

/// Reads a count of at most `max`.
fn read_count(r: &mut BitReader<'_>, max: usize) -> Result<usize, SnapshotError> {
    let n = read_varuint(r, &COUNT_CLASSES)?;
    if n > max as u64 {
        return Err(SnapshotError::Malformed("count above its bound"));
    }
    Ok(n as usize)
}

/// Reads one id gap after `prev`.
fn read_id(r: &mut BitReader<'_>, prev: Option<EntityId>) -> Result<EntityId, SnapshotError> {
    let gap = read_varuint(r, &ID_CLASSES)?;
    let id = match prev {
        Some(p) => u64::from(p) + 1 + gap,
        None => gap,
    };
    EntityId::try_from(id).map_err(|_| SnapshotError::Malformed("entity id overflows"))
}

/// Reads a snapshot's removals and entities against its baseline `base`
/// into `removed` and `updated` (emptied first), checking that every
/// removal names an entity of the view, that none is both removed and
/// updated, and that the view stays within [`MAX_ENTITIES`].
fn read_entities(
    r: &mut BitReader<'_>,
    base: &View,
    config: &SnapshotConfig,
    removed: &mut Vec<EntityId>,
    updated: &mut Vec<(EntityId, QuantizedEntity)>,
) -> Result<(), SnapshotError> {
    read_ids(r, base.len(), removed)?;
    // Every removal must name an entity of the baseline.
    // (Ids come in ascending order: a cursor walks the baseline.)
    let mut at = 0;
    if removed
        .iter()
        .any(|&id| base.find_from(&mut at, id).is_none())
    {
        return Err(SnapshotError::Malformed("removal of an entity not in view"));
    }
    let mut at = 0;
    let bound = MAX_ENTITIES.min(r.bits_left() / MIN_ENTITY_BITS);
    let count = read_count(r, bound)?;
    updated.clear();
    updated.reserve(count);
    let mut prev = None;
    let mut new = 0;
    for _ in 0..count {
        let id = read_id(r, prev)?;
        prev = Some(id);
        if removed.binary_search(&id).is_ok() {
            return Err(SnapshotError::Malformed("entity both removed and updated"));
        }
        let held = base.find_from(&mut at, id);
        new += usize::from(held.is_none());
        let q = read_body(r, held, config)?;
        updated.push((id, q));
    }
    if base.len() - removed.len() + new > MAX_ENTITIES {
        return Err(SnapshotError::Malformed("view above MAX_ENTITIES"));
    }
    Ok(())
}

/// Reads a counted list of ascending ids, at most `max` of them.
fn read_ids(
    r: &mut BitReader<'_>,
    max: usize,
    ids: &mut Vec<EntityId>,
) -> Result<(), SnapshotError> {
    // Each id takes at least 3 bits, which bounds the allocation.
    let bound = max.min(MAX_ENTITIES).min(r.bits_left() / 3);
    let count = read_count(r, bound)?;
    ids.clear();
    ids.reserve(count);
    let mut prev = None;
    for _ in 0..count {
        let id = read_id(r, prev)?;
        ids.push(id);
        prev = Some(id);
    }
    Ok(())
}
