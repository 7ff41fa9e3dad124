//! [`SimState`]: everything a simulation needs to carry on from a tick —
//! the world's saved state, the entity table, where avatars spawn, the
//! clients in the game and the game rules' own state. Keyframes in a
//! recording and `save`/`load` checkpoints are this, encoded.
//!
//! # Encoding
//!
//! Little-endian ([`inertia_codec`]):
//!
//! ```text
//! 0..4    magic "ISIM"
//! 4..6    u16 format version, 3 (1 and 2 are read too: 1 ends after
//!         the rules' state, with no pose window; 2 after the pose
//!         window, with no properties)
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
//!         u32 n, n bytes: the game's properties
//!         ([`PropertyStore::to_bytes`]); n = 0: all defaults (version 3)
//! ```
//!
//! [`PropertyStore::to_bytes`]: crate::properties::PropertyStore::to_bytes
//!
//! The pose window is saved, not rebuilt: re-simulating from this state
//! must answer a rewound shot exactly as the live run did, and the ticks
//! before this one are not in the state to rebuild it from.
//!
//! Decoding bounds every length by what is left and refuses trailing
//! bytes; the world and table are checked as they are restored. Keyframes
//! on disk and checkpoint files are these bytes packed with zstd
//! ([`crate::record::compress`]); decoding unpacks them first.

use inertia_codec::{ByteReader, ByteWriter, CodecError};
use inertia_physics::glam::DVec3;

use crate::pose_history::PoseHistory;
use crate::record::compress::unpack;
use crate::rules::ClientId;
use crate::scene::entities::{EntityTable, TableError};

/// The magic bytes a saved simulation state starts with.
pub const STATE_MAGIC: [u8; 4] = *b"ISIM";
/// The format version [`SimState::encode`] writes.
pub const STATE_VERSION: u16 = 3;
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
    /// The game's properties, saved
    /// ([`crate::properties::PropertyStore::to_bytes`]); empty: all
    /// defaults (and every state of format version 1 or 2).
    pub properties: Vec<u8>,
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
    /// The properties saved are not those of these rules.
    #[error("{0}")]
    Properties(String),
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
            + (4 + poses.len())
            + (4 + self.properties.len());
        let mut out = Vec::with_capacity(len);
        let mut w = ByteWriter::new(&mut out);
        w.bytes(&STATE_MAGIC);
        w.u16(STATE_VERSION);
        w.u64(self.tick);
        w.u32(self.applied);
        put_bytes(&mut w, &self.world);
        put_bytes(&mut w, &table);
        w.u32(self.spawn_points.len() as u32);
        for p in &self.spawn_points {
            for v in p.to_array() {
                w.f64(v);
            }
        }
        w.u32(self.clients.len() as u32);
        for &c in &self.clients {
            w.u64(c);
        }
        put_bytes(&mut w, &self.rules);
        put_bytes(&mut w, &poses);
        put_bytes(&mut w, &self.properties);
        debug_assert_eq!(out.len(), len);
        out
    }

    /// Reads the tick and applied count without decoding the rest
    /// (packed states are unpacked first).
    pub fn peek(bytes: &[u8]) -> Result<(u64, u32), StateError> {
        let bytes = unpack(bytes).map_err(|e| StateError::Malformed(e.to_string()))?;
        let mut r = ByteReader::new(&bytes);
        header(&mut r)?;
        Ok((r.u64()?, r.u32()?))
    }

    /// A state from [`SimState::encode`]'s bytes, packed
    /// ([`crate::record::compress`]) or not.
    pub fn decode(bytes: &[u8]) -> Result<SimState, StateError> {
        let unpacked = unpack(bytes).map_err(|e| StateError::Malformed(e.to_string()))?;
        Self::decode_raw(&unpacked)
    }

    fn decode_raw(bytes: &[u8]) -> Result<SimState, StateError> {
        let mut r = ByteReader::new(bytes);
        let version = header(&mut r)?;
        let tick = r.u64()?;
        if tick > inertia_physics::limits::MAX_TICK {
            return Err(StateError::Malformed(format!(
                "tick {tick} is past the last a world reaches ({})",
                inertia_physics::limits::MAX_TICK
            )));
        }
        let applied = r.u32()?;
        let world = sized_bytes(&mut r)?.to_vec();
        let entities = EntityTable::from_bytes(sized_bytes(&mut r)?)?;
        let n = count(&mut r, 24)?;
        let mut spawn_points = Vec::with_capacity(n);
        for _ in 0..n {
            let p = DVec3::new(r.f64()?, r.f64()?, r.f64()?);
            if !p.is_finite() {
                return Err(StateError::Malformed("a spawn point is not finite".into()));
            }
            spawn_points.push(p);
        }
        let n = count(&mut r, 8)?;
        let mut clients = Vec::with_capacity(n);
        for _ in 0..n {
            clients.push(r.u64()?);
        }
        let rules = sized_bytes(&mut r)?.to_vec();
        let poses = match version {
            1 => None,
            _ => match sized_bytes(&mut r)? {
                [] => None,
                bytes => Some(PoseHistory::from_bytes(bytes).map_err(StateError::Malformed)?),
            },
        };
        let properties = match version {
            1 | 2 => Vec::new(),
            _ => sized_bytes(&mut r)?.to_vec(),
        };
        if !r.is_empty() {
            return Err(StateError::Malformed(format!(
                "{} trailing bytes",
                r.remaining()
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
            properties,
        })
    }
}

/// A field runs past the end of the bytes (the state has no varints).
impl From<CodecError> for StateError {
    fn from(e: CodecError) -> Self {
        Self::Malformed(e.to_string())
    }
}

/// A u32 length, then that many bytes.
fn put_bytes(w: &mut ByteWriter<'_>, bytes: &[u8]) {
    w.u32(bytes.len() as u32);
    w.bytes(bytes);
}

/// Checks the magic and returns the format version.
fn header(r: &mut ByteReader<'_>) -> Result<u16, StateError> {
    if r.bytes(4).ok() != Some(&STATE_MAGIC[..]) {
        return Err(StateError::BadMagic);
    }
    let version = r.u16()?;
    if !(OLDEST_STATE_VERSION..=STATE_VERSION).contains(&version) {
        return Err(StateError::Version(version));
    }
    Ok(version)
}

/// What [`put_bytes`] wrote.
fn sized_bytes<'a>(r: &mut ByteReader<'a>) -> Result<&'a [u8], StateError> {
    let n = r.u32()? as usize;
    Ok(r.bytes(n)?)
}

/// A count of items of `size` bytes each, bounded by what is left.
fn count(r: &mut ByteReader<'_>, size: usize) -> Result<usize, StateError> {
    let n = r.u32()? as usize;
    if n.saturating_mul(size) > r.remaining() {
        return Err(StateError::Malformed(format!(
            "{n} items cannot fit in what is left"
        )));
    }
    Ok(n)
}
