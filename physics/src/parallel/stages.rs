//! Stages of parallel work, one after another, in one hand-off to the
//! threads.
//!
//! A coloured solver runs a short stage per colour, and each stage must
//! finish before the next one starts: a 128² cloth has 21 colours a
//! substep, of 60 µs or less on two threads. As separate parallel loops,
//! each stage would be handed to the pool and waited for on its own. Here
//! the whole sequence is one hand-off:
//!
//! - the stages' blocks are numbered in order, and every thread takes the
//!   next one from one shared counter;
//! - before it runs a block, a thread waits until every block of the
//!   stages before it is done;
//! - one more shared counter holds how many blocks are done. Since no
//!   block can finish before the stages before it have, the count reaches
//!   the first block of a stage exactly when the stages before it are
//!   done.
//!
//! A thread waits only on blocks that running threads have taken, never on
//! a thread that has not started: one thread alone runs every block, and a
//! helper that starts late finds nothing left. Which thread runs a block
//! never changes what the block computes, so the result is the same on any
//! number of threads. Box2D v3's solver synchronises its stages the same
//! way (blocks taken and stages counted with atomics: `solver.c`,
//! `b2ExecuteMainStage`).

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

/// Spins before a waiting thread starts to yield its core.
const SPINS_BEFORE_YIELD: u32 = 256;

/// Runs `run(stage, block)` for every block of every stage, `blocks[s]`
/// blocks in stage `s`: the blocks of one stage in parallel, in any
/// order; a stage only once every block of the stages before it has
/// finished (each block's writes are then visible to the next stage).
pub(crate) fn for_each_stage_block<F>(blocks: &[usize], run: F)
where
    F: Fn(usize, usize) + Sync,
{
    let total: usize = blocks.iter().sum();
    // No stage of two blocks: nothing to share (a rope, a small cloth).
    let alone = blocks.iter().all(|&n| n <= 1);
    if alone || super::inline() || rayon::current_num_threads() <= 1 {
        for (s, &n) in blocks.iter().enumerate() {
            for b in 0..n {
                run(s, b);
            }
        }
        return;
    }
    let shared = Shared {
        blocks,
        total,
        next: AtomicUsize::new(0),
        done: AtomicUsize::new(0),
        abandoned: AtomicBool::new(false),
    };
    let helpers = (rayon::current_num_threads() - 1).min(total - 1);
    rayon::scope(|scope| {
        for _ in 0..helpers {
            scope.spawn(|_| shared.work(&run));
        }
        shared.work(&run);
    });
}

/// What the threads of one call share.
struct Shared<'a> {
    /// Blocks per stage.
    blocks: &'a [usize],
    /// Blocks in all.
    total: usize,
    /// The next block to take (numbered over all stages).
    next: AtomicUsize,
    /// Blocks finished.
    done: AtomicUsize,
    /// Set when a block panicked: the others stop waiting for it.
    abandoned: AtomicBool,
}

impl Shared<'_> {
    /// Takes and runs blocks until none is left.
    fn work(&self, run: &(impl Fn(usize, usize) + Sync)) {
        // The stage of the last block taken and the block its stage starts
        // at: a thread's blocks only go up, so the stage is found by
        // walking on.
        let (mut stage, mut first) = (0usize, 0usize);
        loop {
            let k = self.next.fetch_add(1, Ordering::Relaxed);
            if k >= self.total {
                return;
            }
            while k >= first + self.blocks[stage] {
                first += self.blocks[stage];
                stage += 1;
            }
            if !self.wait_for(first) {
                return;
            }
            let guard = Abandon(&self.abandoned);
            run(stage, k - first);
            std::mem::forget(guard);
            // Release: the block's writes reach whoever sees the count.
            self.done.fetch_add(1, Ordering::Release);
        }
    }

    /// Waits until `count` blocks are done; false if a block panicked.
    fn wait_for(&self, count: usize) -> bool {
        let mut spins = 0u32;
        // Acquire: the finished blocks' writes are seen from here on.
        while self.done.load(Ordering::Acquire) < count {
            if self.abandoned.load(Ordering::Relaxed) {
                return false;
            }
            if spins < SPINS_BEFORE_YIELD {
                spins += 1;
                std::hint::spin_loop();
            } else {
                std::thread::yield_now();
            }
        }
        true
    }
}

/// Marks the call abandoned if a block unwinds, so that no thread waits
/// for it forever (the panic then reaches the caller through the scope).
struct Abandon<'a>(&'a AtomicBool);

impl Drop for Abandon<'_> {
    fn drop(&mut self) {
        self.0.store(true, Ordering::Relaxed);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::atomic::AtomicU64;

    fn pool(threads: usize) -> rayon::ThreadPool {
        rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .expect("pool")
    }

    /// Each block writes one more than the sum of the stage before's
    /// blocks: a block run before its stage's turn would read a sum not
    /// yet complete.
    fn sums(threads: usize) -> Vec<Vec<u64>> {
        let blocks = [3usize, 1, 7, 2, 0, 5];
        let cells: Vec<Vec<AtomicU64>> = blocks
            .iter()
            .map(|&n| (0..n).map(|_| AtomicU64::new(0)).collect())
            .collect();
        let runs = AtomicUsize::new(0);
        pool(threads).install(|| {
            for_each_stage_block(&blocks, |s, b| {
                let before: u64 = match s.checked_sub(1) {
                    Some(p) => cells[p].iter().map(|c| c.load(Ordering::Relaxed)).sum(),
                    None => 0,
                };
                // An empty stage passes the sum on.
                let before = if s >= 2 && blocks[s - 1] == 0 {
                    cells[s - 2].iter().map(|c| c.load(Ordering::Relaxed)).sum()
                } else {
                    before
                };
                cells[s][b].store(before + 1 + b as u64, Ordering::Relaxed);
                runs.fetch_add(1, Ordering::Relaxed);
            });
        });
        assert_eq!(runs.into_inner(), blocks.iter().sum::<usize>());
        cells
            .iter()
            .map(|s| s.iter().map(|c| c.load(Ordering::Relaxed)).collect())
            .collect()
    }

    #[test]
    fn every_block_runs_once_after_the_stages_before_it() {
        let one = sums(1);
        assert_eq!(one[0], vec![1, 2, 3]);
        assert_eq!(one[1], vec![7]);
        assert_eq!(one[2][6], 8 + 6);
        for threads in [2, 3, 8] {
            for _ in 0..20 {
                assert_eq!(sums(threads), one, "{threads} threads");
            }
        }
    }

    #[test]
    fn a_panicking_block_reaches_the_caller_instead_of_hanging() {
        let r = std::panic::catch_unwind(|| {
            pool(2).install(|| {
                for_each_stage_block(&[4, 4], |s, b| {
                    if s == 0 && b == 1 {
                        panic!("block failed");
                    }
                });
            })
        });
        assert!(r.is_err());
    }
}
