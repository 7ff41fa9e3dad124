//! What can go wrong reading or writing a recording.

use std::path::PathBuf;

use inertia_codec::CodecError;

/// Why a stretch of a segment file is not a valid record. Carried by
/// [`RecordError::Corrupt`] with the file and byte offset.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum Corruption {
    /// The file does not start with the segment magic `IREC`.
    #[error("not a segment file (bad magic)")]
    BadMagic,
    /// The segment header names a format version this build cannot read.
    #[error("segment format version {0} is not supported")]
    UnsupportedVersion(u32),
    /// A header or frame runs past the end of the file.
    #[error("record runs past the end of the file")]
    Truncated,
    /// A frame declares a payload longer than
    /// [`MAX_RECORD_BYTES`](super::MAX_RECORD_BYTES).
    #[error("record declares {0} payload bytes, over the limit")]
    Oversized(u32),
    /// The stored CRC-32 does not match the frame's bytes.
    #[error("checksum mismatch (stored {stored:#010x}, computed {computed:#010x})")]
    BadChecksum {
        /// The CRC-32 found in the file.
        stored: u32,
        /// The CRC-32 of the kind, length and payload bytes as read.
        computed: u32,
    },
    /// The checksum holds but the kind byte names no record kind (a newer
    /// format, or a bug).
    #[error("unknown record kind {0}")]
    UnknownKind(u8),
    /// The checksum holds but the payload does not decode as its kind.
    #[error("malformed payload: {0}")]
    BadPayload(&'static str),
}

impl Corruption {
    /// Whether this damage can be a torn write: a header or frame that
    /// runs past the end of the file. Whether it is one depends on where
    /// it is (the end of the newest segment, nothing intact after it);
    /// [`RecordWriter::open`](super::RecordWriter::open) decides. Every
    /// other kind is damage to report, never to cut.
    pub fn is_torn_write(self) -> bool {
        self == Self::Truncated
    }
}

/// A payload field that the codec could not read runs past the payload
/// (payloads hold no varints, so that is the one codec error they meet).
impl From<CodecError> for Corruption {
    fn from(_: CodecError) -> Self {
        Self::BadPayload("field runs past the payload")
    }
}

/// Damage found in a segment file: where it is and what is wrong there.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{}: damaged at byte {offset}: {why}", path.display())]
pub struct SegmentDamage {
    /// The segment file.
    pub path: PathBuf,
    /// Byte offset of the damaged header or frame in the file.
    pub offset: u64,
    /// What is wrong there.
    pub why: Corruption,
}

/// Errors of [`RecordWriter`](super::RecordWriter) and
/// [`RecordReader`](super::RecordReader).
#[derive(Debug, thiserror::Error)]
pub enum RecordError {
    /// The file system refused an operation on `path`.
    #[error("{}: {source}", path.display())]
    Io {
        /// The file or directory involved.
        path: PathBuf,
        /// What the operating system said.
        #[source]
        source: std::io::Error,
    },
    /// Bytes on disk are not a valid record. Nothing after `offset` in that
    /// segment was read; earlier records were delivered.
    #[error("{}: corrupt at byte {offset}: {why}", path.display())]
    Corrupt {
        /// The segment file.
        path: PathBuf,
        /// Byte offset of the bad header or frame in the file.
        offset: u64,
        /// What is wrong there.
        why: Corruption,
    },
    /// A record to append encodes to more than
    /// [`MAX_RECORD_BYTES`](super::MAX_RECORD_BYTES) payload bytes; nothing
    /// was written.
    #[error("record payload of {len} bytes is over the limit of {max} bytes")]
    TooLarge {
        /// The payload size the record needs, bytes.
        len: u64,
        /// The limit, bytes.
        max: u64,
    },
    /// A record to append is for a tick before the last one recorded; ticks
    /// never go back within a recording (seeking back is a reader's job).
    /// Nothing was written.
    #[error("tick {got} is before the last recorded tick {last}")]
    TickBackwards {
        /// The newest tick already recorded.
        last: u64,
        /// The record's tick.
        got: u64,
    },
    /// The newest segment is damaged, so appending goes on in a new
    /// segment; one for `tick` would take the damaged segment's own name
    /// (it starts at that tick). Nothing was written.
    #[error(
        "the newest segment {} is damaged and starts at tick {tick}: a new segment cannot start at that tick",
        path.display()
    )]
    DamagedSegmentInTheWay {
        /// The damaged segment.
        path: PathBuf,
        /// The tick refused.
        tick: u64,
    },
    /// An earlier write or sync failed, so the newest segment may end in a
    /// partial frame. The writer refuses further work; open the directory
    /// again to cut the tail and continue.
    #[error("an earlier write failed; reopen the recording to repair its tail")]
    Poisoned,
}

impl RecordError {
    pub(crate) fn io(path: impl Into<PathBuf>, source: std::io::Error) -> Self {
        Self::Io {
            path: path.into(),
            source,
        }
    }
}
