//! What can go wrong reading or writing a recording.

use std::path::PathBuf;

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
    /// Whether this damage is what an interrupted append leaves at the end
    /// of the newest segment: a frame cut short, a garbage length, or bytes
    /// that never reached the disk intact. Such a tail is cut on open; any
    /// other damage is reported and left alone.
    pub fn is_torn_write(self) -> bool {
        matches!(
            self,
            Self::Truncated | Self::Oversized(_) | Self::BadChecksum { .. }
        )
    }
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
