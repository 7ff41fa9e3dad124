//! Thread priorities: the tick first, then the network and the snapshot
//! encoders alike.
//!
//! On a machine short of cores every thread of the server competes for
//! them, and a tick that waits for a core overruns its 16.7 ms however
//! little work it has. The tick thread asks to be [`TICK_NICE`] more
//! urgent than the process (which needs `CAP_SYS_NICE`, or a soft
//! `RLIMIT_NICE` that allows it: grant one of them to the game-server
//! container for a steady tick under load). With `--tick-realtime` it asks
//! for real-time scheduling instead (`SCHED_FIFO` at [`TICK_RT_PRIORITY`],
//! which needs `CAP_SYS_NICE` or an `RLIMIT_RTPRIO` that allows it): a
//! nice value only weights the kernel's fair share, so a raised tick still
//! waited behind busy threads for milliseconds at a time (tick p99 17-21 ms
//! at 200 clients with both cores busy, p50 5 ms), where a real-time tick
//! runs as soon as it wakes (p99 8.7 ms, p50 3.5 ms, same load). A
//! real-time tick that never slept would hold a core, so the kernel's
//! real-time throttling (5 % of each second kept for other threads by
//! default) is the backstop; the tick loop sleeps between ticks and caps
//! its catch-up, and only fast-forward keeps it busy. It is best effort:
//! where a platform or the limits refuse, the thread falls back to the nice
//! value, then to the process's priority, and says so once in the log.
//!
//! The snapshot stage has a slot to finish within each snapshot period.
//! Below the network workers it lost most of a shared core to them while
//! the other core was partly idle, so it keeps at least the process's
//! priority. With `--tick-realtime` it runs real-time too, below the tick
//! ([`STAGE_RT_PRIORITY`], [`raise_stage_thread`]): at the process's
//! priority, on a machine whose cores were both busy, its slots stretched
//! past the governor's share of the period while its own work took under
//! half of it, and the governor lowered rates the server could have kept.
//! Its work is bounded by the governor (a slot that takes more than
//! [`crate::net::governor::STAGE_SHARE`] of the period lowers rates), so
//! the stage leaves the rest of each period to the network workers.
//!
//! Threads the tick thread starts for background work (the
//! checkpoint packer) go back to the scheduling it had before
//! ([`restore_after_tick`]); the physics workers it starts keep its
//! priority, since the tick waits for them.

/// How much more urgent the tick thread asks to be than the process.
pub const TICK_NICE: i32 = -10;

/// The `SCHED_FIFO` priority the tick thread asks for with
/// `--tick-realtime` (1..=99): low among real-time threads, so the
/// kernel's own (interrupt threads at 50) stay above it.
pub const TICK_RT_PRIORITY: i32 = 10;

/// The `SCHED_FIFO` priority the snapshot stage asks for with
/// `--tick-realtime`: below the tick's, so a tick never waits for an
/// encoder.
pub const STAGE_RT_PRIORITY: i32 = TICK_RT_PRIORITY - 5;

/// The nice value the tick thread had before it raised its priority,
/// for the threads it starts to go back to.
static BEFORE_TICK: std::sync::OnceLock<i32> = std::sync::OnceLock::new();

/// Moves the calling thread's nice value by `delta` (negative: more
/// urgent), within −20..=19. Refused without the privilege to go below
/// the current value; nothing changes then.
pub fn adjust_this_thread(delta: i32) -> std::io::Result<()> {
    let now = this_thread_nice();
    set_this_thread(now + delta)
}

/// How the tick thread was raised.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TickPriority {
    /// Real-time: `SCHED_FIFO` at [`TICK_RT_PRIORITY`].
    RealTime,
    /// [`TICK_NICE`] more urgent than the process.
    Nice,
}

/// Raises the calling thread, the tick thread: to real time when
/// `realtime` and allowed, else [`TICK_NICE`] more urgent, remembering
/// where it was ([`restore_after_tick`]). Says how, or why neither was
/// allowed (then nothing changed); a refused real-time request is logged.
pub fn raise_tick_thread(realtime: bool) -> std::io::Result<TickPriority> {
    let _ = BEFORE_TICK.set(this_thread_nice());
    if realtime {
        match set_this_thread_fifo(TICK_RT_PRIORITY) {
            Ok(()) => return Ok(TickPriority::RealTime),
            Err(e) => tracing::info!(
                error = %e,
                "the tick thread cannot run at real-time priority (grant CAP_SYS_NICE \
                 or an RLIMIT_RTPRIO of at least {TICK_RT_PRIORITY}); it raises its nice value instead"
            ),
        }
    }
    adjust_this_thread(TICK_NICE).map(|()| TickPriority::Nice)
}

/// Raises the calling thread, the snapshot stage, to real time at
/// [`STAGE_RT_PRIORITY`] when `realtime`; otherwise, or where refused
/// (logged), it keeps the process's priority. Says whether it is real
/// time now.
pub fn raise_stage_thread(realtime: bool) -> bool {
    if !realtime {
        return false;
    }
    match set_this_thread_fifo(STAGE_RT_PRIORITY) {
        Ok(()) => true,
        Err(e) => {
            tracing::info!(
                error = %e,
                "the snapshot stage cannot run at real-time priority; it keeps the process's"
            );
            false
        }
    }
}

/// Puts a thread the tick thread started (which took its scheduling) back
/// at the scheduling the tick thread had before it was raised: the normal
/// policy, at the nice value it had.
pub fn restore_after_tick() {
    // Leaving real time and lowering need no privilege.
    let _ = set_this_thread_normal();
    if let Some(&nice) = BEFORE_TICK.get() {
        let _ = set_this_thread(nice);
    }
}

/// Whether the calling thread runs at real-time priority.
pub fn this_thread_is_realtime() -> bool {
    #[cfg(target_os = "linux")]
    {
        // SAFETY: sched_getscheduler(0) only reads the calling thread's
        // policy; it takes no pointers.
        let policy = unsafe { libc::sched_getscheduler(0) };
        policy == libc::SCHED_FIFO || policy == libc::SCHED_RR
    }
    #[cfg(not(target_os = "linux"))]
    {
        false
    }
}

/// Puts the calling thread under `SCHED_FIFO` at `priority`.
fn set_this_thread_fifo(priority: i32) -> std::io::Result<()> {
    #[cfg(target_os = "linux")]
    {
        set_this_thread_policy(libc::SCHED_FIFO, priority)
    }
    #[cfg(not(target_os = "linux"))]
    {
        let _ = priority;
        Err(std::io::Error::from(std::io::ErrorKind::Unsupported))
    }
}

/// Puts the calling thread under the normal time-sharing policy.
fn set_this_thread_normal() -> std::io::Result<()> {
    #[cfg(target_os = "linux")]
    {
        set_this_thread_policy(libc::SCHED_OTHER, 0)
    }
    #[cfg(not(target_os = "linux"))]
    {
        Ok(())
    }
}

#[cfg(target_os = "linux")]
fn set_this_thread_policy(policy: libc::c_int, priority: i32) -> std::io::Result<()> {
    let param = libc::sched_param {
        sched_priority: priority,
    };
    // SAFETY: `param` is a valid sched_param that outlives the call, and
    // pthread_self() names the calling thread, which is alive.
    let err = unsafe { libc::pthread_setschedparam(libc::pthread_self(), policy, &param) };
    if err == 0 {
        Ok(())
    } else {
        Err(std::io::Error::from_raw_os_error(err))
    }
}

fn this_thread_nice() -> i32 {
    #[cfg(target_os = "linux")]
    {
        rustix::process::getpriority_process(Some(rustix::thread::gettid())).unwrap_or(0)
    }
    #[cfg(not(target_os = "linux"))]
    {
        0
    }
}

fn set_this_thread(nice: i32) -> std::io::Result<()> {
    #[cfg(target_os = "linux")]
    {
        let tid = Some(rustix::thread::gettid());
        rustix::process::setpriority_process(tid, nice.clamp(-20, 19))
            .map_err(|e| std::io::Error::from_raw_os_error(e.raw_os_error()))
    }
    #[cfg(not(target_os = "linux"))]
    {
        let _ = nice;
        Err(std::io::Error::from(std::io::ErrorKind::Unsupported))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_thread_the_tick_starts_goes_back_to_the_priority_before_it() {
        std::thread::spawn(|| {
            let before = this_thread_nice();
            // Refused without the privilege: then nothing moved at all.
            let raised = raise_tick_thread(false).is_ok();
            std::thread::spawn(move || {
                let inherited = this_thread_nice();
                if raised {
                    assert!(inherited < before, "{inherited} vs {before}");
                }
                restore_after_tick();
                assert_eq!(this_thread_nice(), *BEFORE_TICK.get().unwrap());
            })
            .join()
            .unwrap();
        })
        .join()
        .unwrap();
    }

    #[test]
    fn the_stage_runs_real_time_only_when_asked_and_below_the_tick() {
        std::thread::spawn(|| {
            assert!(!raise_stage_thread(false));
            assert!(!this_thread_is_realtime());
            let raised = raise_stage_thread(true);
            assert_eq!(this_thread_is_realtime(), raised);
        })
        .join()
        .unwrap();
        const { assert!(0 < STAGE_RT_PRIORITY && STAGE_RT_PRIORITY < TICK_RT_PRIORITY) };
    }

    #[test]
    fn a_realtime_tick_thread_starts_background_threads_back_in_normal_time() {
        std::thread::spawn(|| {
            let raised = raise_tick_thread(true);
            let realtime = raised.as_ref().is_ok_and(|p| *p == TickPriority::RealTime);
            assert_eq!(this_thread_is_realtime(), realtime, "{raised:?}");
            std::thread::spawn(move || {
                // A physics worker keeps it; a background thread drops it.
                assert_eq!(this_thread_is_realtime(), realtime);
                restore_after_tick();
                assert!(!this_thread_is_realtime());
                assert_eq!(this_thread_nice(), *BEFORE_TICK.get().unwrap());
            })
            .join()
            .unwrap();
        })
        .join()
        .unwrap();
    }

    #[test]
    fn a_thread_can_always_become_less_urgent() {
        std::thread::spawn(|| {
            adjust_this_thread(5).expect("lowering needs no privilege");
            #[cfg(target_os = "linux")]
            {
                let tid = Some(rustix::thread::gettid());
                let nice = rustix::process::getpriority_process(tid).unwrap();
                assert!(nice >= 5, "{nice}");
            }
        })
        .join()
        .unwrap();
    }
}
