//! The one error a read can end in.

/// Why a read failed. Positions are byte offsets from the start of the
/// reader's bytes.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum CodecError {
    /// The bytes ended inside a field.
    #[error("ends early at byte {at} ({remaining} of {needed} bytes there)")]
    Truncated {
        /// Where the field starts.
        at: usize,
        /// Bytes the field needs (for a varint, the bytes it read before
        /// they ran out, plus one).
        needed: usize,
        /// Bytes there were from `at` to the end, fewer than `needed`
        /// (so `at + remaining` is where the bytes end).
        remaining: usize,
    },
    /// A varint whose tenth byte holds value bits past the 64th.
    #[error("a varint at byte {at} overflows 64 bits")]
    VarintOverflow {
        /// Where the varint starts.
        at: usize,
    },
    /// A varint whose tenth byte says that more follow.
    #[error("a varint at byte {at} runs past 10 bytes")]
    VarintTooLong {
        /// Where the varint starts.
        at: usize,
    },
}
