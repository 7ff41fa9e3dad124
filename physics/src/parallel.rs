//! Deterministic data parallelism.
//!
//! Work is cut into chunks of a fixed size ([`CHUNK`] particles) that does not
//! depend on the number of threads; every chunk's result lands in its own slot
//! and reductions add the slots in chunk order. So a run on one thread and a
//! run on any number of threads produce the same bits. Small inputs (one
//! chunk) run inline, without touching the thread pool, and so does all work
//! inside [`sequential`] (a world configured for one thread), which then
//! costs no hand-off to a worker thread at all.

use std::cell::Cell;

use rayon::prelude::*;

mod stages;
pub(crate) use stages::for_each_stage_block;

thread_local! {
    static SEQUENTIAL: Cell<bool> = const { Cell::new(false) };
}

/// Runs `f` with every parallel helper running its chunks in order on the
/// calling thread.
pub(crate) fn sequential<R>(f: impl FnOnce() -> R) -> R {
    let before = SEQUENTIAL.with(|s| s.replace(true));
    let r = f();
    SEQUENTIAL.with(|s| s.set(before));
    r
}

fn inline() -> bool {
    SEQUENTIAL.with(Cell::get)
}

/// Particles per parallel work item.
pub(crate) const CHUNK: usize = 4096;

/// Runs `f(base, chunk)` over `CHUNK`-sized pieces of `a`; results in chunk order.
pub(crate) fn par_map_chunks<A, R, F>(a: &mut [A], chunk: usize, f: F) -> Vec<R>
where
    A: Send,
    R: Send,
    F: Fn(usize, &mut [A]) -> R + Sync + Send,
{
    if a.len() <= chunk {
        return vec![f(0, a)];
    }
    if inline() {
        return a
            .chunks_mut(chunk)
            .enumerate()
            .map(|(c, a)| f(c * chunk, a))
            .collect();
    }
    a.par_chunks_mut(chunk)
        .enumerate()
        .map(|(c, a)| f(c * chunk, a))
        .collect()
}

/// Like [`par_map_chunks`], reading `a` only.
pub(crate) fn map_chunks<A, R, F>(a: &[A], chunk: usize, f: F) -> Vec<R>
where
    A: Sync,
    R: Send,
    F: Fn(usize, &[A]) -> R + Sync + Send,
{
    if a.len() <= chunk || inline() {
        return a
            .chunks(chunk)
            .enumerate()
            .map(|(c, a)| f(c * chunk, a))
            .collect();
    }
    a.par_chunks(chunk)
        .enumerate()
        .map(|(c, a)| f(c * chunk, a))
        .collect()
}

/// Runs `f(chunk)` over `chunk`-sized pieces of `items`, in parallel when
/// there are at least two pieces. For work whose result does not depend on
/// the order the pieces run in.
pub(crate) fn for_each_item<T, F>(items: &[T], chunk: usize, f: F)
where
    T: Sync,
    F: Fn(&[T]) + Sync + Send,
{
    if items.len() < 2 * chunk || inline() {
        items.chunks(chunk).for_each(f);
    } else {
        items.par_chunks(chunk).for_each(f);
    }
}

/// Like [`par_map_chunks`] over three equally long slices, chunked alike.
pub(crate) fn par_map_chunks3<A, B, C, R, F>(
    a: &mut [A],
    b: &mut [B],
    c: &mut [C],
    chunk: usize,
    f: F,
) -> Vec<R>
where
    A: Send,
    B: Send,
    C: Send,
    R: Send,
    F: Fn(usize, &mut [A], &mut [B], &mut [C]) -> R + Sync + Send,
{
    debug_assert!(a.len() == b.len() && b.len() == c.len());
    if a.len() <= chunk {
        return vec![f(0, a, b, c)];
    }
    if inline() {
        return a
            .chunks_mut(chunk)
            .zip(b.chunks_mut(chunk))
            .zip(c.chunks_mut(chunk))
            .enumerate()
            .map(|(k, ((a, b), c))| f(k * chunk, a, b, c))
            .collect();
    }
    (
        a.par_chunks_mut(chunk),
        b.par_chunks_mut(chunk),
        c.par_chunks_mut(chunk),
    )
        .into_par_iter()
        .enumerate()
        .map(|(k, (a, b, c))| f(k * chunk, a, b, c))
        .collect()
}

/// Like [`par_map_chunks`] over four equally long slices, chunked alike.
pub(crate) fn par_map_chunks4<A, B, C, D, R, F>(
    a: &mut [A],
    b: &mut [B],
    c: &mut [C],
    d: &mut [D],
    chunk: usize,
    f: F,
) -> Vec<R>
where
    A: Send,
    B: Send,
    C: Send,
    D: Send,
    R: Send,
    F: Fn(usize, &mut [A], &mut [B], &mut [C], &mut [D]) -> R + Sync + Send,
{
    debug_assert!(a.len() == b.len() && b.len() == c.len() && c.len() == d.len());
    if a.len() <= chunk {
        return vec![f(0, a, b, c, d)];
    }
    if inline() {
        return a
            .chunks_mut(chunk)
            .zip(b.chunks_mut(chunk))
            .zip(c.chunks_mut(chunk))
            .zip(d.chunks_mut(chunk))
            .enumerate()
            .map(|(k, (((a, b), c), d))| f(k * chunk, a, b, c, d))
            .collect();
    }
    (
        a.par_chunks_mut(chunk),
        b.par_chunks_mut(chunk),
        c.par_chunks_mut(chunk),
        d.par_chunks_mut(chunk),
    )
        .into_par_iter()
        .enumerate()
        .map(|(k, (a, b, c, d))| f(k * chunk, a, b, c, d))
        .collect()
}

/// Runs `f(base, piece, state)` over `chunk`-sized pieces of `a`, piece `k`
/// with `states[k]` as its own scratch (per-chunk lists, accumulators), in
/// parallel when there are at least two pieces. `states` must hold at least
/// `a.len().div_ceil(chunk)` elements; pieces past its end are not run.
/// Allocates nothing.
pub(crate) fn for_each_chunk_with<A, S, F>(a: &mut [A], chunk: usize, states: &mut [S], f: F)
where
    A: Send,
    S: Send,
    F: Fn(usize, &mut [A], &mut S) + Sync + Send,
{
    debug_assert!(states.len() >= a.len().div_ceil(chunk));
    if a.len() <= chunk || inline() {
        a.chunks_mut(chunk)
            .zip(states.iter_mut())
            .enumerate()
            .for_each(|(k, (a, s))| f(k * chunk, a, s));
        return;
    }
    a.par_chunks_mut(chunk)
        .zip(states.par_iter_mut())
        .enumerate()
        .for_each(|(k, (a, s))| f(k * chunk, a, s));
}

/// Like [`for_each_chunk_with`] over two equally long slices, chunked
/// alike.
pub(crate) fn for_each_chunk2_with<A, B, S, F>(
    a: &mut [A],
    b: &mut [B],
    chunk: usize,
    states: &mut [S],
    f: F,
) where
    A: Send,
    B: Send,
    S: Send,
    F: Fn(usize, &mut [A], &mut [B], &mut S) + Sync + Send,
{
    debug_assert!(a.len() == b.len());
    debug_assert!(states.len() >= a.len().div_ceil(chunk));
    if a.len() <= chunk || inline() {
        a.chunks_mut(chunk)
            .zip(b.chunks_mut(chunk))
            .zip(states.iter_mut())
            .enumerate()
            .for_each(|(k, ((a, b), s))| f(k * chunk, a, b, s));
        return;
    }
    a.par_chunks_mut(chunk)
        .zip(b.par_chunks_mut(chunk))
        .zip(states.par_iter_mut())
        .enumerate()
        .for_each(|(k, ((a, b), s))| f(k * chunk, a, b, s));
}

/// Runs `f(base, piece)` over `chunk`-sized pieces of `a`, in parallel when
/// there are at least two pieces. Every piece writes only its own elements,
/// so the result does not depend on the thread count. Allocates nothing.
pub(crate) fn for_each_chunk<A, F>(a: &mut [A], chunk: usize, f: F)
where
    A: Send,
    F: Fn(usize, &mut [A]) + Sync + Send,
{
    if a.len() <= chunk || inline() {
        a.chunks_mut(chunk)
            .enumerate()
            .for_each(|(k, a)| f(k * chunk, a));
        return;
    }
    a.par_chunks_mut(chunk)
        .enumerate()
        .for_each(|(k, a)| f(k * chunk, a));
}

/// Runs `f(base, len, state)` over the index range `0..n` cut into
/// `chunk`-sized pieces, piece `k` (`base = k · chunk`, `len` indices) with
/// `states[k]`, in parallel when there are at least two pieces. For passes
/// that fill per-chunk lists and write no per-index slice. `states` must
/// hold at least `n.div_ceil(chunk)` elements.
pub(crate) fn for_each_range_with<S, F>(n: usize, chunk: usize, states: &mut [S], f: F)
where
    S: Send,
    F: Fn(usize, usize, &mut S) + Sync + Send,
{
    let pieces = n.div_ceil(chunk);
    debug_assert!(states.len() >= pieces);
    let held = states.len();
    let states = &mut states[..pieces.min(held)];
    let run = |k: usize, s: &mut S| {
        let base = k * chunk;
        f(base, chunk.min(n - base), s);
    };
    if pieces <= 1 || inline() {
        states.iter_mut().enumerate().for_each(|(k, s)| run(k, s));
        return;
    }
    states
        .par_iter_mut()
        .enumerate()
        .for_each(|(k, s)| run(k, s));
}
