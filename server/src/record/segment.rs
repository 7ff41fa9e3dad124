//! Segment files: their names, listing a directory of them, and scanning
//! one end to end.
//!
//! A segment is named after the tick of its first record,
//! `segment-<tick, 20 decimal digits>.irec`, so the names sort by tick and
//! finding the segment that holds a tick needs no file opened.

use std::fs::{self, File};
use std::io::{BufReader, Read, Seek, SeekFrom};
use std::path::{Path, PathBuf};

use super::error::{Corruption, RecordError};
use super::frame::{is_torn_frame, FrameReader, Framed, FRAME_OVERHEAD};
use super::MAX_RECORD_BYTES;

const PREFIX: &str = "segment-";
const SUFFIX: &str = ".irec";

/// The file name of the segment whose first record is at `first_tick`.
pub fn segment_file_name(first_tick: u64) -> String {
    format!("{PREFIX}{first_tick:020}{SUFFIX}")
}

/// The first tick a segment file name stands for, or `None` for any other
/// name (other files in the directory are ignored).
pub fn parse_segment_file_name(name: &str) -> Option<u64> {
    let digits = name.strip_prefix(PREFIX)?.strip_suffix(SUFFIX)?;
    if digits.len() != 20 || !digits.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    digits.parse().ok()
}

/// A segment file as the directory listing shows it (nothing read inside).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SegmentFile {
    /// The file.
    pub path: PathBuf,
    /// The tick of its first record, from its name.
    pub first_tick: u64,
    /// Its size on disk, bytes (for the segment being written, including
    /// what is still buffered).
    pub bytes: u64,
}

/// A segment as a full scan found it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct SegmentInfo {
    /// The file.
    pub path: PathBuf,
    /// Tick of its first record (from the name when it holds none).
    pub first_tick: u64,
    /// Tick of its last intact record (`first_tick` when it holds none).
    pub last_tick: u64,
    /// Intact records, counted.
    pub records: u64,
    /// Its size on disk, bytes.
    pub bytes: u64,
}

/// The segment files in `dir`, oldest first.
pub(crate) fn list_segments(dir: &Path) -> Result<Vec<SegmentFile>, RecordError> {
    let entries = fs::read_dir(dir).map_err(|e| RecordError::io(dir, e))?;
    let mut out = Vec::new();
    for entry in entries {
        let entry = entry.map_err(|e| RecordError::io(dir, e))?;
        let name = entry.file_name();
        let Some(first_tick) = name.to_str().and_then(parse_segment_file_name) else {
            continue;
        };
        let path = entry.path();
        let meta = entry.metadata().map_err(|e| RecordError::io(&path, e))?;
        if !meta.is_file() {
            continue;
        }
        out.push(SegmentFile {
            path,
            first_tick,
            bytes: meta.len(),
        });
    }
    out.sort_by_key(|s| s.first_tick);
    Ok(out)
}

/// What reading a whole segment found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Scan {
    /// Intact records before any damage.
    pub records: u64,
    /// Tick of the first intact record.
    pub first_tick: Option<u64>,
    /// Tick of the last intact record.
    pub last_tick: Option<u64>,
    /// Bytes up to the end of the last intact record (the header alone, 8,
    /// when none; 0 when the header itself is damaged).
    pub good_len: u64,
    /// File length when scanned, bytes.
    pub file_len: u64,
    /// The first damage: its offset and kind.
    pub damage: Option<(u64, Corruption)>,
    /// Whether that damage has the shape of a torn write: a header or
    /// frame cut short by the end of the file with nothing intact after
    /// it (see [`torn_at`]). Only at the end of the newest segment is that
    /// a torn tail; anywhere else it is damage like any other.
    pub torn_tail: bool,
}

/// Reads every frame of the segment at `path`, checking each checksum.
pub(crate) fn scan_segment(path: &Path) -> Result<Scan, RecordError> {
    let io = |e| RecordError::io(path, e);
    let file = File::open(path).map_err(io)?;
    let file_len = file.metadata().map_err(io)?.len();
    scan_frames(BufReader::new(file), file_len, path, |offset, why| {
        torn_at(path, offset, why)
    })
}

/// [`scan_segment`] over a segment's bytes held in memory: the same frame
/// reader, checksums and torn-tail test, with no file (what the fuzz
/// targets drive).
pub fn scan_segment_bytes(bytes: &[u8]) -> Scan {
    let len = bytes.len() as u64;
    let scan = scan_frames(bytes, len, Path::new("<memory>"), |offset, why| {
        torn_shape(offset, why, || {
            Ok(bytes
                .get(offset as usize..)
                .filter(|tail| tail.len() as u64 <= FRAME_OVERHEAD + u64::from(MAX_RECORD_BYTES))
                .map(<[u8]>::to_vec))
        })
    });
    // Reading a slice never fails.
    scan.expect("reading bytes in memory")
}

/// Reads every frame from `inner` (`file_len` bytes), checking each
/// checksum; `torn` says whether the damage found at an offset has the
/// shape of a torn write.
fn scan_frames<R: Read>(
    inner: R,
    file_len: u64,
    path: &Path,
    torn: impl FnOnce(u64, Corruption) -> Result<bool, RecordError>,
) -> Result<Scan, RecordError> {
    let io = |e| RecordError::io(path, e);
    let mut scan = Scan {
        records: 0,
        first_tick: None,
        last_tick: None,
        good_len: 0,
        file_len,
        damage: None,
        torn_tail: false,
    };
    let mut reader = match FrameReader::new(inner, file_len).map_err(io)? {
        Ok(reader) => reader,
        Err(why) => {
            scan.damage = Some((0, why));
            scan.torn_tail = torn(0, why)?;
            return Ok(scan);
        }
    };
    loop {
        match reader.next_frame().map_err(io)? {
            Framed::Record { record, .. } => {
                scan.records += 1;
                scan.first_tick.get_or_insert(record.tick());
                scan.last_tick = Some(record.tick());
            }
            Framed::End => break,
            Framed::Damaged { offset, why } => {
                scan.damage = Some((offset, why));
                scan.torn_tail = torn(offset, why)?;
                break;
            }
        }
    }
    scan.good_len = reader.offset();
    Ok(scan)
}

/// Whether `why` at `offset` in the segment at `path` has the shape of a
/// torn write: a header cut short whose bytes are right so far (offset
/// 0), or a frame cut short by the end of the file with nothing intact
/// after it ([`is_torn_frame`]).
pub(crate) fn torn_at(path: &Path, offset: u64, why: Corruption) -> Result<bool, RecordError> {
    torn_shape(offset, why, || read_tail(path, offset))
}

/// [`torn_at`] with the bytes from `offset` to the end (or `None` when
/// more than one frame could hold) read by `tail`.
fn torn_shape(
    offset: u64,
    why: Corruption,
    tail: impl FnOnce() -> Result<Option<Vec<u8>>, RecordError>,
) -> Result<bool, RecordError> {
    if why != Corruption::Truncated {
        return Ok(false);
    }
    if offset == 0 {
        // FrameReader::new says Truncated only for a right partial header.
        return Ok(true);
    }
    Ok(tail()?.is_some_and(|tail| is_torn_frame(&tail)))
}

/// The bytes of the file at `path` from `offset` to its end, or `None`
/// when there are more than one frame could hold (then they are not one
/// frame cut short).
pub(crate) fn read_tail(path: &Path, offset: u64) -> Result<Option<Vec<u8>>, RecordError> {
    let io = |e| RecordError::io(path, e);
    let mut file = File::open(path).map_err(io)?;
    let len = file.metadata().map_err(io)?.len();
    let left = len.saturating_sub(offset);
    if left > FRAME_OVERHEAD + u64::from(MAX_RECORD_BYTES) {
        return Ok(None);
    }
    file.seek(SeekFrom::Start(offset)).map_err(io)?;
    let mut tail = Vec::with_capacity(left as usize);
    file.take(left).read_to_end(&mut tail).map_err(io)?;
    Ok(Some(tail))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip_and_sort() {
        for tick in [0, 1, 59, 1 << 40, u64::MAX] {
            let name = segment_file_name(tick);
            assert_eq!(name.len(), 8 + 20 + 5);
            assert_eq!(parse_segment_file_name(&name), Some(tick));
        }
        assert!(segment_file_name(9) < segment_file_name(10));
        for bad in [
            "segment-1.irec",
            "segment-0000000000000000000a.irec",
            "segment-99999999999999999999.irec", // over u64::MAX
            "segment-00000000000000000001.irec.tmp",
            "dev-credentials.json",
            "segment-+0000000000000000001.irec",
        ] {
            assert_eq!(parse_segment_file_name(bad), None, "{bad}");
        }
    }
}
