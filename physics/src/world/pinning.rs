//! Pinning a world's worker threads one to a core.
//!
//! A world with threads of its own steps on them while the thread that
//! called `step` waits. On a small machine whose cores are all busy, the
//! OS may wake a worker on the core of the worker that woke it rather
//! than on the core just left idle, and move it only at a later balancing
//! tick, milliseconds on: then one core does a parallel pass while the
//! other idles. `perf sched` showed it on a 2-core Linux 6.18 virtual
//! machine: both workers of a world on one core for 11 ms while the other
//! idled, and woken workers waiting 2–4 ms to run. On that machine (AMD
//! EPYC), with `inertia-bench soft --only _1 --pin-threads auto|never`
//! run in turn three times each, at 2 threads `cloth_128` took 5.95–8.74
//! ms a step pinned and 8.01–8.62 ms not, and `fluid_10k` 6.74–9.13 ms
//! pinned and 9.35–10.34 ms not.
//!
//! Pinning is right only where the process has its cores to itself: a
//! game server on dedicated cores, a Kubernetes pod under the static CPU
//! manager policy. [`ThreadPinning::Auto`] pins where the process may run
//! on no more cores than the world has threads, which is what such a
//! process sees; on a shared machine it leaves the placement to the OS.

/// Whether a world's own worker threads are pinned one to a core
/// ([`crate::WorldConfig::pin_threads`]). Pinning never changes results,
/// only where the threads run. Linux only; elsewhere nothing is pinned.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum ThreadPinning {
    /// Pin when the process may run on no more cores than the world has
    /// threads: it owns those cores, and nothing is gained by letting the
    /// OS move the workers between them.
    #[default]
    Auto,
    /// Never pin.
    Never,
    /// Pin worker `k` to the `k`-th core the process may run on (wrapping
    /// around when there are more workers than cores).
    Always,
}

/// The core each of `threads` workers is pinned to, given the cores the
/// process may run on (`allowed`, in order); `None`: nothing pinned.
pub(crate) fn plan(
    pinning: ThreadPinning,
    threads: usize,
    allowed: Option<&[usize]>,
) -> Option<Vec<usize>> {
    let allowed = allowed.filter(|a| !a.is_empty())?;
    let pin = match pinning {
        ThreadPinning::Never => false,
        ThreadPinning::Always => true,
        ThreadPinning::Auto => allowed.len() <= threads,
    };
    pin.then(|| (0..threads).map(|k| allowed[k % allowed.len()]).collect())
}

/// The cores the calling thread may run on (its affinity mask), in
/// order; `None` if that cannot be known.
#[cfg(target_os = "linux")]
pub(crate) fn allowed_cores() -> Option<Vec<usize>> {
    // SAFETY: a zeroed cpu_set_t is an empty set, and the call writes at
    // most its size into it.
    let set = unsafe {
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        if libc::sched_getaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &mut set) != 0 {
            return None;
        }
        set
    };
    let cores: Vec<usize> = (0..libc::CPU_SETSIZE as usize)
        // SAFETY: `c` is below CPU_SETSIZE, the set's size in bits.
        .filter(|&c| unsafe { libc::CPU_ISSET(c, &set) })
        .collect();
    Some(cores)
}

/// Elsewhere the mask is not known, and nothing is pinned.
#[cfg(not(target_os = "linux"))]
pub(crate) fn allowed_cores() -> Option<Vec<usize>> {
    None
}

/// Pins the calling thread to `core`; false if the OS refused.
#[cfg(target_os = "linux")]
pub(crate) fn pin_current_thread(core: usize) -> bool {
    if core >= libc::CPU_SETSIZE as usize {
        return false;
    }
    // SAFETY: a zeroed cpu_set_t is an empty set; `core` is within it
    // (checked); the call reads the set only.
    unsafe {
        let mut set: libc::cpu_set_t = std::mem::zeroed();
        libc::CPU_SET(core, &mut set);
        libc::sched_setaffinity(0, std::mem::size_of::<libc::cpu_set_t>(), &set) == 0
    }
}

/// Elsewhere nothing is pinned.
#[cfg(not(target_os = "linux"))]
pub(crate) fn pin_current_thread(_core: usize) -> bool {
    false
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn auto_pins_only_a_process_that_owns_its_cores() {
        let two = [4usize, 7];
        assert_eq!(plan(ThreadPinning::Auto, 2, Some(&two)), Some(vec![4, 7]));
        assert_eq!(
            plan(ThreadPinning::Auto, 4, Some(&two)),
            Some(vec![4, 7, 4, 7])
        );
        let many: Vec<usize> = (0..64).collect();
        assert_eq!(plan(ThreadPinning::Auto, 2, Some(&many)), None);
        assert_eq!(
            plan(ThreadPinning::Always, 2, Some(&many)),
            Some(vec![0, 1])
        );
        assert_eq!(plan(ThreadPinning::Never, 2, Some(&two)), None);
        assert_eq!(plan(ThreadPinning::Always, 2, None), None);
        assert_eq!(plan(ThreadPinning::Always, 2, Some(&[])), None);
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn a_pinned_thread_runs_on_its_core_alone() {
        let cores = allowed_cores().expect("the affinity mask");
        assert!(!cores.is_empty());
        let last = *cores.last().expect("a core");
        let seen = std::thread::spawn(move || {
            assert!(pin_current_thread(last));
            allowed_cores()
        })
        .join()
        .expect("thread");
        assert_eq!(seen, Some(vec![last]));
        assert!(!pin_current_thread(usize::MAX));
    }

    #[cfg(target_os = "linux")]
    #[test]
    fn a_world_pins_its_workers_as_configured() {
        use crate::{World, WorldConfig};
        let cores = allowed_cores().expect("the affinity mask");
        let world = |pin_threads| {
            World::new(WorldConfig {
                threads: 2,
                pin_threads,
                ..WorldConfig::default()
            })
            .expect("world")
        };
        let pinned = world(ThreadPinning::Always);
        let want: Vec<usize> = (0..2).map(|k| cores[k % cores.len()]).collect();
        assert_eq!(pinned.pinned_cores(), Some(&want[..]));
        let seen = pinned
            .pool
            .as_ref()
            .expect("a pool")
            .broadcast(|ctx| (ctx.index(), allowed_cores()));
        for (k, mask) in seen {
            assert_eq!(mask, Some(vec![want[k]]), "worker {k}");
        }
        assert_eq!(world(ThreadPinning::Never).pinned_cores(), None);
        let one = World::new(WorldConfig {
            threads: 1,
            pin_threads: ThreadPinning::Always,
            ..WorldConfig::default()
        })
        .expect("world");
        assert_eq!(one.pinned_cores(), None, "one thread has no workers");
    }
}
