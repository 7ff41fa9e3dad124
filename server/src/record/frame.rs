//! Framing: the segment header, and one checksummed frame per record.
//!
//! [`FrameReader`] walks a segment front to back and stops at the first
//! damage, saying where and what. [`is_torn_frame`] tells, from the bytes
//! between a damaged frame and the end of the file, whether they have the
//! shape an interrupted append leaves; whether that makes them a torn
//! tail to cut (only at the end of the newest segment) is the caller's
//! business.

use std::io::{self, Read, Seek, SeekFrom};

use super::codec::{Record, RecordKind};
use super::crc32::{crc32, Crc32};
use super::error::{Corruption, RecordError};
use super::MAX_RECORD_BYTES;

/// The four bytes every segment file starts with.
pub(crate) const SEGMENT_MAGIC: [u8; 4] = *b"IREC";
/// The segment format version written after the magic.
pub(crate) const FORMAT_VERSION: u32 = 1;
/// Bytes of the segment header: magic and version.
pub(crate) const HEADER_BYTES: u64 = 8;
/// Bytes a frame adds around its payload: kind (1), length (4), CRC (4).
pub(crate) const FRAME_OVERHEAD: u64 = 9;

/// The segment header.
pub(crate) fn segment_header() -> [u8; HEADER_BYTES as usize] {
    let mut header = [0u8; HEADER_BYTES as usize];
    header[..4].copy_from_slice(&SEGMENT_MAGIC);
    header[4..].copy_from_slice(&FORMAT_VERSION.to_le_bytes());
    header
}

/// Clears `out` and fills it with `record`'s whole frame.
pub(crate) fn encode_frame(record: &Record, out: &mut Vec<u8>) -> Result<(), RecordError> {
    out.clear();
    out.push(record.kind() as u8);
    out.extend_from_slice(&[0; 4]);
    record.encode_payload(out)?;
    // encode_payload refused anything over MAX_RECORD_BYTES, so this fits.
    let len = (out.len() - 5) as u32;
    out[1..5].copy_from_slice(&len.to_le_bytes());
    let crc = crc32(out);
    out.extend_from_slice(&crc.to_le_bytes());
    Ok(())
}

/// One step of [`FrameReader`]: a framed record, the end, or damage.
#[derive(Debug)]
pub(crate) enum Framed {
    /// An intact record, `len` bytes long with framing.
    Record {
        /// Frame size, bytes.
        len: u64,
        /// The decoded record.
        record: Record,
    },
    /// The end of the file, exactly at a frame boundary.
    End,
    /// The header or the frame at `offset` is damaged; reading stops here.
    Damaged {
        /// Byte offset of the damaged header or frame.
        offset: u64,
        /// What is wrong.
        why: Corruption,
    },
}

/// Reads frames from a segment of known length. Never allocates more than
/// the smaller of [`MAX_RECORD_BYTES`] and what is left of the file.
#[derive(Debug)]
pub(crate) struct FrameReader<R> {
    inner: R,
    /// Byte offset of the next frame.
    offset: u64,
    /// File length, bytes, as of opening.
    end: u64,
    /// Set after `End` or `Damaged`: every later call repeats nothing.
    done: bool,
}

impl<R: Read> FrameReader<R> {
    /// Checks the header of a segment `end` bytes long; on success the
    /// reader stands at the first frame, otherwise it returns the damage at
    /// offset 0.
    pub(crate) fn new(mut inner: R, end: u64) -> io::Result<Result<Self, Corruption>> {
        let mut header = [0u8; HEADER_BYTES as usize];
        if end < HEADER_BYTES {
            // A header cut short is torn only if what there is of it is
            // right.
            let part = &mut header[..end as usize];
            if let Some(damage) = read_or_truncated(&mut inner, part)? {
                return Ok(Err(damage));
            }
            if *part != segment_header()[..end as usize] {
                return Ok(Err(Corruption::BadMagic));
            }
            return Ok(Err(Corruption::Truncated));
        }
        if let Some(damage) = read_or_truncated(&mut inner, &mut header)? {
            return Ok(Err(damage));
        }
        if header[..4] != SEGMENT_MAGIC {
            return Ok(Err(Corruption::BadMagic));
        }
        let version = u32::from_le_bytes([header[4], header[5], header[6], header[7]]);
        if version != FORMAT_VERSION {
            return Ok(Err(Corruption::UnsupportedVersion(version)));
        }
        Ok(Ok(Self {
            inner,
            offset: HEADER_BYTES,
            end,
            done: false,
        }))
    }

    /// Byte offset of the next frame (after the last intact one).
    pub(crate) fn offset(&self) -> u64 {
        self.offset
    }

    /// Reads the next frame.
    pub(crate) fn next_frame(&mut self) -> io::Result<Framed> {
        if self.done {
            return Ok(Framed::End);
        }
        let frame = self.read_frame()?;
        match &frame {
            Framed::Record { len, .. } => self.offset += len,
            Framed::End | Framed::Damaged { .. } => self.done = true,
        }
        Ok(frame)
    }

    fn read_frame(&mut self) -> io::Result<Framed> {
        let offset = self.offset;
        let damaged = |why| Ok(Framed::Damaged { offset, why });
        let left = self.end.saturating_sub(offset);
        if left == 0 {
            return Ok(Framed::End);
        }
        if left < FRAME_OVERHEAD {
            return damaged(Corruption::Truncated);
        }
        let mut head = [0u8; 5];
        if let Some(why) = read_or_truncated(&mut self.inner, &mut head)? {
            return damaged(why);
        }
        let len = u32::from_le_bytes([head[1], head[2], head[3], head[4]]);
        if len > MAX_RECORD_BYTES {
            return damaged(Corruption::Oversized(len));
        }
        let frame_len = FRAME_OVERHEAD + u64::from(len);
        if frame_len > left {
            return damaged(Corruption::Truncated);
        }
        let mut payload = vec![0u8; len as usize];
        if let Some(why) = read_or_truncated(&mut self.inner, &mut payload)? {
            return damaged(why);
        }
        let mut stored = [0u8; 4];
        if let Some(why) = read_or_truncated(&mut self.inner, &mut stored)? {
            return damaged(why);
        }
        let stored = u32::from_le_bytes(stored);
        let mut crc = Crc32::new();
        crc.update(&head);
        crc.update(&payload);
        let computed = crc.finish();
        if stored != computed {
            return damaged(Corruption::BadChecksum { stored, computed });
        }
        let Some(kind) = RecordKind::from_byte(head[0]) else {
            return damaged(Corruption::UnknownKind(head[0]));
        };
        match Record::decode(kind, &payload) {
            Ok(record) => Ok(Framed::Record {
                len: frame_len,
                record,
            }),
            Err(why) => damaged(why),
        }
    }
}

impl<R: Read + Seek> FrameReader<R> {
    /// After the damage [`Self::next_frame`] reported at `damaged`, looks
    /// past it for the next intact frame (see [`find_intact_frame`]) and
    /// stands there, so that reading goes on with the records after the
    /// damage. Returns that frame's offset, or `None` when nothing after
    /// the damage can be trusted (the reader then stays at its end).
    pub(crate) fn resync(&mut self, damaged: u64) -> io::Result<Option<u64>> {
        let from = damaged + 1;
        if from >= self.end {
            return Ok(None);
        }
        self.inner.seek(SeekFrom::Start(from))?;
        let mut rest = Vec::new();
        (&mut self.inner)
            .take(self.end - from)
            .read_to_end(&mut rest)?;
        let Search::Found(at) = find_intact_frame(&rest) else {
            return Ok(None);
        };
        let offset = from + at as u64;
        self.inner.seek(SeekFrom::Start(offset))?;
        self.offset = offset;
        self.done = false;
        Ok(Some(offset))
    }
}

/// Largest payload of a frame [`is_torn_frame`] looks for after a frame
/// cut short, bytes. Most records (tick hashes, journals) are far smaller,
/// so an intact one follows any damage within a few dozen bytes; looking
/// only for these keeps the search cheap.
const RESYNC_PAYLOAD_BYTES: usize = 64 * 1024;

/// Most payload bytes [`is_torn_frame`] checksums while looking; past it
/// the bytes are taken as damage (not cut), bytes.
const RESYNC_CRC_BUDGET: usize = 64 * 1024 * 1024;

/// Whether `tail`, the bytes from a frame's start to the end of the file
/// (the frame [`FrameReader`] found cut short), is what an interrupted
/// append leaves: the beginning of one frame and nothing else. Its kind
/// must be a record kind, its length (when the header is whole) within
/// [`MAX_RECORD_BYTES`] and past the end of the file, and no intact frame
/// may start anywhere after its first byte: a length corrupted upward also
/// runs past the end, but intact records follow it, and that is damage.
/// Frames of payloads over [`RESYNC_PAYLOAD_BYTES`] are not looked for,
/// and a search that would checksum more than [`RESYNC_CRC_BUDGET`] bytes
/// gives up and calls it damage (never cut on a doubt).
pub(crate) fn is_torn_frame(tail: &[u8]) -> bool {
    let Some(&kind) = tail.first() else {
        return false;
    };
    if RecordKind::from_byte(kind).is_none() {
        return false;
    }
    if tail.len() >= 5 {
        let len = u32::from_le_bytes([tail[1], tail[2], tail[3], tail[4]]);
        if len > MAX_RECORD_BYTES || FRAME_OVERHEAD + u64::from(len) <= tail.len() as u64 {
            return false;
        }
    }
    !holds_intact_frame(&tail[1..])
}

/// What [`find_intact_frame`] found.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Search {
    /// An intact frame starts this many bytes in.
    Found(usize),
    /// None starts anywhere.
    None,
    /// Looking would checksum more than [`RESYNC_CRC_BUDGET`] bytes.
    GaveUp,
}

/// Where the first intact frame (a record kind, a payload of at most
/// [`RESYNC_PAYLOAD_BYTES`], its checksum right) starts in `bytes`. Every
/// tick writes a small record (its hash, its journal), so one follows any
/// damage within a tick's worth of bytes; from it, reading goes on frame by
/// frame, large keyframes included. A false start needs a random CRC-32 to
/// match (about one in 4·10⁹ per candidate) and its record to decode.
pub(crate) fn find_intact_frame(bytes: &[u8]) -> Search {
    let overhead = FRAME_OVERHEAD as usize;
    let mut budget = RESYNC_CRC_BUDGET;
    for start in 0..bytes.len() {
        let rest = &bytes[start..];
        if rest.len() < overhead {
            break;
        }
        if RecordKind::from_byte(rest[0]).is_none() {
            continue;
        }
        let len = u32::from_le_bytes([rest[1], rest[2], rest[3], rest[4]]) as usize;
        if len > RESYNC_PAYLOAD_BYTES || overhead + len > rest.len() {
            continue;
        }
        let Some(left) = budget.checked_sub(5 + len) else {
            return Search::GaveUp;
        };
        budget = left;
        let body = &rest[..5 + len];
        let stored = &rest[5 + len..overhead + len];
        if crc32(body).to_le_bytes() == stored {
            return Search::Found(start);
        }
    }
    Search::None
}

/// Whether an intact frame starts anywhere in `bytes`; `true` as well
/// when looking would cost more than [`RESYNC_CRC_BUDGET`] (never cut a
/// tail on a doubt).
fn holds_intact_frame(bytes: &[u8]) -> bool {
    find_intact_frame(bytes) != Search::None
}

/// `read_exact`, except that a file that ends early (it shrank since its
/// length was taken) is damage, not an I/O error.
fn read_or_truncated(r: &mut impl Read, buf: &mut [u8]) -> io::Result<Option<Corruption>> {
    match r.read_exact(buf) {
        Ok(()) => Ok(None),
        Err(e) if e.kind() == io::ErrorKind::UnexpectedEof => Ok(Some(Corruption::Truncated)),
        Err(e) => Err(e),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn segment(records: &[Record]) -> Vec<u8> {
        let mut bytes = segment_header().to_vec();
        let mut frame = Vec::new();
        for r in records {
            encode_frame(r, &mut frame).unwrap();
            bytes.extend_from_slice(&frame);
        }
        bytes
    }

    fn read_all(bytes: &[u8]) -> (Vec<Record>, Framed) {
        let mut reader = match FrameReader::new(bytes, bytes.len() as u64).unwrap() {
            Ok(r) => r,
            Err(why) => return (vec![], Framed::Damaged { offset: 0, why }),
        };
        let mut out = Vec::new();
        loop {
            match reader.next_frame().unwrap() {
                Framed::Record { record, .. } => out.push(record),
                other => return (out, other),
            }
        }
    }

    #[test]
    fn frame_layout_is_as_documented() {
        let record = Record::TickHash {
            tick: 0x0102,
            hash: 0xAB,
        };
        let mut frame = Vec::new();
        encode_frame(&record, &mut frame).unwrap();
        assert_eq!(frame.len(), 9 + 16);
        assert_eq!(frame[0], RecordKind::TickHash as u8);
        assert_eq!(&frame[1..5], &16u32.to_le_bytes());
        assert_eq!(&frame[5..13], &0x0102u64.to_le_bytes());
        assert_eq!(&frame[13..21], &0xABu64.to_le_bytes());
        assert_eq!(&frame[21..], &crc32(&frame[..21]).to_le_bytes());
        assert_eq!(&segment_header(), b"IREC\x01\x00\x00\x00");
    }

    #[test]
    fn reads_back_and_ends_at_a_boundary() {
        let records = vec![
            Record::TickHash { tick: 1, hash: 2 },
            Record::Keyframe {
                tick: 2,
                state: vec![5; 300],
            },
        ];
        let (got, end) = read_all(&segment(&records));
        assert_eq!(got, records);
        assert!(matches!(end, Framed::End));
    }

    #[test]
    fn damage_is_located() {
        let records = vec![
            Record::TickHash { tick: 1, hash: 2 },
            Record::TickHash { tick: 2, hash: 3 },
        ];
        let mut bytes = segment(&records);
        let second = HEADER_BYTES + FRAME_OVERHEAD + 16;
        bytes[second as usize + 7] ^= 1;
        let (got, end) = read_all(&bytes);
        assert_eq!(got, records[..1]);
        assert!(matches!(
            end,
            Framed::Damaged {
                offset,
                why: Corruption::BadChecksum { .. }
            } if offset == second
        ));
        let (_, end) = read_all(&bytes[..bytes.len() - 1]);
        assert!(matches!(
            end,
            Framed::Damaged {
                why: Corruption::Truncated,
                ..
            }
        ));
        let (_, end) = read_all(b"IREC\x02\x00\x00\x00");
        assert!(matches!(
            end,
            Framed::Damaged {
                why: Corruption::UnsupportedVersion(2),
                ..
            }
        ));
        let (_, end) = read_all(b"NOPE\x01\x00\x00\x00");
        assert!(matches!(
            end,
            Framed::Damaged {
                why: Corruption::BadMagic,
                ..
            }
        ));
    }

    #[test]
    fn issue_44_reading_goes_on_at_the_next_intact_frame_after_damage() {
        let records: Vec<Record> = (1..=4)
            .map(|tick| Record::TickHash {
                tick,
                hash: tick * 10,
            })
            .collect();
        let mut bytes = segment(&records);
        let second = HEADER_BYTES + FRAME_OVERHEAD + 16;
        bytes[second as usize + 7] ^= 1;
        let len = bytes.len() as u64;
        let mut reader = FrameReader::new(io::Cursor::new(&bytes), len)
            .unwrap()
            .unwrap();
        assert!(matches!(
            reader.next_frame().unwrap(),
            Framed::Record { .. }
        ));
        let Framed::Damaged { offset, .. } = reader.next_frame().unwrap() else {
            panic!("the second frame is damaged");
        };
        assert_eq!(offset, second);
        // On at the third frame, and to the end.
        let third = second + FRAME_OVERHEAD + 16;
        assert_eq!(reader.resync(offset).unwrap(), Some(third));
        let mut after = Vec::new();
        while let Framed::Record { record, .. } = reader.next_frame().unwrap() {
            after.push(record);
        }
        assert_eq!(after, records[2..]);
        // Damage in the last frame: nothing after it to read.
        let mut bytes = segment(&records[..1]);
        let last = bytes.len() - 3;
        bytes[last] ^= 1;
        let len = bytes.len() as u64;
        let mut reader = FrameReader::new(io::Cursor::new(&bytes), len)
            .unwrap()
            .unwrap();
        assert!(matches!(
            reader.next_frame().unwrap(),
            Framed::Damaged { .. }
        ));
        assert_eq!(reader.resync(HEADER_BYTES).unwrap(), None);
    }

    #[test]
    fn only_the_start_of_one_frame_is_a_torn_frame() {
        let records = vec![
            Record::TickHash { tick: 1, hash: 2 },
            Record::Keyframe {
                tick: 2,
                state: vec![5; 300],
            },
            Record::TickHash { tick: 2, hash: 3 },
        ];
        let mut frame = Vec::new();
        encode_frame(&records[1], &mut frame).unwrap();
        // Every prefix of a frame is what an interrupted append leaves.
        for n in 1..frame.len() {
            assert!(is_torn_frame(&frame[..n]), "{n} bytes");
        }
        // A whole frame is not cut short, whatever its checksum.
        assert!(!is_torn_frame(&frame));
        assert!(!is_torn_frame(&[]));
        // Nor a kind no record has, or a length over the limit.
        assert!(!is_torn_frame(&[0, 1, 0, 0, 0, 9]));
        assert!(!is_torn_frame(&[2, 0xFF, 0xFF, 0xFF, 0xFF, 9]));
        // A length corrupted upward runs past the end too, but the intact
        // frames after it say it is damage.
        let bytes = segment(&records);
        let second = (HEADER_BYTES + FRAME_OVERHEAD + 16) as usize;
        let mut tail = bytes[second..].to_vec();
        tail[3] ^= 0x01;
        assert!(!is_torn_frame(&tail));
        let (_, end) = read_all(&[&bytes[..second], &tail[..]].concat());
        assert!(matches!(
            end,
            Framed::Damaged {
                why: Corruption::Truncated,
                ..
            }
        ));
    }

    #[test]
    fn a_short_header_is_truncated_only_if_right_so_far() {
        for n in 0..HEADER_BYTES as usize {
            let (_, end) = read_all(&segment_header()[..n]);
            assert!(
                matches!(
                    end,
                    Framed::Damaged {
                        offset: 0,
                        why: Corruption::Truncated
                    }
                ),
                "{n}"
            );
        }
        let (_, end) = read_all(b"IRX");
        assert!(matches!(
            end,
            Framed::Damaged {
                why: Corruption::BadMagic,
                ..
            }
        ));
    }

    #[test]
    fn valid_checksum_unknown_kind_is_not_a_torn_write() {
        let mut frame = vec![77u8, 0, 0, 0, 0];
        let crc = crc32(&frame);
        frame.extend_from_slice(&crc.to_le_bytes());
        let mut bytes = segment_header().to_vec();
        bytes.extend_from_slice(&frame);
        let (_, end) = read_all(&bytes);
        let Framed::Damaged { why, .. } = end else {
            panic!("expected damage, got {end:?}");
        };
        assert_eq!(why, Corruption::UnknownKind(77));
        assert!(!why.is_torn_write());
    }
}
