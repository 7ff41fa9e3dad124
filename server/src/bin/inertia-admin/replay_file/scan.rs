//! Reading a recording segment by segment for the offline tools: every
//! intact record of a segment, then what ends it — a clean end, a torn
//! tail (a record cut short at the end of the newest segment with nothing
//! intact after it), or corruption with its file and byte offset. ScanDamage
//! is reported, never a panic, and one damaged segment does not hide the
//! others (each segment after a directory's first starts at a keyframe).

use std::ops::ControlFlow;
use std::path::{Path, PathBuf};

use inertia_server::record::{Corruption, Record, RecordError, RecordReader, SegmentFile};
use serde_json::json;

use super::misuse;
use crate::Failure;

/// Bytes of a segment's header (magic and version).
const HEADER_BYTES: u64 = 8;
/// Bytes a frame adds to its payload: kind (1), length (4), CRC-32 (4).
const FRAME_BYTES: u64 = 9;

/// The segment files of the recording at `path` (a directory, or one
/// segment file), oldest first; misuse (exit 2) when the path does not
/// exist, cannot be listed or holds no segment file.
pub fn open(path: &Path) -> Result<Vec<SegmentFile>, Failure> {
    if !path.exists() {
        return Err(misuse(
            "not_found",
            format!("{}: no such file or directory", path.display()),
        ));
    }
    let reader = RecordReader::open(path).map_err(|e| misuse("io", e.to_string()))?;
    let segments = reader.segment_files().to_vec();
    if segments.is_empty() {
        return Err(misuse(
            "not_a_recording",
            format!(
                "{}: not a recording (no segment files named segment-<tick>.irec)",
                path.display()
            ),
        ));
    }
    Ok(segments)
}

/// ScanDamage found in a segment.
#[derive(Debug, Clone)]
pub struct ScanDamage {
    /// The segment file.
    pub file: PathBuf,
    /// Byte offset of the first bad byte, from the start of the file.
    pub offset: u64,
    /// What is wrong, for people.
    pub why: String,
    /// The damage as the store classified it (`None` for an I/O error).
    pub corruption: Option<Corruption>,
    /// A record cut short at the end of the newest segment: what a crash
    /// mid-append leaves. Readers stop there cleanly and a writer cuts it
    /// (keeping the bytes aside) when it opens the recording; nothing
    /// before it is lost.
    pub torn_tail: bool,
    /// Whether the records after it in that segment cannot be read (the
    /// framing itself is damaged) or only this record is bad (a checksummed
    /// record whose content does not decode).
    pub rest_unread: bool,
}

impl ScanDamage {
    /// Whether the file is not a segment at all (bad magic at byte 0).
    pub fn not_a_segment(&self) -> bool {
        self.offset == 0 && self.corruption == Some(Corruption::BadMagic)
    }

    /// One line for people.
    pub fn text(&self) -> String {
        let name = file_name(&self.file);
        if self.torn_tail {
            format!(
                "torn tail in {name} at byte {}: {} (a crash mid-write; readers stop there \
                 and the server cuts it when it reopens the recording)",
                self.offset, self.why
            )
        } else if self.rest_unread {
            format!(
                "corrupt: {name} at byte {}: {}; nothing after it in that segment can be read",
                self.offset, self.why
            )
        } else {
            format!("corrupt: {name} at byte {}: {}", self.offset, self.why)
        }
    }

    /// A checksummed record at `offset` of `file` whose content is bad.
    pub fn bad_record(file: &Path, offset: u64, why: String) -> ScanDamage {
        ScanDamage {
            file: file.to_path_buf(),
            offset,
            why,
            corruption: None,
            torn_tail: false,
            rest_unread: false,
        }
    }

    /// The damage as a JSON object.
    pub fn json(&self) -> serde_json::Value {
        json!({
            "file": self.file.display().to_string(),
            "offset": self.offset,
            "why": self.why,
            "torn_tail": self.torn_tail,
            "rest_unread": self.rest_unread,
        })
    }
}

/// What scanning one segment found.
#[derive(Debug, Clone)]
pub struct SegmentScan {
    /// Tick of its first intact record.
    pub first_tick: Option<u64>,
    /// Tick of its last intact record.
    pub last_tick: Option<u64>,
    /// Intact records read.
    pub records: u64,
    /// The file's size, bytes.
    pub bytes: u64,
    /// What stopped the records early, if anything.
    pub damage: Option<ScanDamage>,
    /// True when the caller broke off before the end.
    pub stopped: bool,
}

/// Reads `segment` front to back, handing each intact record and the
/// byte offset of its frame to `each` (which may break off). `newest`:
/// whether it is the recording's newest segment, the only one where a
/// record cut short is a torn tail rather than corruption.
pub fn scan_segment(
    segment: &SegmentFile,
    newest: bool,
    mut each: impl FnMut(u64, Record) -> ControlFlow<()>,
) -> SegmentScan {
    let mut scan = SegmentScan {
        first_tick: None,
        last_tick: None,
        records: 0,
        bytes: segment.bytes,
        damage: None,
        stopped: false,
    };
    let io_damage = |offset: u64, e: &dyn std::fmt::Display| ScanDamage {
        file: segment.path.clone(),
        offset,
        why: e.to_string(),
        corruption: None,
        torn_tail: false,
        rest_unread: true,
    };
    // Opened alone, a segment reads as a recording's newest: a record cut
    // short at its end ends the records cleanly. Whether that was a torn
    // tail or damage is decided below from the bytes read.
    let reader = match RecordReader::open(&segment.path) {
        Ok(r) => r,
        Err(e) => {
            scan.damage = Some(io_damage(0, &e));
            return scan;
        }
    };
    let mut intact = HEADER_BYTES;
    for record in reader.iter() {
        match record {
            Ok(record) => {
                let tick = record.tick();
                scan.first_tick.get_or_insert(tick);
                scan.last_tick = Some(tick);
                scan.records += 1;
                let offset = intact;
                intact += FRAME_BYTES + record.payload_len();
                if each(offset, record).is_break() {
                    scan.stopped = true;
                    return scan;
                }
            }
            Err(RecordError::Corrupt { offset, why, .. }) => {
                scan.damage = Some(ScanDamage {
                    file: segment.path.clone(),
                    offset,
                    why: why.to_string(),
                    corruption: Some(why),
                    torn_tail: false,
                    rest_unread: true,
                });
                return scan;
            }
            Err(e) => {
                scan.damage = Some(io_damage(intact, &e));
                return scan;
            }
        }
    }
    // The length as read now (a live recording may have grown since it
    // was listed).
    let len = std::fs::metadata(&segment.path)
        .map(|m| m.len())
        .unwrap_or(segment.bytes);
    scan.bytes = len;
    let end = if len < HEADER_BYTES { 0 } else { intact };
    if end < len || len < HEADER_BYTES {
        scan.damage = Some(ScanDamage {
            file: segment.path.clone(),
            offset: end,
            why: Corruption::Truncated.to_string(),
            corruption: Some(Corruption::Truncated),
            torn_tail: newest,
            rest_unread: true,
        });
    }
    scan
}

/// A segment file's name, for people.
pub fn file_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_else(|| path.display().to_string())
}
