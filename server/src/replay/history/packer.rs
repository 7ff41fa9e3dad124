//! The checkpoint packer: a thread (`inertia-pack`) that zstd-packs each
//! checkpoint against the keyframe before it, so the tick thread only
//! captures the state.

use std::sync::Arc;

use super::Checkpoint;

/// Level of checkpoint packing: zstd's fastest strategy (the packer
/// thread shares the machine with the tick thread).
const CHECKPOINT_LEVEL: i32 = 1;

/// The window and hash table (log2 sizes) a checkpoint is packed with
/// against a keyframe of `keyframe` bytes: the window spans the keyframe
/// and the checkpoint, and the table has a slot for every other position
/// of the keyframe. Level 1's own table (2^13 slots) forgets most of a
/// 1.3 MB keyframe, and a checkpoint packed with it held about twice the
/// bytes that changed (measured on the replay bench's 1000-body scene:
/// 510 kB, against 234 kB with this table, for 3.7 ms of packing instead
/// of 2.4 ms).
fn checkpoint_table(keyframe: usize) -> (u32, u32) {
    let log2 = |n: usize| usize::BITS - n.max(1).leading_zeros();
    let window = log2(2 * keyframe).clamp(20, MAX_WINDOW_LOG);
    let hash = log2(keyframe).saturating_sub(1).clamp(16, 24);
    (window, hash)
}

/// The largest window a checkpoint is packed with (zstd unpacks up to
/// 2^27 without being told more).
const MAX_WINDOW_LOG: u32 = 27;

/// A checkpoint to pack against its keyframe.
pub(super) struct PackJob {
    /// The checkpoint's tick.
    pub(super) tick: u64,
    /// The keyframe it is packed against (tick, entries applied).
    pub(super) base: (u64, u32),
    /// That keyframe's bytes.
    pub(super) dictionary: Arc<Vec<u8>>,
    /// The checkpoint's bytes.
    pub(super) raw: Vec<u8>,
}

/// The checkpoint packer: a thread (`inertia-pack`) that zstd-packs each
/// checkpoint against its keyframe, so the tick thread only captures the
/// state. Packed checkpoints come back through `done` and are taken in on
/// the next tick.
pub(super) struct Packer {
    jobs: Option<std::sync::mpsc::SyncSender<PackJob>>,
    /// Packed checkpoints by tick.
    pub(super) done: std::sync::mpsc::Receiver<(u64, Checkpoint)>,
}

/// Checkpoints waiting to be packed; more are dropped (seeks then start a
/// little further back).
pub const PACK_QUEUE: usize = 16;

/// A compressor that packs checkpoints against `keyframe` (its table is
/// built once, on the first checkpoint); `None` if zstd refuses it.
fn checkpoint_packer(keyframe: &[u8]) -> Option<zstd::bulk::Compressor<'static>> {
    use zstd::zstd_safe::CParameter;
    let (window, hash) = checkpoint_table(keyframe.len());
    let mut c = zstd::bulk::Compressor::with_dictionary(CHECKPOINT_LEVEL, keyframe).ok()?;
    c.set_parameter(CParameter::WindowLog(window)).ok()?;
    c.set_parameter(CParameter::HashLog(hash)).ok()?;
    Some(c)
}

impl Packer {
    pub(super) fn start() -> Packer {
        let (jobs, rx) = std::sync::mpsc::sync_channel::<PackJob>(PACK_QUEUE);
        let (tx, done) = std::sync::mpsc::channel();
        let spawned = std::thread::Builder::new()
            .name("inertia-pack".into())
            .spawn(move || {
                // Background work: not at the tick's priority.
                crate::priority::restore_after_tick();
                let mut prepared: Option<((u64, u32), zstd::bulk::Compressor<'static>)> = None;
                // zstd needs room for the worst case (a little more than
                // the state) to pack into; a checkpoint is most often a
                // tiny fraction of that, so it is copied out exactly sized.
                let mut scratch: Vec<u8> = Vec::new();
                for job in rx {
                    if prepared.as_ref().map(|(k, _)| *k) != Some(job.base) {
                        // The old dictionary goes before the next is made.
                        drop(prepared.take());
                        prepared = checkpoint_packer(&job.dictionary).map(|c| (job.base, c));
                    }
                    drop(job.dictionary);
                    let Some((_, packer)) = &mut prepared else {
                        continue;
                    };
                    scratch.clear();
                    scratch.reserve(zstd::zstd_safe::compress_bound(job.raw.len()));
                    let packed = packer.compress_to_buffer(&job.raw, &mut scratch);
                    if packed.is_ok() {
                        let checkpoint = Checkpoint {
                            base: job.base,
                            len: job.raw.len(),
                            packed: scratch.as_slice().to_vec(),
                        };
                        if tx.send((job.tick, checkpoint)).is_err() {
                            return;
                        }
                    }
                }
            });
        Packer {
            jobs: spawned.ok().map(|_| jobs),
            done,
        }
    }

    /// Hands a job over without waiting; dropped when the queue is full.
    pub(super) fn send(&self, job: PackJob) {
        if let Some(jobs) = &self.jobs {
            let _ = jobs.try_send(job);
        }
    }
}
