//! [`RecordWriter`]: appends records to the newest segment, starts a new
//! segment at a keyframe once the current one is big enough, repairs a torn
//! tail on open and enforces the retention limit.
//!
//! # Durability
//!
//! `append` only buffers (up to [`WRITE_BUFFER_BYTES`]) and writes to the
//! operating system; nothing is promised to survive a crash until
//! [`RecordWriter::flush`] returns, which writes out the buffer and calls
//! `sync_data` on the segment (and syncs the directory when a segment was
//! created or removed since the last flush). A segment is also synced before
//! the next one is started, so only the newest segment can ever end in a
//! torn write. Dropping the writer writes the buffer out without syncing.
//!
//! # Opening after a crash
//!
//! [`RecordWriter::open`] reads the newest segment through. What it finds
//! at its end decides what happens:
//!
//! - **a torn tail**: the last frame is cut short by the end of the file
//!   (its header or its payload runs past it) with nothing intact after
//!   it — what an interrupted append leaves. Those bytes are first written
//!   to `<segment file name>.torn-<offset>` beside it and synced, then the
//!   segment is cut at `offset`, the end of the last intact record
//!   ([`TailCut`]). A newest segment left with no record is removed (it
//!   held a header only).
//! - **damage**: anything else — a checksum that fails, an impossible
//!   header, a frame of unknown kind, a length that runs past the end with
//!   intact records after it. Nothing is cut or skipped: the segment stays
//!   exactly as it is, the damage is reported
//!   ([`OpenReport::damaged`]), and the next append starts a new segment
//!   rather than writing after the damage.
//!
//! Older segments are not read on open; damage there is the readers' to
//! report.
//!
//! One writer per directory: nothing stops a second process from opening
//! the same directory, and two writers would interleave frames.

use std::fs::{self, File, OpenOptions};
use std::io::{BufWriter, Seek, SeekFrom, Write};
use std::path::{Path, PathBuf};

use super::codec::Record;
use super::error::{Corruption, RecordError, SegmentDamage};
use super::frame::{encode_frame, segment_header, HEADER_BYTES};
use super::segment::{list_segments, read_tail, scan_segment, segment_file_name, SegmentFile};

/// Bytes `append` buffers before writing to the operating system.
pub const WRITE_BUFFER_BYTES: usize = 256 * 1024;

/// Default segment size at which the next keyframe starts a new segment,
/// bytes (64 MiB: a few seconds of keyframes for a large world, a few
/// hundred files for a multi-gigabyte retention limit).
pub const DEFAULT_SEGMENT_BYTES: u64 = 64 * 1024 * 1024;

/// How a [`RecordWriter`] lays out its segments.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RecordOptions {
    /// Once the current segment holds at least this many bytes, the next
    /// keyframe starts a new segment, bytes. Segments only ever start at a
    /// keyframe (except a directory's very first), so one may grow past
    /// this while no keyframe comes.
    pub segment_bytes: u64,
}

impl Default for RecordOptions {
    fn default() -> Self {
        Self {
            segment_bytes: DEFAULT_SEGMENT_BYTES,
        }
    }
}

/// Where open cut a torn tail off the newest segment, and where the bytes
/// cut were kept.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TailCut {
    /// The segment cut.
    pub path: PathBuf,
    /// The new file length: the end of the last intact record, bytes.
    pub offset: u64,
    /// Bytes removed from the end of the file.
    pub bytes_cut: u64,
    /// What was wrong at `offset` (a frame cut short).
    pub why: Corruption,
    /// The file, beside the segment, that holds exactly the bytes cut
    /// (`<segment file name>.torn-<offset>`), written and synced before
    /// the cut.
    pub kept_at: PathBuf,
}

/// What [`RecordWriter::open`] found and repaired.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub struct OpenReport {
    /// Segments in the directory after repair.
    pub segments: usize,
    /// Tick of the last intact record; the next append must not be before
    /// it. `None` for an empty recording.
    pub last_tick: Option<u64>,
    /// Records kept in the segment appended to (0 when appending starts a
    /// new one).
    pub records_in_newest: u64,
    /// The torn tail cut off the newest segment, if there was one.
    pub cut: Option<TailCut>,
    /// The newest segment's damage, if it is damaged: the segment is left
    /// as it is and the next append starts a new segment.
    pub damaged: Option<SegmentDamage>,
    /// Newest segments that held no intact record (a crash right after
    /// starting them) and were removed (their torn bytes kept aside, see
    /// `cut`).
    pub removed: Vec<PathBuf>,
}

impl OpenReport {
    /// Bytes of torn tail cut off, 0 when the recording was intact.
    pub fn bytes_cut(&self) -> u64 {
        self.cut.as_ref().map_or(0, |c| c.bytes_cut)
    }
}

/// The segment being appended to.
#[derive(Debug)]
struct Current {
    path: PathBuf,
    first_tick: u64,
    file: BufWriter<File>,
    /// Bytes written, buffered ones included.
    len: u64,
}

/// Appends records to a recording directory. See the module docs for
/// durability.
#[derive(Debug)]
pub struct RecordWriter {
    dir: PathBuf,
    options: RecordOptions,
    /// Every segment, oldest first; the last is `current`'s.
    segments: Vec<SegmentFile>,
    current: Option<Current>,
    last_tick: Option<u64>,
    /// A segment was created or removed since the directory was last synced.
    dir_dirty: bool,
    /// An earlier write or sync failed.
    poisoned: bool,
    /// The newest segment is damaged (left alone): its first tick, which a
    /// new segment cannot take.
    damaged_first_tick: Option<u64>,
    /// Reused frame buffer.
    scratch: Vec<u8>,
    /// What open found.
    report: OpenReport,
}

impl RecordWriter {
    /// Opens (creating it if needed) the recording directory `dir` and
    /// repairs a torn tail of the newest segment, keeping the bytes cut
    /// aside; a newest segment that is damaged instead is left as it is and
    /// appending goes on in a new segment (see the module docs). Errors only
    /// when the file system refuses.
    pub fn open(dir: impl AsRef<Path>, options: RecordOptions) -> Result<Self, RecordError> {
        let dir = dir.as_ref().to_path_buf();
        fs::create_dir_all(&dir).map_err(|e| RecordError::io(&dir, e))?;
        let mut segments = list_segments(&dir)?;
        let mut report = OpenReport::default();
        let mut newest = true;
        let mut current = None;
        let mut last_tick = None;
        let mut damaged_first_tick = None;
        let mut dir_dirty = false;
        while let Some(last) = segments.last_mut() {
            let path = last.path.clone();
            let io = |e| RecordError::io(&path, e);
            let scan = scan_segment(&path)?;
            let mut len = scan.file_len;
            if let Some((offset, why)) = scan.damage {
                if !(newest && scan.torn_tail) {
                    // Left exactly as it is; appending starts a new segment,
                    // which must sort after this one and not go back past
                    // its last intact record.
                    last.bytes = scan.file_len;
                    last_tick = Some(
                        scan.last_tick
                            .map_or(last.first_tick, |t| t.max(last.first_tick)),
                    );
                    damaged_first_tick = Some(last.first_tick);
                    report.damaged = Some(SegmentDamage { path, offset, why });
                    break;
                }
                report.cut = Some(cut_torn_tail(&dir, &path, offset, why)?);
                len = offset;
            }
            newest = false;
            if scan.records == 0 {
                // A header at most is left: nothing of the recording.
                fs::remove_file(&path).map_err(io)?;
                dir_dirty = true;
                report.removed.push(path);
                segments.pop();
                continue;
            }
            let mut file = OpenOptions::new().write(true).open(&path).map_err(io)?;
            file.seek(SeekFrom::End(0)).map_err(io)?;
            last.bytes = len;
            last_tick = scan.last_tick;
            report.records_in_newest = scan.records;
            current = Some(Current {
                first_tick: last.first_tick,
                path,
                file: BufWriter::with_capacity(WRITE_BUFFER_BYTES, file),
                len,
            });
            break;
        }
        report.segments = segments.len();
        report.last_tick = last_tick;
        Ok(Self {
            dir,
            options,
            segments,
            current,
            last_tick,
            dir_dirty,
            poisoned: false,
            damaged_first_tick,
            scratch: Vec::new(),
            report,
        })
    }

    /// Whether a record for `tick` can be appended: it is not before the
    /// last tick recorded, and when the newest segment is damaged (so the
    /// next append starts a new segment) it is after that segment's first
    /// tick, whose name the new segment would otherwise take.
    pub fn can_append_at(&self, tick: u64) -> bool {
        self.last_tick.is_none_or(|last| tick >= last) && !self.damaged_segment_in_the_way(tick)
    }

    /// Whether appending `tick` would start a new segment named like the
    /// damaged newest one (which starts at `tick`).
    fn damaged_segment_in_the_way(&self, tick: u64) -> bool {
        self.current.is_none() && self.damaged_first_tick == Some(tick)
    }

    /// What [`open`](Self::open) found and repaired: log it (a cut tail
    /// was kept aside; a damaged newest segment was left alone).
    pub fn open_report(&self) -> &OpenReport {
        &self.report
    }

    /// The recording directory.
    pub fn dir(&self) -> &Path {
        &self.dir
    }

    /// Tick of the newest record written, `None` before the first.
    pub fn last_tick(&self) -> Option<u64> {
        self.last_tick
    }

    /// Every segment, oldest first; the last is the one being appended to.
    pub fn segments(&self) -> &[SegmentFile] {
        &self.segments
    }

    /// Total size of all segments, bytes (buffered bytes included).
    pub fn total_bytes(&self) -> u64 {
        self.segments.iter().map(|s| s.bytes).sum()
    }

    /// Appends `record` (buffered; see [`flush`](Self::flush)). A keyframe
    /// starts a new segment when the current one holds at least
    /// [`RecordOptions::segment_bytes`]; the old segment is synced first.
    ///
    /// Refuses, writing nothing, a record over
    /// [`MAX_RECORD_BYTES`](super::MAX_RECORD_BYTES) or for a tick before
    /// the last one. After an I/O error the writer is poisoned.
    pub fn append(&mut self, record: &Record) -> Result<(), RecordError> {
        if self.poisoned {
            return Err(RecordError::Poisoned);
        }
        let tick = record.tick();
        if let Some(last) = self.last_tick {
            if tick < last {
                return Err(RecordError::TickBackwards { last, got: tick });
            }
        }
        if self.damaged_segment_in_the_way(tick) {
            let path = self
                .segments
                .last()
                .map(|s| s.path.clone())
                .unwrap_or_default();
            return Err(RecordError::DamagedSegmentInTheWay { path, tick });
        }
        let mut frame = std::mem::take(&mut self.scratch);
        let result = encode_frame(record, &mut frame).and_then(|()| {
            let roll = match &self.current {
                None => true,
                Some(current) => {
                    matches!(record, Record::Keyframe { .. })
                        && current.len >= self.options.segment_bytes
                        && tick > current.first_tick
                }
            };
            self.guard(|w| {
                if roll {
                    w.start_segment(tick)?;
                }
                w.write_frame(&frame)
            })
        });
        self.scratch = frame;
        result?;
        self.last_tick = Some(tick);
        Ok(())
    }

    /// Writes out everything appended and syncs it to disk (`sync_data`;
    /// the directory too when segments were created or removed). When this
    /// returns `Ok`, every record appended so far survives a crash.
    pub fn flush(&mut self) -> Result<(), RecordError> {
        if self.poisoned {
            return Err(RecordError::Poisoned);
        }
        self.guard(|w| {
            if let Some(current) = &mut w.current {
                sync(current)?;
            }
            if w.dir_dirty {
                sync_dir(&w.dir)?;
                w.dir_dirty = false;
            }
            Ok(())
        })
    }

    /// Deletes whole segments, oldest first, until all of them together
    /// take at most `max_bytes` — but never the segment being written, so
    /// the total can stay above the limit. Returns the segments removed.
    /// Since every segment after the first starts with a keyframe, what
    /// remains can still be replayed from its start.
    pub fn enforce_retention(&mut self, max_bytes: u64) -> Result<Vec<SegmentFile>, RecordError> {
        let mut total = self.total_bytes();
        let mut removed = Vec::new();
        while total > max_bytes && self.segments.len() > 1 {
            let oldest = self.segments.remove(0);
            match fs::remove_file(&oldest.path) {
                Ok(()) => {}
                Err(e) if e.kind() == std::io::ErrorKind::NotFound => {}
                Err(e) => {
                    let err = RecordError::io(&oldest.path, e);
                    self.segments.insert(0, oldest);
                    return Err(err);
                }
            }
            self.dir_dirty = true;
            total -= oldest.bytes;
            removed.push(oldest);
        }
        Ok(removed)
    }

    /// Runs `f`, poisoning the writer if it fails: a failed write may have
    /// left part of a frame in the file.
    fn guard(
        &mut self,
        f: impl FnOnce(&mut Self) -> Result<(), RecordError>,
    ) -> Result<(), RecordError> {
        let result = f(self);
        if result.is_err() {
            self.poisoned = true;
        }
        result
    }

    /// Syncs the current segment and starts `segment-<first_tick>.irec`.
    fn start_segment(&mut self, first_tick: u64) -> Result<(), RecordError> {
        if let Some(current) = &mut self.current {
            sync(current)?;
        }
        let path = self.dir.join(segment_file_name(first_tick));
        let io = |e| RecordError::io(&path, e);
        let file = OpenOptions::new()
            .write(true)
            .create_new(true)
            .open(&path)
            .map_err(io)?;
        let mut file = BufWriter::with_capacity(WRITE_BUFFER_BYTES, file);
        file.write_all(&segment_header()).map_err(io)?;
        self.dir_dirty = true;
        self.segments.push(SegmentFile {
            path: path.clone(),
            first_tick,
            bytes: HEADER_BYTES,
        });
        self.current = Some(Current {
            path,
            first_tick,
            file,
            len: HEADER_BYTES,
        });
        Ok(())
    }

    fn write_frame(&mut self, frame: &[u8]) -> Result<(), RecordError> {
        // `append` starts a segment first when there is none, so this
        // refusal is unreachable; it beats a panic or a lost record.
        let (Some(current), Some(entry)) = (&mut self.current, self.segments.last_mut()) else {
            return Err(RecordError::Poisoned);
        };
        current
            .file
            .write_all(frame)
            .map_err(|e| RecordError::io(&current.path, e))?;
        current.len += frame.len() as u64;
        entry.bytes = current.len;
        Ok(())
    }
}

/// Cuts the torn tail of the segment at `path` at `offset`, first writing
/// the bytes cut to `<segment file name>.torn-<offset>` beside it (a
/// numbered name if that is taken) and syncing that file and the
/// directory.
fn cut_torn_tail(
    dir: &Path,
    path: &Path,
    offset: u64,
    why: Corruption,
) -> Result<TailCut, RecordError> {
    // The scan found a frame cut short: at most one frame's bytes.
    let tail = read_tail(path, offset)?.ok_or_else(|| {
        RecordError::io(
            path,
            std::io::Error::other("a torn tail longer than one record"),
        )
    })?;
    let kept_at = keep_aside(path, offset, &tail)?;
    sync_dir(dir)?;
    let io = |e| RecordError::io(path, e);
    let file = OpenOptions::new().write(true).open(path).map_err(io)?;
    file.set_len(offset).map_err(io)?;
    file.sync_data().map_err(io)?;
    Ok(TailCut {
        path: path.to_path_buf(),
        offset,
        bytes_cut: tail.len() as u64,
        why,
        kept_at,
    })
}

/// Writes `bytes` to a new file `<path>.torn-<offset>` (or
/// `<path>.torn-<offset>.<n>` if taken) and syncs it; returns its path.
fn keep_aside(path: &Path, offset: u64, bytes: &[u8]) -> Result<PathBuf, RecordError> {
    for n in 0..1000u32 {
        let mut name = path.as_os_str().to_owned();
        name.push(format!(".torn-{offset}"));
        if n > 0 {
            name.push(format!(".{n}"));
        }
        let aside = PathBuf::from(name);
        let io = |e| RecordError::io(&aside, e);
        let mut file = match OpenOptions::new().write(true).create_new(true).open(&aside) {
            Ok(file) => file,
            Err(e) if e.kind() == std::io::ErrorKind::AlreadyExists => continue,
            Err(e) => return Err(io(e)),
        };
        file.write_all(bytes).map_err(io)?;
        file.sync_all().map_err(io)?;
        return Ok(aside);
    }
    Err(RecordError::io(
        path,
        std::io::Error::other("no free name to keep a torn tail aside"),
    ))
}

/// Writes out the buffer and syncs the segment's data.
fn sync(current: &mut Current) -> Result<(), RecordError> {
    let io = |e| RecordError::io(&current.path, e);
    current.file.flush().map_err(io)?;
    current.file.get_ref().sync_data().map_err(io)
}

/// Makes file creations and removals in `dir` durable (POSIX needs the
/// directory itself synced; elsewhere this is a no-op).
fn sync_dir(dir: &Path) -> Result<(), RecordError> {
    #[cfg(unix)]
    {
        File::open(dir)
            .and_then(|d| d.sync_all())
            .map_err(|e| RecordError::io(dir, e))?;
    }
    #[cfg(not(unix))]
    let _ = dir;
    Ok(())
}
