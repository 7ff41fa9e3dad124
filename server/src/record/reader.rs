//! [`RecordReader`]: read-only access to a recording directory (or one
//! segment file): list segments, iterate records from a tick, find the
//! keyframe to seek from, the hash of a tick, the inputs of a range.
//!
//! Lookups use the segment names to skip to the right file, then read it
//! front to back (records are tick-ordered, so a lookup stops at the first
//! record past its tick). Every frame's checksum is checked on the way.
//!
//! Damage: a torn tail — a frame cut short by the end of the newest
//! segment with nothing intact after it — is a write in progress (or a
//! crash not yet repaired by a writer) and ends the records cleanly;
//! anything else — a bad checksum anywhere, a short frame in an older
//! segment — is [`RecordError::Corrupt`] with the file and offset, and no
//! record after it in that segment is delivered.
//!
//! [`RecordReader::salvage`] reads a damaged recording as far as it can
//! be trusted, for `--resume`: each segment up to its first damage (which
//! it reports and reads past by going on with the next segment, which
//! starts at a keyframe), never a record after damage in the same
//! segment.

use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use super::codec::LegacyInput;

use super::codec::Record;
use super::error::{Corruption, RecordError, SegmentDamage};
use super::frame::{FrameReader, Framed};
use super::segment::{
    list_segments, parse_segment_file_name, scan_segment, torn_at, SegmentFile, SegmentInfo,
};

/// The inputs applied at one tick: the tick and its `(client id, input)`
/// pairs, in the order applied.
pub type TickInputs = (u64, Vec<(u64, LegacyInput)>);

/// Reads a recording. Holds the segment list as of
/// [`open`](Self::open); open again to see segments added or removed since.
#[derive(Debug, Clone)]
pub struct RecordReader {
    /// Oldest first.
    segments: Vec<SegmentFile>,
}

impl RecordReader {
    /// Opens a recording directory, or a single segment file (whatever its
    /// name) for offline inspection. Reads only the directory listing.
    pub fn open(path: impl AsRef<Path>) -> Result<Self, RecordError> {
        let path = path.as_ref();
        let meta = std::fs::metadata(path).map_err(|e| RecordError::io(path, e))?;
        let segments = if meta.is_dir() {
            list_segments(path)?
        } else {
            let first_tick = path
                .file_name()
                .and_then(|n| n.to_str())
                .and_then(parse_segment_file_name)
                .unwrap_or(0);
            vec![SegmentFile {
                path: path.to_path_buf(),
                first_tick,
                bytes: meta.len(),
            }]
        };
        Ok(Self { segments })
    }

    /// The segment files, oldest first, as listed at open (no file read).
    pub fn segment_files(&self) -> &[SegmentFile] {
        &self.segments
    }

    /// Reads every segment through and reports its first and last tick and
    /// record count. Damage is an error as described in the module docs.
    pub fn segments(&self) -> Result<Vec<SegmentInfo>, RecordError> {
        let mut out = Vec::with_capacity(self.segments.len());
        for (i, segment) in self.segments.iter().enumerate() {
            let scan = scan_segment(&segment.path)?;
            if let Some((offset, why)) = scan.damage {
                if !(i + 1 == self.segments.len() && scan.torn_tail) {
                    return Err(RecordError::Corrupt {
                        path: segment.path.clone(),
                        offset,
                        why,
                    });
                }
            }
            let first_tick = scan.first_tick.unwrap_or(segment.first_tick);
            out.push(SegmentInfo {
                path: segment.path.clone(),
                first_tick,
                last_tick: scan.last_tick.unwrap_or(first_tick),
                records: scan.records,
                bytes: scan.file_len,
            });
        }
        Ok(out)
    }

    /// Every record, oldest first.
    pub fn iter(&self) -> Records {
        Records::new(self.segments.clone(), true)
    }

    /// Records from the start of the segment a replay to `tick` starts in —
    /// the newest whose first record (a keyframe, for every segment but a
    /// directory's first) is at or before `tick` — through the end of the
    /// recording. Starts at the oldest segment when `tick` is before all.
    pub fn iter_from(&self, tick: u64) -> Records {
        let start = self
            .segments
            .iter()
            .rposition(|s| s.first_tick <= tick)
            .unwrap_or(0);
        Records::new(self.segments[start..].to_vec(), true)
    }

    /// The newest keyframe at or before `tick`: its tick and saved state.
    pub fn keyframe_at_or_before(&self, tick: u64) -> Result<Option<(u64, Vec<u8>)>, RecordError> {
        let mut end = self.segments.len();
        // Normally the first segment read holds the answer; step back only
        // when it does not (a segment that does not start with a keyframe).
        while end > 0 {
            let start = self.segments[..end]
                .iter()
                .rposition(|s| s.first_tick <= tick)
                .unwrap_or(0);
            let mut found = None;
            for record in Records::new(
                self.segments[start..end].to_vec(),
                end == self.segments.len(),
            ) {
                match record? {
                    r if r.tick() > tick => break,
                    Record::Keyframe { tick, state } => found = Some((tick, state)),
                    _ => {}
                }
            }
            if found.is_some() {
                return Ok(found);
            }
            end = start;
        }
        Ok(None)
    }

    /// The state hash recorded for `tick`, if any.
    pub fn hash_at(&self, tick: u64) -> Result<Option<u64>, RecordError> {
        for record in self.records_from_tick(tick) {
            match record? {
                r if r.tick() > tick => break,
                Record::TickHash { tick: t, hash } if t == tick => return Ok(Some(hash)),
                _ => {}
            }
        }
        Ok(None)
    }

    /// Every inputs record for ticks `first..=last`, in order. Ticks with
    /// no inputs record are absent.
    pub fn inputs_between(&self, first: u64, last: u64) -> Result<Vec<TickInputs>, RecordError> {
        let mut out = Vec::new();
        if first > last {
            return Ok(out);
        }
        for record in self.records_from_tick(first) {
            match record? {
                r if r.tick() > last => break,
                Record::Inputs { tick, inputs } if tick >= first => out.push((tick, inputs)),
                _ => {}
            }
        }
        Ok(out)
    }

    /// Records from a point at or before the first record of `tick`: a
    /// segment named for `tick` may be preceded by records of the same tick
    /// at the end of the previous segment, so start at the newest segment
    /// named strictly before it.
    fn records_from_tick(&self, tick: u64) -> Records {
        let start = self
            .segments
            .iter()
            .rposition(|s| s.first_tick < tick)
            .unwrap_or(0);
        Records::new(self.segments[start..].to_vec(), true)
    }

    /// Every record that can be trusted, oldest first, reading past damage:
    /// see [`Salvage`].
    pub fn salvage(&self) -> Salvage {
        Salvage {
            segments: self.segments.clone(),
            next: 0,
            current: None,
            done: false,
        }
    }
}

/// An iterator over records across segments, oldest first. Yields
/// `Err` once on damage or an I/O error, then ends.
#[derive(Debug)]
pub struct Records {
    /// Segments still to read, in order.
    segments: std::vec::IntoIter<SegmentFile>,
    /// Whether the last of `segments` is the recording's newest.
    ends_at_newest: bool,
    /// The segment being read: its path, whether it is the newest, and
    /// the reader.
    current: Option<(PathBuf, bool, FrameReader<BufReader<File>>)>,
    /// Set once the iterator has ended or failed.
    done: bool,
}

impl Records {
    fn new(segments: Vec<SegmentFile>, ends_at_newest: bool) -> Self {
        Self {
            segments: segments.into_iter(),
            ends_at_newest,
            current: None,
            done: false,
        }
    }

    /// Opens the next segment; `Ok(false)` when there are none left or the
    /// newest ends inside its header.
    fn open_next(&mut self) -> Result<bool, RecordError> {
        let Some(segment) = self.segments.next() else {
            return Ok(false);
        };
        let newest = self.ends_at_newest && self.segments.len() == 0;
        let path = segment.path;
        let io = |e| RecordError::io(&path, e);
        let file = File::open(&path).map_err(io)?;
        let len = file.metadata().map_err(io)?.len();
        match FrameReader::new(BufReader::new(file), len).map_err(io)? {
            Ok(reader) => {
                self.current = Some((path, newest, reader));
                Ok(true)
            }
            Err(why) if newest && torn_at(&path, 0, why)? => Ok(false),
            Err(why) => Err(RecordError::Corrupt {
                path,
                offset: 0,
                why,
            }),
        }
    }

    fn step(&mut self) -> Result<Option<Record>, RecordError> {
        loop {
            let Some((path, newest, reader)) = &mut self.current else {
                if !self.open_next()? {
                    return Ok(None);
                }
                continue;
            };
            match reader
                .next_frame()
                .map_err(|e| RecordError::io(&*path, e))?
            {
                Framed::Record { record, .. } => return Ok(Some(record)),
                Framed::End => self.current = None,
                Framed::Damaged { offset, why } if *newest && torn_at(path, offset, why)? => {
                    return Ok(None)
                }
                Framed::Damaged { offset, why } => {
                    return Err(RecordError::Corrupt {
                        path: path.clone(),
                        offset,
                        why,
                    })
                }
            }
        }
    }
}

impl Iterator for Records {
    type Item = Result<Record, RecordError>;

    fn next(&mut self) -> Option<Self::Item> {
        // Ends for good at the end or the first error.
        if self.done {
            return None;
        }
        let item = self.step().transpose();
        self.done = !matches!(item, Some(Ok(_)));
        item
    }
}

impl std::iter::FusedIterator for Records {}

/// One step of [`Salvage`].
#[derive(Debug, Clone, PartialEq)]
pub enum Salvaged {
    /// An intact record.
    Record {
        /// Index of its segment in [`RecordReader::segment_files`].
        segment: usize,
        /// Byte offset of its frame in that file.
        offset: u64,
        /// The record.
        record: Record,
    },
    /// Damage: reading goes on at the next intact frame after it in the
    /// same segment (`read_on_at`), or, when none can be found, with the
    /// next segment.
    Damaged {
        /// Where and what.
        damage: SegmentDamage,
        /// Byte offset in the same file where reading went on past the
        /// damage; `None` when the rest of the segment was skipped.
        read_on_at: Option<u64>,
    },
    /// The newest segment ends in a torn tail here (an append cut short by
    /// a crash): the records end cleanly before it.
    TornTail(SegmentDamage),
}

/// Reads a recording as far as it can be trusted: every intact frame of
/// every segment, oldest first. Damage is reported as
/// [`Salvaged::Damaged`] and read past: reading goes on at the next intact
/// frame (a checksum that holds; every tick writes a small record, so one
/// follows soon), or with the next segment when none does (each segment
/// after a directory's first starts at a keyframe, or a session start and
/// its keyframe). Replay starts again at the next keyframe after damage. Yields `Err` once on an I/O error, then ends. Made by
/// [`RecordReader::salvage`].
#[derive(Debug)]
pub struct Salvage {
    segments: Vec<SegmentFile>,
    /// Index of the next segment to open.
    next: usize,
    /// The segment being read: its index and reader.
    current: Option<(usize, FrameReader<BufReader<File>>)>,
    done: bool,
}

impl Salvage {
    /// Stops reading the current segment (its records after the last one
    /// yielded are not trusted: a caller found one that does not decode)
    /// and goes on with the next.
    pub fn skip_rest_of_segment(&mut self) {
        self.current = None;
    }

    fn step(&mut self) -> Result<Option<Salvaged>, RecordError> {
        loop {
            let Some((index, reader)) = &mut self.current else {
                let Some(segment) = self.segments.get(self.next) else {
                    return Ok(None);
                };
                let index = self.next;
                self.next += 1;
                let path = &segment.path;
                let io = |e| RecordError::io(path, e);
                let file = File::open(path).map_err(io)?;
                let len = file.metadata().map_err(io)?.len();
                match FrameReader::new(BufReader::new(file), len).map_err(io)? {
                    Ok(reader) => self.current = Some((index, reader)),
                    Err(why) => return self.damaged(index, 0, why).map(Some),
                }
                continue;
            };
            let index = *index;
            let offset = reader.offset();
            let path = &self.segments[index].path;
            match reader.next_frame().map_err(|e| RecordError::io(path, e))? {
                Framed::Record { record, .. } => {
                    return Ok(Some(Salvaged::Record {
                        segment: index,
                        offset,
                        record,
                    }))
                }
                Framed::End => self.current = None,
                Framed::Damaged { offset, why } => {
                    let torn = index + 1 == self.segments.len() && torn_at(path, offset, why)?;
                    let damage = SegmentDamage {
                        path: path.clone(),
                        offset,
                        why,
                    };
                    if torn {
                        self.current = None;
                        return Ok(Some(Salvaged::TornTail(damage)));
                    }
                    let read_on_at = reader
                        .resync(offset)
                        .map_err(|e| RecordError::io(&damage.path, e))?;
                    if read_on_at.is_none() {
                        self.current = None;
                    }
                    return Ok(Some(Salvaged::Damaged { damage, read_on_at }));
                }
            }
        }
    }

    /// What damage at `offset` of segment `index` is: a torn tail (the
    /// end) or damage to read past.
    fn damaged(
        &mut self,
        index: usize,
        offset: u64,
        why: Corruption,
    ) -> Result<Salvaged, RecordError> {
        let path = self.segments[index].path.clone();
        let newest = index + 1 == self.segments.len();
        let torn = newest && torn_at(&path, offset, why)?;
        let damage = SegmentDamage { path, offset, why };
        Ok(if torn {
            Salvaged::TornTail(damage)
        } else {
            Salvaged::Damaged {
                damage,
                read_on_at: None,
            }
        })
    }
}

impl Iterator for Salvage {
    type Item = Result<Salvaged, RecordError>;

    fn next(&mut self) -> Option<Self::Item> {
        // Ends for good at the end or the first error.
        if self.done {
            return None;
        }
        let item = self.step().transpose();
        self.done = !matches!(item, Some(Ok(_)));
        item
    }
}

impl std::iter::FusedIterator for Salvage {}
