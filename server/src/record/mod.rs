//! Recording: the append-only, checksummed store of everything needed to
//! replay a session — keyframes (the world's full saved state) every K
//! ticks, the inputs applied at each tick, admin edits and each tick's state
//! hash. Seeking to tick T restores the keyframe at or before T and
//! re-simulates the recorded inputs (see DESIGN.md, "The tick and the two
//! clocks"). This module stores and finds bytes; it knows nothing of the
//! world, the network or the clock.
//!
//! # On disk
//!
//! A recording is a directory of **segment files**, each named after the
//! tick of its first record: `segment-<tick as 20 decimal digits>.irec`
//! (`segment-00000000000000003600.irec`), so names sort by tick. Other files
//! in the directory are ignored. Segments are only ever appended to. A new
//! segment starts at a keyframe once the current one has reached
//! [`RecordOptions::segment_bytes`], so every segment but a directory's
//! first begins with a keyframe (or, where a writer started a new segment
//! after a damaged one, a session start and its keyframe): a replay can
//! start at any segment, and retention can delete the oldest whole.
//!
//! All integers are little-endian. A segment is an 8-byte header followed
//! by frames, back to back:
//!
//! ```text
//! header   0..4   magic  "IREC" (0x49 0x52 0x45 0x43)
//!          4..8   u32    format version, 1
//! frame    +0     u8     kind (1 SessionStart, 2 Keyframe, 3 Inputs
//!                        without views (read only), 4 TickHash,
//!                        5 AdminEdit, 6 Journal, 7 Inputs)
//!          +1     u32    payload length n, bytes (≤ MAX_RECORD_BYTES)
//!          +5     n      payload
//!          +5+n   u32    CRC-32/IEEE of bytes +0 .. +5+n (kind, length
//!                        and payload)
//! ```
//!
//! Payloads, by kind (every one starts with the record's tick):
//!
//! ```text
//! SessionStart  u64 tick, u32 tick_hz (Hz), u32 scene length s,
//!               s bytes scene name (UTF-8)
//! Keyframe      u64 tick, the rest: the saved state (the server's: a
//!               SimState packed with zstd, see [`compress`])
//! Inputs (7)    u64 tick, u32 count c, then c entries of 37 bytes:
//!               u64 client id, u32 input sequence, u64 input's tick,
//!               f32 movement x, f32 movement z, f32 yaw (rad),
//!               u8 buttons, f32 view behind (ticks)  (floats as their
//!               IEEE-754 bit patterns)
//! Inputs (3)    as kind 7 without the view: entries of 33 bytes, written
//!               before inputs carried a view; read as a view of 0
//! TickHash      u64 tick, u64 state hash
//! AdminEdit     u64 tick, u32 name length w, w bytes who (UTF-8),
//!               the rest: the edit (opaque, for people: the audit trail)
//! Journal       u64 tick, the rest: what changed the simulation while
//!               the world stood at that tick (opaque here; see
//!               crate::replay::journal)
//! ```
//!
//! The server writes `Journal` records (inputs along with joins, leaves
//! and edits, in the order applied); `Inputs` is inputs alone, for tools
//! that record nothing else. A keyframe's state is a
//! [`crate::replay::SimState`] when the server wrote it.
//!
//! A payload must be consumed exactly; trailing bytes are corruption.
//! Within a recording ticks never decrease; several records may share one.
//!
//! # Crashes and damage
//!
//! Appends are buffered; [`RecordWriter::flush`] makes them durable (see
//! [`writer`]'s docs). A segment is synced before the next is started, so a
//! crash can leave only the newest segment ending in a **torn tail**: its
//! last frame cut short by the end of the file — the header, or the
//! payload its length announces, runs past it — with nothing intact after
//! it. That, and only that, is cut: [`RecordWriter::open`] first writes the
//! bytes to `<segment file name>.torn-<offset>` beside the segment and
//! syncs them, then cuts the segment at the end of the last intact record,
//! reporting it in an [`OpenReport`] ([`TailCut`]).
//!
//! Everything else is **damage**, wherever it is: a checksum that fails, an
//! impossible header (a length over the limit, a kind no record has), a
//! checksummed frame of unknown kind or payload, a frame whose length runs
//! past the end while intact frames follow it. Damage is never cut or
//! skipped silently. Readers stop there with [`RecordError::Corrupt`],
//! naming the file and byte offset; [`RecordReader::salvage`] reports it
//! and goes on with the next segment (never with the rest of the damaged
//! one: nothing says where its next frame begins); a writer that finds its
//! newest segment damaged leaves it exactly as it is and appends in a new
//! segment. The reader's lengths are all bounded ([`MAX_RECORD_BYTES`],
//! and the file's length), so hostile bytes cost at most one record's
//! allocation and never a panic.
//!
//! # Example
//!
//! ```
//! use inertia_server::record::{Record, RecordOptions, RecordReader, RecordWriter};
//!
//! # fn main() -> Result<(), inertia_server::record::RecordError> {
//! let dir = std::env::temp_dir().join(format!("inertia-record-doc-{}", std::process::id()));
//! let mut writer = RecordWriter::open(&dir, RecordOptions::default())?;
//! writer.append(&Record::Keyframe { tick: 0, state: vec![1, 2, 3] })?;
//! writer.append(&Record::TickHash { tick: 1, hash: 0xFEED })?;
//! writer.flush()?; // durable from here on
//!
//! let reader = RecordReader::open(&dir)?;
//! assert_eq!(reader.keyframe_at_or_before(1)?, Some((0, vec![1, 2, 3])));
//! assert_eq!(reader.hash_at(1)?, Some(0xFEED));
//! # drop(writer);
//! # std::fs::remove_dir_all(&dir).ok();
//! # Ok(())
//! # }
//! ```

mod codec;
pub mod compress;
pub mod crc32;
mod error;
mod frame;
pub mod matches;
mod reader;
pub mod recorder;
mod segment;
pub mod writer;

pub use codec::{LegacyInput, Record, RecordKind};
pub use error::{Corruption, RecordError, SegmentDamage};
pub use reader::{RecordReader, Records, Salvage, Salvaged, TickInputs};
pub use recorder::{Recorder, RecorderConfig, RecorderStats};
pub use segment::{
    parse_segment_file_name, scan_segment_bytes, segment_file_name, Scan, SegmentFile, SegmentInfo,
};
pub use writer::{
    OpenReport, RecordOptions, RecordWriter, TailCut, DEFAULT_SEGMENT_BYTES, WRITE_BUFFER_BYTES,
};

/// Largest payload a frame may carry, bytes (64 MiB). Bounds what a reader
/// allocates for one record; a keyframe of a world larger than this cannot
/// be recorded.
pub const MAX_RECORD_BYTES: u32 = 64 * 1024 * 1024;
