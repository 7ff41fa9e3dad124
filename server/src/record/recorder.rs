//! The live session's recorder: a [`RecordWriter`] on its own thread
//! (`inertia-record`), fed by a bounded channel.
//!
//! The tick thread never touches the disk. After each tick it hands the
//! recorder the tick's records ([`Recorder::send`]); sending never blocks:
//! when the channel is full the record is dropped and counted
//! ([`RecorderStats::dropped`], the `record_dropped` metric). A recording
//! with a hole in it cannot be replayed, so the simulation stops recording
//! at the first drop (and says so in the log); `record on` starts a fresh
//! session with a keyframe.
//!
//! The recorder thread appends what arrives, flushes (`sync_data`) at
//! least once every [`FLUSH_INTERVAL`] while it has unflushed records —
//! so a crash loses at most about a second — and after each flush deletes
//! the oldest whole segments beyond the retention limit. A write error
//! stops the recording (logged, counted in [`RecorderStats::failed`]);
//! later records are discarded.

use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, SyncSender, TrySendError};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use tokio::sync::oneshot;
use tracing::{error, info, warn};

use super::{Record, RecordError, RecordOptions, RecordWriter};
use crate::metrics::Metrics;

/// Longest time an appended record waits before it is synced to disk.
pub const FLUSH_INTERVAL: Duration = Duration::from_secs(1);
/// Default keyframe interval, ticks (15 s at 60 Hz). Seeks start from
/// the in-memory checkpoints between keyframes, so keyframes on disk can
/// be sparse: they serve `--resume` (at most this many ticks to
/// re-simulate) and seeks past the memory budget.
pub const DEFAULT_KEYFRAME_TICKS: u64 = 900;
/// Default retention limit, bytes (2 GiB).
pub const DEFAULT_RECORD_MAX_BYTES: u64 = 2 * 1024 * 1024 * 1024;
/// Default capacity of the recorder's channel, records (a few seconds of
/// 60 Hz ticks at three records a tick).
pub const DEFAULT_CHANNEL_CAPACITY: usize = 1024;

/// How a recorder records.
#[derive(Debug, Clone, PartialEq)]
pub struct RecorderConfig {
    /// The recording directory.
    pub dir: PathBuf,
    /// A keyframe every this many ticks (≥ 1).
    pub keyframe_ticks: u64,
    /// Retention limit: oldest whole segments are deleted beyond it, bytes.
    pub max_bytes: u64,
    /// Capacity of the channel from the tick thread, records.
    pub capacity: usize,
    /// Segment size at which a keyframe starts a new segment, bytes.
    pub segment_bytes: u64,
}

impl RecorderConfig {
    /// Defaults for recording into `dir`.
    pub fn new(dir: impl Into<PathBuf>) -> Self {
        RecorderConfig {
            dir: dir.into(),
            keyframe_ticks: DEFAULT_KEYFRAME_TICKS,
            max_bytes: DEFAULT_RECORD_MAX_BYTES,
            capacity: DEFAULT_CHANNEL_CAPACITY,
            segment_bytes: RecordOptions::default().segment_bytes,
        }
    }
}

/// Counters shared with the recorder thread.
#[derive(Debug, Default)]
pub struct RecorderStats {
    /// Records handed to the thread.
    pub sent: AtomicU64,
    /// Records dropped because the channel was full.
    pub dropped: AtomicU64,
    /// Records appended.
    pub appended: AtomicU64,
    /// Flushes done.
    pub flushes: AtomicU64,
    /// Segments deleted by retention.
    pub segments_removed: AtomicU64,
    /// A write failed; the recording stopped.
    pub failed: AtomicBool,
}

enum Msg {
    Record(Record),
    Flush(oneshot::Sender<Result<(), String>>),
}

/// Why a record was not handed over.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum SendError {
    /// The channel is full: the record was dropped (and counted).
    #[error("the recorder is behind; record dropped")]
    Full,
    /// The recorder thread has stopped (a write failed).
    #[error("the recorder has stopped")]
    Stopped,
}

/// The tick thread's handle on a recorder thread. Dropping it lets the
/// thread write out and sync what it has, then end (without waiting for
/// it); [`Recorder::finish`] waits.
#[derive(Debug)]
pub struct Recorder {
    tx: Option<SyncSender<Msg>>,
    thread: Option<JoinHandle<()>>,
    stats: Arc<RecorderStats>,
    config: RecorderConfig,
    metrics: Option<Metrics>,
    moved_aside: Option<PathBuf>,
}

impl Recorder {
    /// Opens the recording directory (cutting a torn tail, kept aside, and
    /// logging it; a damaged newest segment is left alone and logged, and
    /// recording goes on in a new segment) and starts the recorder thread.
    /// `first_tick` is the tick the session starts at: a recording already
    /// there that cannot be continued at it — its ticks run past it (an
    /// earlier run of the server), or its newest segment is damaged and
    /// starts at it — is moved aside, to `<dir>.<unix seconds>`, so ticks
    /// never go backwards in a directory.
    pub fn start(
        config: RecorderConfig,
        first_tick: u64,
        metrics: Option<Metrics>,
    ) -> Result<Recorder, RecordError> {
        let options = RecordOptions {
            segment_bytes: config.segment_bytes,
        };
        let mut writer = RecordWriter::open(&config.dir, options.clone())?;
        log_open(&config.dir, &writer);
        let mut moved_aside = None;
        if !writer.can_append_at(first_tick) {
            drop(writer);
            let aside = aside_name(&config.dir);
            warn!(
                dir = %config.dir.display(),
                moved_to = %aside.display(),
                "the recording there cannot go on at this session's first tick (it runs past it, \
                 or its newest segment is damaged and starts there); moving it aside"
            );
            std::fs::rename(&config.dir, &aside).map_err(|e| RecordError::io(&config.dir, e))?;
            writer = RecordWriter::open(&config.dir, options)?;
            moved_aside = Some(aside);
        }
        let (tx, rx) = mpsc::sync_channel(config.capacity.max(1));
        let stats = Arc::new(RecorderStats::default());
        let thread = {
            let stats = stats.clone();
            let max_bytes = config.max_bytes;
            std::thread::Builder::new()
                .name("inertia-record".into())
                .spawn(move || run(writer, rx, stats, max_bytes))
                .map_err(|e| RecordError::io(&config.dir, e))?
        };
        info!(dir = %config.dir.display(), first_tick, "recording");
        Ok(Recorder {
            tx: Some(tx),
            thread: Some(thread),
            stats,
            config,
            metrics,
            moved_aside,
        })
    }

    /// Where the recording found in the directory was moved aside when it
    /// could not be continued ([`Recorder::start`]); this session then
    /// starts an empty one.
    pub fn moved_aside(&self) -> Option<&Path> {
        self.moved_aside.as_deref()
    }

    /// The configuration it records with.
    pub fn config(&self) -> &RecorderConfig {
        &self.config
    }

    /// The recording directory.
    pub fn dir(&self) -> &Path {
        &self.config.dir
    }

    /// The shared counters.
    pub fn stats(&self) -> Arc<RecorderStats> {
        self.stats.clone()
    }

    /// Whether the thread has stopped on a write error.
    pub fn failed(&self) -> bool {
        self.stats.failed.load(Ordering::Relaxed)
    }

    /// Hands `record` to the thread without blocking; a full channel drops
    /// it, counted.
    pub fn send(&self, record: Record) -> Result<(), SendError> {
        let Some(tx) = &self.tx else {
            return Err(SendError::Stopped);
        };
        match tx.try_send(Msg::Record(record)) {
            Ok(()) => {
                self.stats.sent.fetch_add(1, Ordering::Relaxed);
                Ok(())
            }
            Err(TrySendError::Full(_)) => {
                self.stats.dropped.fetch_add(1, Ordering::Relaxed);
                if let Some(m) = &self.metrics {
                    m.record_dropped.inc();
                }
                Err(SendError::Full)
            }
            Err(TrySendError::Disconnected(_)) => Err(SendError::Stopped),
        }
    }

    /// Asks the thread to write out and sync everything sent so far; the
    /// answer arrives on the receiver once it has. Never blocks.
    pub fn request_flush(&self) -> Result<oneshot::Receiver<Result<(), String>>, SendError> {
        let Some(tx) = &self.tx else {
            return Err(SendError::Stopped);
        };
        let (reply, rx) = oneshot::channel();
        match tx.try_send(Msg::Flush(reply)) {
            Ok(()) => Ok(rx),
            Err(TrySendError::Full(_)) => Err(SendError::Full),
            Err(TrySendError::Disconnected(_)) => Err(SendError::Stopped),
        }
    }

    /// Sends `last` (waiting for room: this is the end of the session),
    /// then lets the thread write out, sync and stop, and waits for it.
    pub fn finish(mut self, last: Option<Record>) {
        if let Some(tx) = self.tx.take() {
            if let Some(record) = last {
                let _ = tx.send(Msg::Record(record));
            }
        }
        self.join();
    }

    /// Waits for the thread (after the handle's sender is gone).
    fn join(&mut self) {
        self.tx = None;
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }

    /// Lets go of the channel: the thread writes out and syncs what it
    /// has, then ends (nothing more can be sent).
    pub fn close(&mut self) {
        self.tx = None;
    }

    /// Stops sending and waits for the thread to write out what it has.
    pub fn stop(mut self) {
        self.join();
    }
}

/// Logs what opening the recording found: a torn tail cut (and where its
/// bytes were kept), a damaged newest segment left alone.
pub(crate) fn log_open(dir: &Path, writer: &RecordWriter) {
    let report = writer.open_report();
    if let Some(cut) = &report.cut {
        warn!(
            dir = %dir.display(),
            file = %cut.path.display(),
            offset = cut.offset,
            bytes_cut = cut.bytes_cut,
            kept_at = %cut.kept_at.display(),
            "cut a torn tail off the recording; its bytes are kept aside"
        );
    }
    if let Some(damage) = &report.damaged {
        warn!(
            dir = %dir.display(),
            file = %damage.path.display(),
            offset = damage.offset,
            why = %damage.why,
            "the newest segment is damaged; left as it is, recording goes on in a new segment"
        );
    }
}

fn aside_name(dir: &Path) -> PathBuf {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let mut name = dir.as_os_str().to_owned();
    name.push(format!(".{secs}"));
    let mut path = PathBuf::from(name);
    let mut n = 1;
    while path.exists() {
        let mut name = dir.as_os_str().to_owned();
        name.push(format!(".{secs}-{n}"));
        path = PathBuf::from(name);
        n += 1;
    }
    path
}

fn run(mut writer: RecordWriter, rx: Receiver<Msg>, stats: Arc<RecorderStats>, max_bytes: u64) {
    let mut dirty_since: Option<Instant> = None;
    let mut broken = false;
    let dir = writer.dir().to_path_buf();
    let fail = |stats: &RecorderStats, e: &RecordError, broken: &mut bool| {
        if !*broken {
            error!(error = %e, dir = %dir.display(), "recording failed; it stops here");
            stats.failed.store(true, Ordering::Relaxed);
            *broken = true;
        }
    };
    let flush = |writer: &mut RecordWriter, broken: &mut bool| -> Result<(), String> {
        if *broken {
            return Err("the recording stopped after a write error".into());
        }
        let r = writer.flush().and_then(|()| {
            let removed = writer.enforce_retention(max_bytes)?;
            if !removed.is_empty() {
                stats
                    .segments_removed
                    .fetch_add(removed.len() as u64, Ordering::Relaxed);
                writer.flush()?;
            }
            Ok(())
        });
        stats.flushes.fetch_add(1, Ordering::Relaxed);
        r.map_err(|e| {
            fail(&stats, &e, broken);
            e.to_string()
        })
    };
    loop {
        let wait = match dirty_since {
            Some(t) => FLUSH_INTERVAL.saturating_sub(t.elapsed()),
            None => Duration::from_secs(3600),
        };
        match rx.recv_timeout(wait) {
            Ok(Msg::Record(record)) => {
                if broken {
                    continue;
                }
                // Keyframes are most of the bytes: packed here, off the
                // tick thread.
                let record = match record {
                    Record::Keyframe { tick, state } if !super::compress::is_packed(&state) => {
                        Record::Keyframe {
                            tick,
                            state: super::compress::pack(&state),
                        }
                    }
                    r => r,
                };
                match writer.append(&record) {
                    Ok(()) => {
                        stats.appended.fetch_add(1, Ordering::Relaxed);
                        dirty_since.get_or_insert_with(Instant::now);
                    }
                    Err(e) => fail(&stats, &e, &mut broken),
                }
            }
            Ok(Msg::Flush(reply)) => {
                let r = flush(&mut writer, &mut broken);
                dirty_since = None;
                let _ = reply.send(r);
            }
            Err(RecvTimeoutError::Timeout) => {}
            Err(RecvTimeoutError::Disconnected) => {
                if dirty_since.is_some() {
                    let _ = flush(&mut writer, &mut broken);
                }
                return;
            }
        }
        if dirty_since.is_some_and(|t| t.elapsed() >= FLUSH_INTERVAL) {
            let _ = flush(&mut writer, &mut broken);
            dirty_since = None;
        }
    }
}
