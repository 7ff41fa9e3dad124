//! [`SimState`]: everything a simulation needs to carry on from a tick —
//! the world's saved state, the entity table, where avatars spawn, the
//! clients in the game and the game rules' own state. Keyframes in a
//! recording and `save`/`load` checkpoints are this, encoded.
//!
//! # Encoding
//!
//! Little-endian:
//!
//! ```text
//! 0..4    magic "ISIM"
//! 4..6    u16 format version, 2 (1 is read too: it ends after the
//!         rules' state, with no pose window)
//! 6..14   u64 tick
//! 14..18  u32 applied: entries of the journal of `tick` already in this
//!         state (0 for a keyframe taken right after the tick's step)
//! then    u32 n, n bytes: the world (inertia-physics save format)
//!         u32 n, n bytes: the entity table (postcard)
//!         u32 count, count × (f64 x, f64 y, f64 z): spawn points, m
//!         u32 count, count × u64: clients in the game
//!         u32 n, n bytes: the rules' state (theirs to define)
//!         u32 n, n bytes: the pose window for lag compensation
//!         ([`PoseHistory::to_bytes`]); n = 0: none       (version 2)
//! ```
//!
//! The pose window is saved, not rebuilt: re-simulating from this state
//! must answer a rewound shot exactly as the live run did, and the ticks
//! before this one are not in the state to rebuild it from.
//!
//! Decoding bounds every length by what is left and refuses trailing
//! bytes; the world and table are checked as they are restored. Keyframes
//! on disk and checkpoint files are these bytes packed with zstd
//! ([`crate::record::compress`]); decoding unpacks them first.

use inertia_physics::glam::DVec3;

use crate::pose_history::PoseHistory;
use crate::record::compress::unpack;
use crate::rules::ClientId;
use crate::scene::entities::{EntityTable, TableError};

/// The magic bytes a saved simulation state starts with.
pub const STATE_MAGIC: [u8; 4] = *b"ISIM";
/// The format version [`SimState::encode`] writes.
pub const STATE_VERSION: u16 = 2;
/// The oldest format version [`SimState::decode`] reads.
pub const OLDEST_STATE_VERSION: u16 = 1;

/// A simulation's whole state at a tick.
#[derive(Debug, Clone)]
pub struct SimState {
    /// The tick it belongs to.
    pub tick: u64,
    /// Journal entries of `tick` already applied to it.
    pub applied: u32,
    /// The world's saved bytes ([`inertia_physics::World::save`]).
    pub world: Vec<u8>,
    /// The entity table.
    pub entities: EntityTable,
    /// Where avatars appear, m.
    pub spawn_points: Vec<DVec3>,
    /// Clients in the game.
    pub clients: Vec<ClientId>,
    /// The rules' state ([`crate::rules::GameRules::save_state`]).
    pub rules: Vec<u8>,
    /// The moving bodies' poses over the ticks before, for lag
    /// compensation; `None` for a fresh scene or a state of format
    /// version 1 (a window then starts at `tick`).
    pub poses: Option<PoseHistory>,
}

/// Why a saved state was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum StateError {
    /// Not a saved simulation state.
    #[error("not a saved simulation state (bad magic)")]
    BadMagic,
    /// Written by a format this build cannot read.
    #[error(
        "saved state format version {0} is not supported (this build reads \
         {OLDEST_STATE_VERSION} to {STATE_VERSION})"
    )]
    Version(u16),
    /// The bytes end early or carry too much.
    #[error("saved state is malformed: {0}")]
    Malformed(String),
    /// The world part does not restore.
    #[error("saved world does not restore: {0}")]
    World(String),
    /// The entity table does not decode.
    #[error(transparent)]
    Entities(#[from] TableError),
    /// The rules refused their part.
    #[error("the game rules refused their saved state: {0}")]
    Rules(String),
}

impl SimState {
    /// The state as bytes (see the module docs).
    pub fn encode(&self) -> Vec<u8> {
        let table = self.entities.to_bytes();
        let poses = self
            .poses
            .as_ref()
            .map(PoseHistory::to_bytes)
            .unwrap_or_default();
        // Exactly what is written: the header (18), three length-prefixed
        // byte strings and two counted arrays. Keyframes are held as they
        // are, so no spare capacity.
        let len = 18
            + (4 + self.world.len())
            + (4 + table.len())
            + (4 + self.spawn_points.len() * 24)
            + (4 + self.clients.len() * 8)
            + (4 + self.rules.len())
            + (4 + poses.len());
        let mut out = Vec::with_capacity(len);
        out.extend_from_slice(&STATE_MAGIC);
        out.extend_from_slice(&STATE_VERSION.to_le_bytes());
        out.extend_from_slice(&self.tick.to_le_bytes());
        out.extend_from_slice(&self.applied.to_le_bytes());
        put_bytes(&mut out, &self.world);
        put_bytes(&mut out, &table);
        out.extend_from_slice(&(self.spawn_points.len() as u32).to_le_bytes());
        for p in &self.spawn_points {
            for v in p.to_array() {
                out.extend_from_slice(&v.to_bits().to_le_bytes());
            }
        }
        out.extend_from_slice(&(self.clients.len() as u32).to_le_bytes());
        for c in &self.clients {
            out.extend_from_slice(&c.to_le_bytes());
        }
        put_bytes(&mut out, &self.rules);
        put_bytes(&mut out, &poses);
        debug_assert_eq!(out.len(), len);
        out
    }

    /// Reads the tick and applied count without decoding the rest
    /// (packed states are unpacked first).
    pub fn peek(bytes: &[u8]) -> Result<(u64, u32), StateError> {
        let bytes = unpack(bytes).map_err(|e| StateError::Malformed(e.to_string()))?;
        let mut r = Reader {
            bytes: &bytes,
            at: 0,
        };
        r.header()?;
        Ok((r.u64()?, r.u32()?))
    }

    /// A state from [`SimState::encode`]'s bytes, packed
    /// ([`crate::record::compress`]) or not.
    pub fn decode(bytes: &[u8]) -> Result<SimState, StateError> {
        let unpacked = unpack(bytes).map_err(|e| StateError::Malformed(e.to_string()))?;
        Self::decode_raw(&unpacked)
    }

    fn decode_raw(bytes: &[u8]) -> Result<SimState, StateError> {
        let mut r = Reader { bytes, at: 0 };
        let version = r.header()?;
        let tick = r.u64()?;
        if tick > inertia_physics::limits::MAX_TICK {
            return Err(StateError::Malformed(format!(
                "tick {tick} is past the last a world reaches ({})",
                inertia_physics::limits::MAX_TICK
            )));
        }
        let applied = r.u32()?;
        let world = r.bytes()?.to_vec();
        let entities = EntityTable::from_bytes(r.bytes()?)?;
        let n = r.count(24)?;
        let mut spawn_points = Vec::with_capacity(n);
        for _ in 0..n {
            let p = DVec3::new(r.f64()?, r.f64()?, r.f64()?);
            if !p.is_finite() {
                return Err(StateError::Malformed("a spawn point is not finite".into()));
            }
            spawn_points.push(p);
        }
        let n = r.count(8)?;
        let mut clients = Vec::with_capacity(n);
        for _ in 0..n {
            clients.push(r.u64()?);
        }
        let rules = r.bytes()?.to_vec();
        let poses = match version {
            1 => None,
            _ => match r.bytes()? {
                [] => None,
                bytes => Some(PoseHistory::from_bytes(bytes).map_err(StateError::Malformed)?),
            },
        };
        if r.at != bytes.len() {
            return Err(StateError::Malformed(format!(
                "{} trailing bytes",
                bytes.len() - r.at
            )));
        }
        Ok(SimState {
            tick,
            applied,
            world,
            entities,
            spawn_points,
            clients,
            rules,
            poses,
        })
    }
}

fn put_bytes(out: &mut Vec<u8>, bytes: &[u8]) {
    out.extend_from_slice(&(bytes.len() as u32).to_le_bytes());
    out.extend_from_slice(bytes);
}

struct Reader<'a> {
    bytes: &'a [u8],
    at: usize,
}

impl<'a> Reader<'a> {
    fn take(&mut self, n: usize) -> Result<&'a [u8], StateError> {
        let end = self
            .at
            .checked_add(n)
            .filter(|&e| e <= self.bytes.len())
            .ok_or_else(|| StateError::Malformed(format!("ends early at byte {}", self.at)))?;
        let s = &self.bytes[self.at..end];
        self.at = end;
        Ok(s)
    }

    /// Checks the magic and returns the format version.
    fn header(&mut self) -> Result<u16, StateError> {
        if self.bytes.len() < 4 || self.take(4)? != STATE_MAGIC {
            return Err(StateError::BadMagic);
        }
        let version = u16::from_le_bytes(self.take(2)?.try_into().unwrap_or_default());
        if !(OLDEST_STATE_VERSION..=STATE_VERSION).contains(&version) {
            return Err(StateError::Version(version));
        }
        Ok(version)
    }

    fn u32(&mut self) -> Result<u32, StateError> {
        Ok(u32::from_le_bytes(
            self.take(4)?.try_into().unwrap_or_default(),
        ))
    }

    fn u64(&mut self) -> Result<u64, StateError> {
        Ok(u64::from_le_bytes(
            self.take(8)?.try_into().unwrap_or_default(),
        ))
    }

    fn f64(&mut self) -> Result<f64, StateError> {
        Ok(f64::from_bits(self.u64()?))
    }

    fn bytes(&mut self) -> Result<&'a [u8], StateError> {
        let n = self.u32()? as usize;
        self.take(n)
    }

    /// A count of items of `size` bytes each, bounded by what is left.
    fn count(&mut self, size: usize) -> Result<usize, StateError> {
        let n = self.u32()? as usize;
        if n.saturating_mul(size) > self.bytes.len() - self.at {
            return Err(StateError::Malformed(format!(
                "{n} items cannot fit in what is left"
            )));
        }
        Ok(n)
    }
}
