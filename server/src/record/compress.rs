//! Keyframe compression. A keyframe's state is most of a recording's
//! bytes, so the recorder thread compresses each one (zstd, level
//! [`LEVEL`]) before it is written; readers unpack it transparently
//! ([`unpack`] leaves anything else as it is).
//!
//! ```text
//! 0..4  magic "IZST"
//! 4..8  u32 length of the unpacked bytes (≤ MAX_RECORD_BYTES)
//! 8..   one zstd frame
//! ```

use std::borrow::Cow;

use super::MAX_RECORD_BYTES;

/// The magic bytes of a packed payload.
pub const PACKED_MAGIC: [u8; 4] = *b"IZST";
/// The zstd level a keyframe is packed at, up to [`DEEP_UP_TO`] bytes:
/// zstd's deepest. On the replay bench's 1000-body scene (0.92 MB a
/// keyframe) it packs 7 % smaller than level 3 (281 kB against 302 kB,
/// which keeps a recording under 100 MB an hour) for about 0.3 s of the
/// recorder thread every 15 s, off the tick thread.
pub const LEVEL: i32 = 19;

/// Larger keyframes are packed at [`FAST_LEVEL`], so that packing one
/// stays under about a second of the recorder thread (level 19 packs a
/// saved world at about 3 MB/s).
pub const DEEP_UP_TO: usize = 2 << 20;

/// The level of keyframes over [`DEEP_UP_TO`]: fast, and most of what
/// the deeper levels give.
pub const FAST_LEVEL: i32 = 3;

/// Why a packed payload does not unpack.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("packed payload: {0}")]
pub struct UnpackError(pub String);

/// Whether `bytes` are packed.
pub fn is_packed(bytes: &[u8]) -> bool {
    bytes.len() >= 8 && bytes[..4] == PACKED_MAGIC
}

/// `raw`, packed (or `raw` itself if packing would not make it smaller).
pub fn pack(raw: &[u8]) -> Vec<u8> {
    let level = if raw.len() <= DEEP_UP_TO {
        LEVEL
    } else {
        FAST_LEVEL
    };
    match zstd::bulk::compress(raw, level) {
        Ok(z) if z.len() + 8 < raw.len() => {
            let mut out = Vec::with_capacity(z.len() + 8);
            out.extend_from_slice(&PACKED_MAGIC);
            out.extend_from_slice(&(raw.len() as u32).to_le_bytes());
            out.extend_from_slice(&z);
            out
        }
        _ => raw.to_vec(),
    }
}

/// The unpacked bytes of `bytes` (borrowed when they were not packed).
/// The stated length is bounded by [`MAX_RECORD_BYTES`] and must match.
pub fn unpack(bytes: &[u8]) -> Result<Cow<'_, [u8]>, UnpackError> {
    if !is_packed(bytes) {
        return Ok(Cow::Borrowed(bytes));
    }
    let len = u32::from_le_bytes([bytes[4], bytes[5], bytes[6], bytes[7]]);
    if len > MAX_RECORD_BYTES {
        return Err(UnpackError(format!("{len} bytes unpacked is too large")));
    }
    let out = zstd::bulk::decompress(&bytes[8..], len as usize)
        .map_err(|e| UnpackError(e.to_string()))?;
    if out.len() != len as usize {
        return Err(UnpackError(format!(
            "{} bytes unpacked, {len} stated",
            out.len()
        )));
    }
    Ok(Cow::Owned(out))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn packs_and_unpacks() {
        let raw: Vec<u8> = (0..100_000u32).map(|i| (i % 251) as u8).collect();
        let packed = pack(&raw);
        assert!(packed.len() < raw.len() / 10);
        assert_eq!(unpack(&packed).unwrap().as_ref(), raw.as_slice());
        let small = b"ISIM tiny";
        assert_eq!(pack(small), small.to_vec());
        assert_eq!(unpack(small).unwrap().as_ref(), small);
    }

    #[test]
    fn damage_is_refused_without_panic() {
        let raw = vec![7u8; 50_000];
        let packed = pack(&raw);
        for cut in 8..packed.len() {
            let _ = unpack(&packed[..cut]);
        }
        let mut lie = packed.clone();
        lie[4..8].copy_from_slice(&(MAX_RECORD_BYTES + 1).to_le_bytes());
        assert!(unpack(&lie).is_err());
        let mut short = packed;
        short[4..8].copy_from_slice(&10u32.to_le_bytes());
        assert!(unpack(&short).is_err());
    }
}
