//! The server's half: one [`SnapshotEncoder`] per client.

use std::sync::Arc;

use crate::bits::BitWriter;
use crate::entity::{EntityId, EntityState};
use crate::priority::{PriorityAccumulator, Standing};
use crate::property::{PropertyRow, PropertySchema};

use super::property_section::{section_bound_bits, SectionWriter};

use super::code::{varuint_bits, write_varuint, COUNT_CLASSES, ID_CLASSES, TICK_CLASSES};
use super::frame::QuantizedFrame;
use super::sent::{Sent, SentLog};
use super::shared::{DeltaCache, DeltaRef};
use super::view::{QuantizedEntity, View};
use super::{SnapshotConfig, SnapshotConfigError, MAX_ENTITIES, MAX_TIME_SCALE, SNAPSHOT_TAG};

/// What the last [`SnapshotEncoder::encode`] did.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct EncodeReport {
    /// The snapshot's sequence number.
    pub sequence: u16,
    /// The view it was coded against, if any.
    pub baseline: Option<u16>,
    /// Datagram size, bytes.
    pub bytes: usize,
    /// Entities whose state was sent.
    pub included: usize,
    /// Entities that differed from the baseline but did not fit the budget.
    pub deferred: usize,
    /// Removals sent.
    pub removed: usize,
    /// Removals that did not fit the budget.
    pub removals_deferred: usize,
    /// Entities in the view the snapshot describes.
    pub view_len: usize,
    /// Property values sent (of entities and the match).
    pub properties: usize,
    /// Bits the property section took.
    pub property_bits: usize,
    /// Entities whose property changes did not fit the budget.
    pub properties_deferred: usize,
}

/// Codes the world for one client: remembers what it sent (the last
/// [`RING`](super::RING) snapshots, each as its change to the view it was
/// coded against), the newest view the client acknowledged, whole, and
/// the next sequence number.
#[derive(Debug, Clone)]
pub struct SnapshotEncoder {
    config: SnapshotConfig,
    log: SentLog,
    next: u16,
    last: EncodeReport,
    /// Buffers of a snapshot the log no longer holds, for the next one.
    spare: Sent,
    /// The deltas of [`Self::encode_frame`], which shares them with no
    /// other client (kept for their memory).
    own: SharedDeltas,
    /// The game's properties (none by default).
    schema: Arc<PropertySchema>,
    /// The id after which the next snapshot starts listing property
    /// changes of entities already in view, so that when they do not all
    /// fit, each gets its turn.
    property_cursor: EntityId,
}

/// What the encoders of one frame share, made once and kept: the deltas
/// coded so far, each entity's coded once per baseline state and copied
/// for every client that needs it ([`super::shared`]), and the working
/// memory of one encode, lent to each encoder in turn ([`Work`]).
#[derive(Debug, Clone, Default)]
pub struct SharedDeltas {
    deltas: DeltaCache,
    work: Work,
}

impl SharedDeltas {
    /// Holds nothing yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// Deltas handed out that had been coded before (for another client
    /// with the same baseline state), since this was made.
    pub fn reused(&self) -> u64 {
        self.deltas.reused()
    }

    /// Deltas coded for the current frame.
    pub fn coded(&self) -> usize {
        self.deltas.coded()
    }
}

/// The buffers one encode fills, kept between encodes so a snapshot
/// allocates only its datagram. Nothing in them outlives an encode, so the
/// encoders of one frame take turns with one set ([`SharedDeltas`] holds
/// it): a server coding for a few hundred clients then writes the same
/// few tens of KB each time, in cache, instead of each client's own.
#[derive(Debug, Clone, Default)]
pub(crate) struct Work {
    removed: Vec<EntityId>,
    candidates: Vec<ChangedEntity>,
    /// Candidates in the order they are sized, as [`sort_key`]s.
    order: Vec<u128>,
    picked: Vec<(EntityId, usize, DeltaRef)>,
    chosen: IndexSet,
    /// The delta of each chosen entity, by frame index (only the chosen
    /// ones are read).
    delta_of: Vec<Option<DeltaRef>>,
    /// The client's always relevant entities, ascending, walked beside
    /// the frame.
    always: Vec<EntityId>,
}

/// An entity that differs from the baseline (24 bytes: a thousand of them
/// are pushed for every snapshot, and ordered by their [`sort_key`]).
#[derive(Debug, Clone, Copy)]
struct ChangedEntity {
    /// Its accumulated priority.
    priority: f64,
    id: EntityId,
    /// Its index in the frame.
    index: u32,
    /// Its index in the baseline view, or [`NOT_IN_BASE`].
    in_base: u32,
}

/// [`ChangedEntity::in_base`] of an entity the baseline does not hold.
const NOT_IN_BASE: u32 = u32::MAX;

/// Candidates are put in priority order this many at a time: a snapshot
/// fills its budget long before the last of a thousand, so the rest need
/// not be sorted.
const SORT_CHUNK: usize = 256;
/// The least bits an entity's update takes (its id gap, flags and a
/// position delta in the smallest classes), for the first chunk's size:
/// about as many as fit the budget, so the first chunk is seldom followed
/// by another and seldom sorts many that will not be sized.
const FEWEST_BITS_AN_ENTITY: usize = 48;
/// Once this many candidates in a row did not fit, the snapshot is full:
/// the rest are not sized (entities of one kind code to much the same
/// size, so one that fits after this many misses is rare).
const MISSES_WHEN_FULL: usize = 16;

/// The key that puts candidate `position` (of those pushed, in ascending
/// id order) of accumulated `priority` in the order it is sized: highest
/// priority first ([`f64::total_cmp`]'s order), ties by id. One integer,
/// so ordering a thousand candidates compares and moves 16 bytes, not a
/// candidate.
fn sort_key(priority: f64, position: usize) -> u128 {
    // The bits of a float, made to order as total_cmp does: negative ones
    // flipped whole, positive ones above them.
    let bits = priority.to_bits();
    let ascending = if bits >> 63 == 1 {
        !bits
    } else {
        bits | 1 << 63
    };
    (u128::from(!ascending) << 64) | position as u128
}

/// The id gap code's size when `id` follows `prev` (`None`: first).
fn id_bits(prev: Option<EntityId>, id: EntityId) -> usize {
    varuint_bits(id_gap(prev, id), &ID_CLASSES)
}

fn id_gap(prev: Option<EntityId>, id: EntityId) -> u64 {
    prev.map_or(u64::from(id), |p| u64::from(id - p - 1))
}

impl SnapshotEncoder {
    /// An encoder that has sent nothing; the first snapshot is sequence 0.
    pub fn new(config: SnapshotConfig) -> Result<Self, SnapshotConfigError> {
        config.validate()?;
        Ok(Self {
            config,
            log: SentLog::new(),
            next: 0,
            last: EncodeReport::default(),
            spare: Sent::default(),
            own: SharedDeltas::new(),
            schema: Arc::default(),
            property_cursor: 0,
        })
    }

    /// The same encoder, coding the game's properties of `schema` from
    /// each frame's ([`QuantizedFrame::with_properties`]); the client's
    /// decoder must know the same schema.
    pub fn with_properties(mut self, schema: Arc<PropertySchema>) -> Self {
        self.schema = schema;
        self
    }

    /// The configuration.
    pub fn config(&self) -> &SnapshotConfig {
        &self.config
    }

    /// The client acknowledged snapshot `sequence`: it may become the
    /// baseline. Acks of snapshots never sent, no longer held, or older
    /// than the newest acknowledged are ignored.
    pub fn on_ack(&mut self, sequence: u16) {
        self.log.on_ack(sequence, self.next);
    }

    /// Acknowledgements as [`super::SnapshotDecoder::ack_state`] gives
    /// them: only the newest matters, as it makes the best baseline.
    pub fn on_ack_state(&mut self, newest: Option<u16>, _ack_bits: u32) {
        if let Some(s) = newest {
            self.on_ack(s);
        }
    }

    /// The newest snapshot the client acknowledged, while it can be the
    /// baseline of the next one (no more than [`RING`](super::RING) back).
    pub fn acked(&self) -> Option<u16> {
        self.log.baseline(self.next).map(|(a, _)| a)
    }

    /// The view snapshot `sequence` described, built from what it sent and
    /// its baseline, while both are held (the last [`RING`](super::RING)
    /// snapshots; a baseline older than the newest acknowledged view only
    /// while a snapshot in flight needs it).
    pub fn view(&self, sequence: u16) -> Option<View> {
        self.log.view(sequence)
    }

    /// Whole views this encoder holds now (the acknowledged one and older
    /// ones snapshots in flight were coded against): its memory beyond
    /// the [`RING`](super::RING) snapshots' changes.
    pub fn held_views(&self) -> usize {
        self.log.held_views()
    }

    /// What the last [`Self::encode`] did.
    pub fn last_report(&self) -> EncodeReport {
        self.last
    }

    /// Codes the next snapshot of `entities` (in any order; an id
    /// repeated is taken once) at `tick`, with the clock's `time_scale`
    /// and `paused` flag: [`QuantizedFrame::new`] then
    /// [`Self::encode_frame`]. A server with many clients quantizes each
    /// frame once and calls [`Self::encode_frame`] for each.
    pub fn encode(
        &mut self,
        tick: u64,
        time_scale: f32,
        paused: bool,
        entities: &[EntityState],
        priorities: &mut PriorityAccumulator,
        budget_bytes: usize,
    ) -> Vec<u8> {
        let frame = QuantizedFrame::new(tick, time_scale, paused, entities, &self.config);
        self.encode_frame(&frame, priorities, budget_bytes)
    }

    /// Codes the next snapshot of `frame` (quantized under this encoder's
    /// config) against the newest view the client acknowledged. Entities
    /// are chosen by `priorities` (which also decides relevance: weight 0
    /// is out of view and removed from the client's view) until the
    /// datagram would exceed `min(budget_bytes, max_datagram)` bytes. The
    /// header and the counts are always written, so a budget below about
    /// 20 bytes still sends them; a budget that does not fit the top
    /// entity sends none.
    pub fn encode_frame(
        &mut self,
        frame: &QuantizedFrame,
        priorities: &mut PriorityAccumulator,
        budget_bytes: usize,
    ) -> Vec<u8> {
        let mut own = std::mem::take(&mut self.own);
        let bytes = self.encode_shared(frame, &mut own, priorities, budget_bytes);
        self.own = own;
        bytes
    }

    /// [`Self::encode_frame`], taking each entity's delta from `shared`
    /// where another client's encoder of the same frame coded it against
    /// the same baseline state (and leaving there the ones coded here).
    /// The datagram is the same byte for byte as without sharing.
    pub fn encode_shared(
        &mut self,
        frame: &QuantizedFrame,
        shared: &mut SharedDeltas,
        priorities: &mut PriorityAccumulator,
        budget_bytes: usize,
    ) -> Vec<u8> {
        self.encode_shared_at(frame, frame.time_scale, shared, priorities, budget_bytes)
    }

    /// [`Self::encode_shared`] with the header's time scale `time_scale`
    /// in place of the frame's: a replay of the frame at that speed.
    pub fn encode_shared_at(
        &mut self,
        frame: &QuantizedFrame,
        time_scale: f32,
        shared: &mut SharedDeltas,
        priorities: &mut PriorityAccumulator,
        budget_bytes: usize,
    ) -> Vec<u8> {
        let config = self.config;
        shared.deltas.start(frame);
        let (tick, paused) = (frame.tick, frame.paused);
        // The decoder refuses scales no clock produces (the frame's field
        // is public, so it is checked here too).
        let time_scale = if time_scale.is_finite() {
            time_scale.clamp(-MAX_TIME_SCALE, MAX_TIME_SCALE)
        } else {
            0.0
        };
        let sequence = self.next;
        let empty = View::default();
        let (baseline, base) = match self.log.baseline(sequence) {
            Some((b, view)) => (Some(b), view),
            None => (None, &empty),
        };

        // Walk the frame and the baseline together, by id.
        let mut work = std::mem::take(&mut shared.work);
        let Work {
            removed,
            candidates,
            order,
            picked,
            chosen,
            delta_of,
            always,
        } = &mut work;
        removed.clear();
        candidates.clear();
        picked.clear();
        always.clear();
        always.extend(priorities.interest().always_relevant.iter().copied());
        let mut next_always = 0;
        let base_entities = base.entities();
        let mut b = 0;
        for (i, &id) in frame.ids().iter().enumerate() {
            while b < base_entities.len() && base_entities[b].0 < id {
                removed.push(base_entities[b].0);
                b += 1;
            }
            let in_base =
                (b < base_entities.len() && base_entities[b].0 == id).then(|| &base_entities[b].1);
            if in_base.is_some() {
                b += 1;
            }
            while always.get(next_always).is_some_and(|&a| a < id) {
                next_always += 1;
            }
            let is_always = always.get(next_always) == Some(&id);
            let relevance = if is_always {
                1.0
            } else {
                priorities.interest().distance_weight(frame.position(i))
            };
            if relevance <= 0.0 {
                if in_base.is_some() {
                    removed.push(id);
                }
                continue;
            }
            if in_base.is_some_and(|q| frame.same_as(i, q)) {
                continue;
            }
            let standing = Standing::new(is_always, frame.at_rest(i));
            candidates.push(ChangedEntity {
                priority: priorities.accumulate_as(id, standing, relevance),
                id,
                index: i as u32,
                in_base: if in_base.is_some() {
                    (b - 1) as u32
                } else {
                    NOT_IN_BASE
                },
            });
        }
        removed.extend(base_entities[b..].iter().map(|e| e.0));
        // Only entities still waiting (the candidates) keep an accumulated
        // priority.
        priorities.end_round();

        // Fill the budget: the header with both counts at their widest,
        // then removals in id order, then entities by priority.
        let budget = budget_bytes.min(config.max_datagram) * 8;
        let tick_rel = tick
            .checked_sub(base.tick)
            .filter(|&d| baseline.is_some() && d < (1 << 16) + (1 << 8) + (1 << 4));
        let mut used = 8 + 16 + 1 + if baseline.is_some() { 16 } else { 0 };
        used += 1 + tick_rel.map_or(64, |d| varuint_bits(d, &TICK_CLASSES));
        used += 1 + if time_scale == 1.0 { 0 } else { 32 } + 1;
        used += 2 * varuint_bits(MAX_ENTITIES as u64, &COUNT_CLASSES);

        let mut removed_sent = std::mem::take(&mut self.spare.removed);
        removed_sent.clear();
        for &id in removed.iter() {
            let cost = id_bits(removed_sent.last().copied(), id);
            if used + cost > budget || removed_sent.len() == MAX_ENTITIES {
                break;
            }
            used += cost;
            removed_sent.push(id);
        }

        // The game's properties: the match's change, then the changes of
        // entities already in view (and staying), within three quarters
        // of what is left (a quarter stays for the entities' states); new
        // entities' come with them, below.
        let section = SectionWriter::new(&self.schema);
        let mut props = PropertyPlan::default();
        if !section.is_empty() {
            used += section_bound_bits(&self.schema);
            props.plan_held(
                &section,
                frame,
                base,
                &removed_sent,
                self.property_cursor,
                budget.saturating_sub(used) * 3 / 4,
            );
            used += props.bits;
        }

        // A view never grows past MAX_ENTITIES: new entities beyond its
        // room wait.
        let mut room = MAX_ENTITIES.saturating_sub(base.len());
        // The chosen, as a set of frame indices (index order is id order).
        chosen.reset(frame.len());
        delta_of.clear();
        delta_of.resize(frame.len(), None);
        order.clear();
        order.extend(
            candidates
                .iter()
                .enumerate()
                .map(|(k, c)| sort_key(c.priority, k)),
        );
        // The first chunk: about as many as the last snapshot took and a
        // half again (the same world codes to much the same sizes from one
        // snapshot to the next), never more than the budget can take. The
        // chunks only decide how much is sorted at a time, not the order,
        // so the datagram is the same whatever their sizes.
        let fit = budget / FEWEST_BITS_AN_ENTITY;
        let expected = self.last.included + self.last.included / 2;
        let first_chunk =
            (fit.min(expected.max(MISSES_WHEN_FULL)) + MISSES_WHEN_FULL).min(SORT_CHUNK);
        let (mut sorted, mut misses) = (0, 0);
        for k in 0..order.len() {
            if misses == MISSES_WHEN_FULL {
                break;
            }
            if k == sorted {
                // The next chunk in priority order.
                let rest = &mut order[sorted..];
                let n = if sorted == 0 { first_chunk } else { SORT_CHUNK }
                    .max(1)
                    .min(rest.len());
                if n < rest.len() {
                    rest.select_nth_unstable(n - 1);
                }
                rest[..n].sort_unstable();
                sorted += n;
            }
            let c = &candidates[order[k] as u32 as usize];
            let new = c.in_base == NOT_IN_BASE;
            if new && room == 0 {
                continue;
            }
            let base_state = (!new).then(|| &base_entities[c.in_base as usize].1);
            let index = c.index as usize;
            let (delta, bits) = shared.deltas.delta(frame, index, base_state, &config);
            let id_at = |j: usize| frame.ids()[j];
            let prev = chosen.before(index).map(id_at);
            let next = chosen.after(index).map(id_at);
            let mut cost = bits + id_bits(prev, c.id);
            if let Some(n) = next {
                // Splitting a gap never costs less than nothing; saturate
                // so an encoding of gaps that is not subadditive cannot
                // underflow.
                cost = (cost + id_bits(Some(c.id), n)).saturating_sub(id_bits(prev, n));
            }
            // A new entity's properties come with it.
            let new_props = if new && !section.is_empty() {
                let row = frame.properties().and_then(|p| p.entity(c.id));
                let (mask, bits) = section.entity_change(row, None);
                cost += if mask == 0 {
                    0
                } else {
                    bits + SectionWriter::id_bound_bits(c.id)
                };
                (mask != 0).then(|| (c.id, mask, row.cloned()))
            } else {
                None
            };
            if used + cost <= budget {
                used += cost;
                chosen.insert(index);
                delta_of[index] = Some(delta);
                room -= usize::from(new);
                props.entities.extend(new_props);
                misses = 0;
            } else {
                misses += 1;
            }
        }
        // The chosen in id order (index order is id order).
        picked.extend(
            chosen
                .iter()
                .filter_map(|i| Some((frame.ids()[i], i, delta_of[i]?))),
        );
        let by_id = &*picked;
        let mut updated: Vec<(EntityId, QuantizedEntity)> = std::mem::take(&mut self.spare.updated);
        updated.clear();
        for &(id, index, _) in by_id {
            updated.push((id, frame.state(index)));
            priorities.sent(id);
        }

        // Write it.
        let mut w = BitWriter::with_capacity(used.div_ceil(8));
        w.write(u64::from(SNAPSHOT_TAG), 8);
        w.write(u64::from(sequence), 16);
        w.write_bool(baseline.is_some());
        if let Some(b) = baseline {
            w.write(u64::from(b), 16);
        }
        w.write_bool(tick_rel.is_some());
        match tick_rel {
            Some(d) => write_varuint(&mut w, d, &TICK_CLASSES),
            None => w.write(tick, 64),
        }
        w.write_bool(time_scale == 1.0);
        if time_scale != 1.0 {
            w.write(u64::from(time_scale.to_bits()), 32);
        }
        w.write_bool(paused);
        write_varuint(&mut w, removed_sent.len() as u64, &COUNT_CLASSES);
        let mut prev = None;
        for &id in &removed_sent {
            write_varuint(&mut w, id_gap(prev, id), &ID_CLASSES);
            prev = Some(id);
        }
        write_varuint(&mut w, updated.len() as u64, &COUNT_CLASSES);
        let mut prev = None;
        for &(id, _, delta) in by_id {
            write_varuint(&mut w, id_gap(prev, id), &ID_CLASSES);
            shared.deltas.write(frame, delta, &config, &mut w);
            prev = Some(id);
        }
        let before_props = w.bit_len();
        let (sent_rows, sent_match) = if section.is_empty() {
            (Vec::new(), None)
        } else {
            props.entities.sort_unstable_by_key(|e| e.0);
            let frame_match = frame.properties().and_then(|p| p.match_state.as_ref());
            section.write(&mut w, (props.match_mask, frame_match), &props.entities);
            if let Some(last) = props.held_last {
                self.property_cursor = last;
            }
            let n = self.schema.entity.len();
            let rows = props
                .entities
                .iter()
                .map(|(id, _, row)| (*id, row.clone().unwrap_or_else(|| zeros(n))))
                .collect();
            let m = self.schema.match_state.len();
            let match_row =
                (props.match_mask != 0).then(|| frame_match.cloned().unwrap_or_else(|| zeros(m)));
            (rows, match_row)
        };
        let property_bits = w.bit_len() - before_props;
        debug_assert!(
            w.bit_len() <= budget.max(used),
            "{} > {budget}",
            w.bit_len()
        );
        let bytes = w.finish();

        // The view it describes: the baseline's, less the removals, with
        // the entities new to it (each took one of the room).
        let new = MAX_ENTITIES.saturating_sub(base.len()) - room;
        let view_len = base.len() - removed_sent.len() + new;
        self.last = EncodeReport {
            sequence,
            baseline,
            bytes: bytes.len(),
            included: updated.len(),
            deferred: candidates.len() - updated.len(),
            removed: removed_sent.len(),
            removals_deferred: removed.len() - removed_sent.len(),
            view_len,
            properties: props.values,
            property_bits,
            properties_deferred: props.deferred,
        };
        let replaced = self.log.record(Sent {
            sequence,
            baseline,
            tick,
            removed: removed_sent,
            updated,
            properties: sent_rows,
            match_state: sent_match,
        });
        self.spare = replaced.unwrap_or_default();
        self.next = sequence.wrapping_add(1);
        shared.work = work;
        bytes
    }
}

/// A row of `n` defaults.
fn zeros(n: usize) -> PropertyRow {
    vec![0; n].into()
}

/// The property changes one snapshot sends: the match's and the
/// entities', with the bits they take.
#[derive(Debug, Default)]
struct PropertyPlan {
    /// The match's change (0: none).
    match_mask: u64,
    /// Entities' changes: id, mask, row now.
    entities: Vec<(EntityId, u64, Option<PropertyRow>)>,
    /// The last entity already in view whose change was planned, in the
    /// order they were taken (the next snapshot starts after it).
    held_last: Option<EntityId>,
    /// Bits planned so far (counting each id gap at its widest).
    bits: usize,
    /// Values planned.
    values: usize,
    /// Entities in view whose change did not fit.
    deferred: usize,
}

impl PropertyPlan {
    /// Plans the match's change and those of entities in the baseline's
    /// view that stay in it (in the frame, not removed), starting after
    /// `cursor` and wrapping, within `budget` bits.
    fn plan_held(
        &mut self,
        section: &SectionWriter<'_>,
        frame: &QuantizedFrame,
        base: &View,
        removed: &[EntityId],
        cursor: EntityId,
        budget: usize,
    ) {
        let now = frame.properties();
        let before = base.properties();
        let (mask, bits) = section.match_change(
            now.and_then(|p| p.match_state.as_ref()),
            before.match_state(),
        );
        if mask != 0 {
            self.match_mask = mask;
            self.bits += bits;
            self.values += mask.count_ones() as usize;
        }
        // Ids with a row on either side, ascending, once.
        let empty = Vec::new();
        let a = now.map_or(&empty, |p| &p.entities);
        let b = &before.entities;
        let mut changed: Vec<(EntityId, u64, usize, Option<PropertyRow>)> = Vec::new();
        let (mut i, mut j) = (0, 0);
        while i < a.len() || j < b.len() {
            let id = match (a.get(i), b.get(j)) {
                (Some(x), Some(y)) => x.0.min(y.0),
                (Some(x), None) => x.0,
                (None, Some(y)) => y.0,
                (None, None) => break,
            };
            let row_now = a.get(i).filter(|x| x.0 == id).map(|x| &x.1);
            let row_before = b.get(j).filter(|y| y.0 == id).map(|y| &y.1);
            i += usize::from(row_now.is_some());
            j += usize::from(row_before.is_some());
            let stays = base.get(id).is_some()
                && removed.binary_search(&id).is_err()
                && frame.ids().binary_search(&id).is_ok();
            if !stays {
                continue;
            }
            let (mask, bits) = section.entity_change(row_now, row_before);
            if mask != 0 {
                changed.push((
                    id,
                    mask,
                    bits + SectionWriter::id_bound_bits(id),
                    row_now.cloned(),
                ));
            }
        }
        // Those after the cursor first, then from the start.
        let split = changed.partition_point(|c| c.0 <= cursor);
        changed.rotate_left(split);
        for (id, mask, bits, row) in changed {
            if self.bits + bits > budget {
                self.deferred += 1;
                continue;
            }
            self.bits += bits;
            self.values += mask.count_ones() as usize;
            self.held_last = Some(id);
            self.entities.push((id, mask, row));
        }
    }
}

/// A set of frame indices, as bits, that finds the nearest member either
/// side of an index.
#[derive(Debug, Clone, Default)]
struct IndexSet {
    words: Vec<u64>,
}

impl IndexSet {
    /// Now holds none of `0..len`.
    fn reset(&mut self, len: usize) {
        self.words.clear();
        self.words.resize(len.div_ceil(64), 0);
    }

    fn insert(&mut self, i: usize) {
        self.words[i / 64] |= 1 << (i % 64);
    }

    /// The members, ascending.
    fn iter(&self) -> impl Iterator<Item = usize> + '_ {
        self.words.iter().enumerate().flat_map(|(w, &word)| {
            let mut bits = word;
            std::iter::from_fn(move || {
                (bits != 0).then(|| {
                    let b = bits.trailing_zeros() as usize;
                    bits &= bits - 1;
                    w * 64 + b
                })
            })
        })
    }

    /// The largest member below `i`.
    fn before(&self, i: usize) -> Option<usize> {
        let (w, b) = (i / 64, i % 64);
        let below = self.words[w] & ((1u64 << b) - 1);
        if below != 0 {
            return Some(w * 64 + 63 - below.leading_zeros() as usize);
        }
        (0..w)
            .rev()
            .find(|&k| self.words[k] != 0)
            .map(|k| k * 64 + 63 - self.words[k].leading_zeros() as usize)
    }

    /// The smallest member above `i`.
    fn after(&self, i: usize) -> Option<usize> {
        let (w, b) = (i / 64, i % 64);
        let above = if b == 63 {
            0
        } else {
            self.words[w] & !((1u64 << (b + 1)) - 1)
        };
        if above != 0 {
            return Some(w * 64 + above.trailing_zeros() as usize);
        }
        (w + 1..self.words.len())
            .find(|&k| self.words[k] != 0)
            .map(|k| k * 64 + self.words[k].trailing_zeros() as usize)
    }
}

#[cfg(test)]
mod tests {
    use super::{sort_key, IndexSet};

    #[test]
    fn sort_keys_order_by_priority_down_then_position_up() {
        let priorities = [3.5, -1.0, 0.0, 1e300, -0.0, 3.5, f64::MIN_POSITIVE, -7.25];
        let mut by_key: Vec<usize> = (0..priorities.len()).collect();
        by_key.sort_by_key(|&k| sort_key(priorities[k], k));
        let mut by_total_cmp: Vec<usize> = (0..priorities.len()).collect();
        by_total_cmp.sort_by(|&a, &b| priorities[b].total_cmp(&priorities[a]).then(a.cmp(&b)));
        assert_eq!(by_key, by_total_cmp);
    }

    #[test]
    fn index_sets_find_the_nearest_members_either_side() {
        let mut set = IndexSet::default();
        set.reset(300);
        assert_eq!((set.before(150), set.after(150)), (None, None));
        for i in [0, 63, 64, 130, 299] {
            set.insert(i);
        }
        assert_eq!((set.before(0), set.after(0)), (None, Some(63)));
        assert_eq!((set.before(63), set.after(63)), (Some(0), Some(64)));
        assert_eq!((set.before(100), set.after(100)), (Some(64), Some(130)));
        assert_eq!((set.before(299), set.after(299)), (Some(130), None));
        assert_eq!((set.before(200), set.after(131)), (Some(130), Some(299)));
        assert_eq!(set.iter().collect::<Vec<_>>(), [0, 63, 64, 130, 299]);
    }
}
