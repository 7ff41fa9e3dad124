//! The snapshot datagram (server → client): a quantized view of the world,
//! delta-coded against a view the client acknowledged, bit-packed and
//! fitted into a byte budget by priority.
//!
//! # Design
//!
//! After Glenn Fiedler's "Snapshot Compression" (gafferongames.com, 2015)
//! and "State Synchronization" (2015), with one change of emphasis: where
//! his demo sends a changed-bit for every cube, we list only the entities
//! whose quantized state differs from the baseline, by id deltas, which is
//! cheaper when most of the world is at rest and does not grow with the
//! size of the world.
//!
//! - **Views.** The server quantizes each entity ([`QuantizedEntity`]:
//!   grid indices, smallest-three rotation, at-rest bit, optionally a
//!   quantized velocity). A *view* is a set of those, by id. Each snapshot
//!   describes a view `W_S`, and both ends keep a ring of the last
//!   [`RING`] views by sequence number.
//! - **Baselines.** A snapshot is coded against the newest view the client
//!   acknowledged (`W_B`), or against nothing. Entities whose quantized
//!   state equals the baseline's are simply not in the datagram. Included
//!   entities carry their position as a small delta from the baseline in
//!   one of a few size classes (absolute grid indices when none fits), the
//!   rotation only when it changed (again a small delta of the three small
//!   components when the largest component is the same one), and the
//!   velocity the same way.
//! - **Budget.** The encoder fills the datagram in the order of the
//!   [`crate::priority::PriorityAccumulator`] (Fiedler's priority
//!   accumulator) until the byte budget is spent. `W_S` is `W_B` with
//!   exactly the included entities updated and the listed removals gone,
//!   so what was left out stays as the baseline had it on both ends: the
//!   client never holds a state the server does not know it holds. An
//!   entity new since the baseline that does not fit is simply not in
//!   `W_S` yet.
//! - **Removals.** Entities of the baseline that left the client's view
//!   (despawned, or out of interest) are listed by id so the client can
//!   hide them.
//! - **Untrusted bytes.** The decoder bounds every count by
//!   [`MAX_ENTITIES`] and by the bits left, rejects indices outside the
//!   grid, ids out of order, time scales not finite or beyond
//!   ±[`MAX_TIME_SCALE`] and trailing bytes, and never panics.
//!
//! # Layout (bits, least significant first)
//!
//! ```text
//! tag 8 (0x53) | sequence 16 | has_baseline 1 [baseline 16]
//! tick: relative 1 (varuint delta from the baseline's tick) | 64
//! time_scale: is_one 1 [f32 32] | paused 1
//! removed: count varuint, then id deltas (varuint)
//! entities: count varuint, then for each:
//!   id delta varuint | at_rest 1 | position | [rotation_changed 1] rotation
//!   | [velocity, when configured and not at rest]
//! ```
//!
//! The time scale is the server clock's: 1 is real time, 0 stopped, and a
//! negative scale means recorded history is playing backwards (−1 is real
//! time in reverse): the ticks of successive snapshots then *decrease* by
//! about `|time_scale| × tick rate` per second while sequence numbers keep
//! increasing. It is finite and at most [`MAX_TIME_SCALE`] either way; the
//! decoder refuses anything else and the encoder clamps to that range.
//!
//! Ids ascend; each is coded as the gap from the previous one minus one.
//! A position (or velocity) against a baseline is coded axis by axis: a
//! truncated-unary size class, then a signed delta of that class's width
//! (the first class is "unchanged", no bits; the last is the absolute
//! index). Without a baseline it is absolute indices. A changed rotation
//! is a class and three deltas of the small components when the same
//! component was dropped, else the dropped index and three levels.

mod code;
mod decoder;
mod encoder;
mod frame;
mod property_section;
mod sent;
mod shared;
mod view;

pub use decoder::{DecodeStats, DecodedSnapshot, SnapshotDecoder};
pub use encoder::{EncodeReport, SharedDeltas, SnapshotEncoder};
pub use frame::QuantizedFrame;
pub use sent::HELD_VIEWS;
pub use view::{QuantizedEntity, QuantizedRotation, View, ViewEntity};

use thiserror::Error;

use crate::bits::BitError;
use crate::quantize::PositionGrid;

/// First byte of every snapshot datagram ('S'; client input datagrams use
/// 0x49, 'I').
pub const SNAPSHOT_TAG: u8 = 0x53;

/// Views kept by each end, by sequence number: a baseline older than this
/// many snapshots is gone and the next snapshot is coded without one.
pub const RING: usize = 64;

pub use crate::entity::MAX_ENTITIES;

/// The largest time scale a snapshot header may carry, either way, and so
/// the largest an operator may ask for (the admin protocol's limit is
/// this one). Negative scales down to its negation mean history playing
/// backwards.
pub const MAX_TIME_SCALE: f32 = 64.0;

/// How snapshots are quantized and sized. Both ends must use the same.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SnapshotConfig {
    /// Position grid (resolution and bound in m); at most 32 bits an axis.
    pub grid: PositionGrid,
    /// Bits per smallest-three component, 4 to 16 (9 gives about 0.3°
    /// typical, under 0.5° worst error).
    pub rotation_bits: u32,
    /// Whether moving (not at rest) entities carry a quantized linear
    /// velocity for the client's interpolation and extrapolation.
    pub velocities: bool,
    /// Velocity grid (resolution and bound in m/s), used when
    /// `velocities` is on; at most 32 bits an axis.
    pub velocity_grid: PositionGrid,
    /// Largest datagram, bytes (the path's datagram size; 64 to 65 507).
    pub max_datagram: usize,
}

impl Default for SnapshotConfig {
    /// 1 mm grid within ±512 m (20 bits an axis), 11-bit rotation
    /// components (about 0.1° error), no velocities, 1200-byte datagrams
    /// (fits the smallest QUIC path MTU with room for its headers).
    fn default() -> Self {
        Self {
            grid: PositionGrid {
                resolution: 0.001,
                bound: 512.0,
            },
            rotation_bits: 11,
            velocities: false,
            velocity_grid: PositionGrid {
                resolution: 0.01,
                bound: 100.0,
            },
            max_datagram: 1200,
        }
    }
}

impl SnapshotConfig {
    /// Checks every setting.
    pub fn validate(&self) -> Result<(), SnapshotConfigError> {
        for (what, g) in [("grid", self.grid), ("velocity_grid", self.velocity_grid)] {
            let ok = g.resolution.is_finite()
                && g.resolution > 0.0
                && g.bound.is_finite()
                && g.bound > 0.0
                && g.bits() <= 32;
            if !ok {
                return Err(SnapshotConfigError {
                    what,
                    why: format!(
                        "resolution and bound must be finite and > 0 with at most 32 bits an axis, got {g:?}"
                    ),
                });
            }
        }
        if !(4..=16).contains(&self.rotation_bits) {
            return Err(SnapshotConfigError {
                what: "rotation_bits",
                why: format!("must be 4 to 16, got {}", self.rotation_bits),
            });
        }
        if !(64..=65_507).contains(&self.max_datagram) {
            return Err(SnapshotConfigError {
                what: "max_datagram",
                why: format!("must be 64 to 65 507 bytes, got {}", self.max_datagram),
            });
        }
        Ok(())
    }
}

/// A [`SnapshotConfig`] setting out of range.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("snapshot config {what}: {why}")]
pub struct SnapshotConfigError {
    /// Which setting.
    pub what: &'static str,
    /// Why it was refused.
    pub why: String,
}

/// Why a snapshot datagram was not decoded. Every case drops the datagram
/// and leaves the decoder as it was; none is fatal to the connection.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
pub enum SnapshotError {
    /// The bytes ended early or held a count above its bound.
    #[error("snapshot bits: {0}")]
    Bits(#[from] BitError),
    /// Not a snapshot datagram.
    #[error("not a snapshot: tag {tag:#04x}")]
    WrongKind {
        /// The first byte.
        tag: u8,
    },
    /// Longer than the configured datagram size.
    #[error("snapshot of {len} bytes is above the datagram size {max}")]
    TooLong {
        /// Bytes received.
        len: usize,
        /// The configured `max_datagram`.
        max: usize,
    },
    /// Coded against a view this decoder does not have (never received, or
    /// fallen out of the ring). The server will code against an older
    /// acknowledged view or none; nothing to do but keep acknowledging.
    #[error("snapshot {sequence}: baseline {baseline} is not held")]
    MissingBaseline {
        /// The snapshot.
        sequence: u16,
        /// The view it was coded against.
        baseline: u16,
    },
    /// Already received.
    #[error("snapshot {sequence} already received")]
    Duplicate {
        /// The snapshot.
        sequence: u16,
    },
    /// More than [`RING`] snapshots older than the newest received.
    #[error("snapshot {sequence} is stale (newest {newest})")]
    Stale {
        /// The snapshot.
        sequence: u16,
        /// The newest received.
        newest: u16,
    },
    /// Well-formed bits with meaning no encoder produces.
    #[error("malformed snapshot: {0}")]
    Malformed(&'static str),
}

/// Whether sequence `a` is newer than `b`, modulo 2^16 (the half of the
/// circle ahead of `b` counts as newer).
pub fn sequence_newer(a: u16, b: u16) -> bool {
    a != b && a.wrapping_sub(b) < 0x8000
}
