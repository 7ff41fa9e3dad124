//! The memory-copy baseline: what "streaming at memory bandwidth" means on
//! the machine at hand, measured in the same process as the step it anchors.
//!
//! A step that must move `T` bytes (reads plus writes) is compared with a
//! plain copy of `T / 2` bytes from one buffer into another, which also moves
//! `T` bytes: `T / 2` read and `T / 2` written. With `threads > 1` the
//! buffers are cut into that many contiguous parts copied in parallel, the
//! same way the step spreads its work, so both sides see the same number of
//! cores pulling on memory.

use std::time::Instant;

use rayon::prelude::*;

/// Source and destination buffers for the copy baseline.
#[derive(Debug)]
pub struct CopyBench {
    src: Vec<u64>,
    dst: Vec<u64>,
    threads: usize,
    pool: Option<rayon::ThreadPool>,
}

impl CopyBench {
    /// Buffers for a copy that moves `traffic_bytes` in all (half read, half
    /// written), split over `threads` workers. Both buffers are written once
    /// here, so no page fault lands in a timed copy.
    pub fn new(traffic_bytes: usize, threads: usize) -> Self {
        let words = (traffic_bytes / 2 / 8).max(1);
        let src: Vec<u64> = (0..words as u64).collect();
        let dst = vec![1u64; words];
        let threads = threads.max(1);
        let pool = (threads > 1).then(|| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .expect("copy thread pool")
        });
        Self {
            src,
            dst,
            threads,
            pool,
        }
    }

    /// Bytes one copy moves, counted like the step's traffic (read + write).
    pub fn counted_bytes(&self) -> usize {
        2 * 8 * self.src.len()
    }

    /// Copies once; returns the wall time, s.
    pub fn run(&mut self) -> f64 {
        let t0 = Instant::now();
        match &self.pool {
            None => self.dst.copy_from_slice(&self.src),
            Some(pool) => {
                let part = self.src.len().div_ceil(self.threads);
                let (src, dst) = (&self.src, &mut self.dst);
                pool.install(|| {
                    dst.par_chunks_mut(part)
                        .zip(src.par_chunks(part))
                        .for_each(|(d, s)| d.copy_from_slice(s));
                });
            }
        }
        std::hint::black_box(&mut self.dst);
        t0.elapsed().as_secs_f64()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn copies_everything_in_parallel_parts() {
        let mut c = CopyBench::new(1 << 20, 2);
        assert_eq!(c.counted_bytes(), 1 << 20);
        assert!(c.run() >= 0.0);
        assert_eq!(c.dst, c.src);
    }
}
