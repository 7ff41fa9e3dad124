//! The tick thread's loop: drain commands and inputs, run the ticks the
//! clock says are due, publish a frame, sleep until the next tick; and
//! what it does when the loop ends or anything in it panics.

use std::collections::VecDeque;
use std::panic::{self, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{Receiver, RecvTimeoutError, TryRecvError};
use std::sync::Arc;
use std::time::{Duration, Instant};

use inertia_protocol::EntityState;
use tokio::sync::watch;

use super::command::{Command, FromClient};
use super::frame::Frame;
use super::Simulation;
use crate::rules::ClientId;

/// How the tick thread ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SimExit {
    /// It was asked to stop ([`SimHandle::shutdown`](super::SimHandle::shutdown), or every handle
    /// dropped) and ended its recording with a keyframe.
    Shutdown,
    /// It failed: a panic in a tick, a command or an admin call. The world
    /// is frozen at the tick it reached.
    Failed {
        /// The panic's message.
        reason: String,
        /// The tick reached.
        tick: u64,
        /// Whether the state was sound (the failure came between ticks)
        /// and a final keyframe of it was written; otherwise the recording
        /// ends at the last whole tick and `--resume` re-simulates to it.
        keyframe: bool,
    },
}

/// Longest sleep between loops while paused, so the loop notices closed
/// channels.
const IDLE_WAIT: Duration = Duration::from_millis(50);

/// The tick thread: the loop, then the end of the recording. A panic
/// anywhere in the loop (a tick, a command, an admin call) is caught here
/// and reported on `exit`, so the server can fail its health checks, tell
/// the clients and exit for a restart instead of serving a frozen world.
pub(super) fn run(
    mut sim: Simulation,
    control: Receiver<Command>,
    inputs: Receiver<(ClientId, FromClient)>,
    mut frames: Publisher,
    exit: watch::Sender<Option<SimExit>>,
    stopping: &AtomicBool,
) {
    let looped = panic::catch_unwind(AssertUnwindSafe(|| {
        run_loop(&mut sim, control, inputs, &mut frames, stopping)
    }));
    let outcome = match looped {
        Ok(()) => match panic::catch_unwind(AssertUnwindSafe(|| sim.finish_recording())) {
            Ok(()) => SimExit::Shutdown,
            Err(payload) => SimExit::Failed {
                reason: panic_message(payload.as_ref()),
                tick: sim.shown().world.tick(),
                keyframe: false,
            },
        },
        Err(payload) => {
            let reason = panic_message(payload.as_ref());
            let tick = sim.shown().world.tick();
            let keyframe =
                panic::catch_unwind(AssertUnwindSafe(|| sim.end_after_failure())).unwrap_or(false);
            tracing::error!(
                %reason,
                tick,
                keyframe,
                "the simulation failed and has stopped"
            );
            SimExit::Failed {
                reason,
                tick,
                keyframe,
            }
        }
    };
    exit.send_replace(Some(outcome));
}

/// Frames a [`Publisher`] keeps after replacing them, until no reader
/// holds them: one of those lends its states buffer to the next frame, so
/// publishing 60 frames a second does not allocate (and fault in) a
/// fresh buffer of every moving entity each time.
const RETIRED_FRAMES: usize = 8;

/// Where the tick thread's frames go: every frame to `frames`.
pub(super) struct Publisher {
    pub(super) frames: watch::Sender<Arc<Frame>>,
    /// Frames replaced, oldest first, at most [`RETIRED_FRAMES`].
    pub(super) retired: VecDeque<Arc<Frame>>,
}

impl Publisher {
    /// Publishes the simulation's frame now.
    fn publish(&mut self, sim: &mut Simulation) {
        let frame = Arc::new(sim.frame_in(self.reclaim()));
        let old = self.frames.send_replace(frame);
        self.retired.push_back(old);
        if self.retired.len() > RETIRED_FRAMES {
            self.retired.pop_front();
        }
    }

    /// The states buffer of the oldest retired frame no reader holds any
    /// more, emptied (a new one when every one is still read).
    fn reclaim(&mut self) -> Vec<EntityState> {
        let free = self
            .retired
            .iter_mut()
            .position(|f| Arc::get_mut(f).is_some());
        let mut states = free
            .and_then(|i| self.retired.remove(i))
            .and_then(Arc::into_inner)
            .map(|f| f.entities)
            .unwrap_or_default();
        states.clear();
        states
    }
}

/// The message a panic was raised with.
fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    if let Some(s) = payload.downcast_ref::<&str>() {
        (*s).to_string()
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s.clone()
    } else {
        "a panic without a message".to_string()
    }
}

fn run_loop(
    sim: &mut Simulation,
    control: Receiver<Command>,
    inputs: Receiver<(ClientId, FromClient)>,
    frames: &mut Publisher,
    stopping: &AtomicBool,
) {
    let mut last = Instant::now();
    let mut early: Option<Command> = None;
    let stats = sim.stats();
    loop {
        if stopping.load(Ordering::SeqCst) {
            break;
        }
        stats.loops.fetch_add(1, Ordering::Relaxed);
        let mut changed = false;
        let mut budget = sim.config.max_control_per_loop.max(1);
        if let Some(cmd) = early.take() {
            changed = true;
            budget -= 1;
            if !sim.apply(cmd) {
                break;
            }
        }
        while budget > 0 {
            match control.try_recv() {
                Ok(cmd) => {
                    changed = true;
                    budget -= 1;
                    if !sim.apply(cmd) {
                        frames.publish(sim);
                        return;
                    }
                }
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) => return,
            }
        }
        for _ in 0..sim.config.max_inputs_per_loop {
            match inputs.try_recv() {
                Ok((client, sent)) => sim.take_from_client(client, sent),
                Err(_) => break,
            }
        }
        let now = Instant::now();
        let ran = sim.advance(now - last);
        last = now;
        if ran > 0 && stats.match_over.borrow().is_none() {
            if let Some(why) = sim.match_over() {
                tracing::info!(reason = %why, "the game rules ended the match");
                stats.match_over.send_replace(Some(why));
            }
        }
        // What changed between ticks (joins, edits while paused) reaches
        // the recording now, not at the next tick.
        sim.flush_journal();
        if ran > 0 || changed {
            frames.publish(sim);
        }
        let wait = sim
            .shown()
            .clock
            .until_next_tick()
            .unwrap_or(IDLE_WAIT)
            .min(IDLE_WAIT);
        if wait > Duration::ZERO {
            match control.recv_timeout(wait) {
                Ok(cmd) => early = Some(cmd),
                Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => return,
            }
        }
    }
    frames.publish(sim);
}
