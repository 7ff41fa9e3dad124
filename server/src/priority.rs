//! Thread priorities: the tick first, then the network and the snapshot
//! encoders alike.
//!
//! On a machine short of cores every thread of the server competes for
//! them, and a tick that waits for a core overruns its 16.7 ms however
//! little work it has. The tick thread asks to be [`TICK_NICE`] more
//! urgent than the process (which needs `CAP_SYS_NICE`, or a soft
//! `RLIMIT_NICE` that allows it: grant one of them to the game-server
//! container for a steady tick under load). It is best effort: where a
//! platform or the limits refuse, the thread keeps the process's priority
//! and says so once in the log. The snapshot stage keeps the process's
//! priority, as the network workers do: it has a slot to finish within
//! each snapshot period, and below them it lost most of a shared core to
//! them while the other core was partly idle. Threads the tick
//! thread starts for background work (the checkpoint packer) go back to
//! the priority it had before ([`restore_after_tick`]); the physics
//! workers it starts keep its priority, since the tick waits for them.

/// How much more urgent the tick thread asks to be than the process.
pub const TICK_NICE: i32 = -10;

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

/// Makes the calling thread, the tick thread, [`TICK_NICE`] more urgent,
/// remembering where it was ([`restore_after_tick`]).
pub fn raise_tick_thread() -> std::io::Result<()> {
    let _ = BEFORE_TICK.set(this_thread_nice());
    adjust_this_thread(TICK_NICE)
}

/// Puts a thread the tick thread started (which took its priority) back
/// at the priority the tick thread had before it was raised.
pub fn restore_after_tick() {
    if let Some(&nice) = BEFORE_TICK.get() {
        // Lowering needs no privilege.
        let _ = set_this_thread(nice);
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
            let raised = raise_tick_thread().is_ok();
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
