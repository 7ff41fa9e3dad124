//! Thread priorities: the tick first, then the network, then the
//! snapshot encoders.
//!
//! On a machine short of cores every thread of the server competes for
//! them, and a tick that waits for a core overruns its 16.7 ms however
//! little work it has. The tick thread asks to be [`TICK_NICE`] more
//! urgent than the process (which needs `CAP_SYS_NICE`, or a soft
//! `RLIMIT_NICE` that allows it: grant one of them to the game-server
//! container for a steady tick under load); the snapshot stage makes
//! itself [`STAGE_NICE`] less urgent, which needs nothing. Both are best
//! effort: where a platform or the limits refuse, the thread keeps the
//! process's priority and says so once in the log.

/// How much more urgent the tick thread asks to be than the process.
pub const TICK_NICE: i32 = -10;
/// How much less urgent the snapshot stage's thread is than the process.
pub const STAGE_NICE: i32 = 5;

/// Moves the calling thread's nice value by `delta` (negative: more
/// urgent), within −20..=19. Refused without the privilege to go below
/// the current value; nothing changes then.
pub fn adjust_this_thread(delta: i32) -> std::io::Result<()> {
    #[cfg(target_os = "linux")]
    {
        use rustix::process::{getpriority_process, setpriority_process};
        let tid = Some(rustix::thread::gettid());
        let now = getpriority_process(tid).unwrap_or(0);
        setpriority_process(tid, (now + delta).clamp(-20, 19))
            .map_err(|e| std::io::Error::from_raw_os_error(e.raw_os_error()))
    }
    #[cfg(not(target_os = "linux"))]
    {
        let _ = delta;
        Err(std::io::Error::from(std::io::ErrorKind::Unsupported))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_thread_can_always_become_less_urgent() {
        std::thread::spawn(|| {
            adjust_this_thread(STAGE_NICE).expect("lowering needs no privilege");
            #[cfg(target_os = "linux")]
            {
                let tid = Some(rustix::thread::gettid());
                let nice = rustix::process::getpriority_process(tid).unwrap();
                assert!(nice >= STAGE_NICE.min(19), "{nice}");
            }
        })
        .join()
        .unwrap();
    }
}
