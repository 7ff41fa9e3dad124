//! The 64-bit state hash: a fast, non-cryptographic digest over the exact bit
//! patterns of the whole world state. Two worlds with the same hash have, for
//! all practical purposes, the same bits; one flipped bit anywhere changes it.
//! It covers exactly what [`World::save`](crate::World::save) writes, because
//! both are produced by the same walk over the state.

use super::StateSink;

/// Hashes 64-bit words: multiply-rotate mixing per word, a strong avalanche
/// at the end (the finaliser of MurmurHash3).
#[derive(Debug, Clone)]
pub struct StateHasher {
    h: u64,
    words: u64,
}

impl Default for StateHasher {
    fn default() -> Self {
        Self {
            h: 0x9E37_79B9_7F4A_7C15,
            words: 0,
        }
    }
}

impl StateHasher {
    /// Mixes in one word.
    #[inline]
    pub fn write_u64(&mut self, w: u64) {
        self.h = (self.h ^ w)
            .wrapping_mul(0xFF51_AFD7_ED55_8CCD)
            .rotate_left(29)
            ^ (self.h >> 17);
        self.words += 1;
    }

    /// The digest.
    pub fn finish(&self) -> u64 {
        let mut k = self.h ^ self.words;
        k ^= k >> 33;
        k = k.wrapping_mul(0xFF51_AFD7_ED55_8CCD);
        k ^= k >> 33;
        k = k.wrapping_mul(0xC4CE_B9FE_1A85_EC53);
        k ^ (k >> 33)
    }
}

impl StateSink for StateHasher {
    fn u8(&mut self, v: u8) {
        self.write_u64(u64::from(v));
    }
    fn u32(&mut self, v: u32) {
        self.write_u64(u64::from(v));
    }
    fn u64(&mut self, v: u64) {
        self.write_u64(v);
    }
    fn f32(&mut self, v: f32) {
        self.write_u64(u64::from(v.to_bits()));
    }
    fn f64(&mut self, v: f64) {
        self.write_u64(v.to_bits());
    }
}

/// Hashes a byte slice (the checksum of saved files; the server's digest
/// of its game rules' saved state).
pub fn hash_bytes(bytes: &[u8]) -> u64 {
    let mut h = StateHasher::default();
    let mut chunks = bytes.chunks_exact(8);
    for c in &mut chunks {
        h.write_u64(u64::from_le_bytes(c.try_into().expect("8 bytes")));
    }
    let mut tail = [0u8; 8];
    let rest = chunks.remainder();
    tail[..rest.len()].copy_from_slice(rest);
    h.write_u64(u64::from_le_bytes(tail) ^ ((rest.len() as u64) << 56));
    h.finish()
}
