//! The network layer's handle on the tick thread: commands in over
//! bounded channels that never block, frames out through a watch
//! channel, and how the thread ended.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, SyncSender, TrySendError};
use std::sync::Arc;
use std::thread::JoinHandle;
use std::time::Duration;

use inertia_protocol::connection::ReceivedMessage;
use inertia_protocol::{EntityId, PlayerInput};
use tokio::sync::{oneshot, watch};

use super::clock_control::ClockControl;
use super::command::{Command, CommandError, FromClient, JoinedAt, SimCall};
use super::frame::Frame;
use super::stats::SimStats;
use super::thread::{run, Publisher, SimExit};
use super::{SimConfig, Simulation};
use crate::rules::{ClientId, GameRules, JoinRefusal};
use crate::scene::BuiltScene;

/// The network layer's handle on the tick thread. Dropping it stops the
/// thread (after its current loop); [`SimHandle::shutdown`] also waits,
/// and [`SimHandle::stop_within`] waits a bounded time.
#[derive(Debug)]
pub struct SimHandle {
    control: SyncSender<Command>,
    inputs: SyncSender<(ClientId, FromClient)>,
    /// The input channel's capacity.
    input_capacity: usize,
    frames: watch::Receiver<Arc<Frame>>,
    exit: watch::Receiver<Option<SimExit>>,
    stats: Arc<SimStats>,
    /// Set to stop the thread at the top of its next loop when the
    /// control channel is too full to take [`Command::Shutdown`].
    stopping: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

/// Starts the tick thread on `scene` under `rules`.
pub fn spawn(
    scene: BuiltScene,
    rules: Box<dyn GameRules>,
    config: SimConfig,
) -> std::io::Result<SimHandle> {
    SimHandle::spawn(scene, rules, config)
}

impl SimHandle {
    /// Starts the tick thread (named `inertia-tick`) on `scene` under
    /// `rules`. Fails only if the OS refuses a thread.
    pub fn spawn(
        scene: BuiltScene,
        rules: Box<dyn GameRules>,
        config: SimConfig,
    ) -> std::io::Result<SimHandle> {
        Self::run(Simulation::new(scene, rules, config))
    }

    /// Starts the tick thread on a simulation already set up (resumed from
    /// a recording, say).
    pub fn run(mut sim: Simulation) -> std::io::Result<SimHandle> {
        let (control_tx, control_rx) = mpsc::sync_channel(sim.config.control_capacity.max(1));
        let input_capacity = sim.config.input_capacity.max(1);
        let (input_tx, input_rx) = mpsc::sync_channel(input_capacity);
        let stats = sim.stats();
        let (frame_tx, frame_rx) = watch::channel(Arc::new(sim.frame()));
        let (exit_tx, exit_rx) = watch::channel(None);
        let stopping = Arc::new(AtomicBool::new(false));
        let stop = stopping.clone();
        let publisher = Publisher {
            frames: frame_tx,
            retired: Default::default(),
        };
        let realtime = sim.config.tick_realtime;
        let thread = std::thread::Builder::new()
            .name("inertia-tick".into())
            .spawn(move || {
                if let Err(e) = crate::priority::raise_tick_thread(realtime) {
                    tracing::info!(
                        error = %e,
                        "the tick thread keeps the process's priority (grant CAP_SYS_NICE \
                         for a steadier tick on a busy machine)"
                    );
                }
                run(sim, control_rx, input_rx, publisher, exit_tx, &stop)
            })?;
        Ok(SimHandle {
            control: control_tx,
            inputs: input_tx,
            input_capacity,
            frames: frame_rx,
            exit: exit_rx,
            stats,
            stopping,
            thread: Some(thread),
        })
    }

    fn send(&self, cmd: Command) -> Result<(), CommandError> {
        self.control.try_send(cmd).map_err(|e| match e {
            TrySendError::Full(_) => {
                self.stats.commands_dropped.fetch_add(1, Ordering::Relaxed);
                CommandError::Busy
            }
            TrySendError::Disconnected(_) => CommandError::Stopped,
        })
    }

    /// Sends a control command without waiting (inputs go to the input
    /// channel whichever way they are sent).
    pub fn command(&self, cmd: Command) -> Result<(), CommandError> {
        match cmd {
            Command::Input { client, input } => self.input(client, input),
            Command::Message { client, message } => self.message(client, message),
            cmd => self.send(cmd),
        }
    }

    /// Asks for a client to join; await the answer on the receiver.
    pub fn request_join(
        &self,
        client: ClientId,
    ) -> Result<oneshot::Receiver<Result<JoinedAt, JoinRefusal>>, CommandError> {
        let (reply, rx) = oneshot::channel();
        self.send(Command::Join { client, reply })?;
        Ok(rx)
    }

    /// A client joins: its avatar's entity id, or why not.
    pub async fn join(&self, client: ClientId) -> Result<EntityId, JoinRefusal> {
        let rx = self
            .request_join(client)
            .map_err(|_| JoinRefusal::Unavailable)?;
        rx.await
            .unwrap_or(Err(JoinRefusal::Unavailable))
            .map(|j| j.avatar)
    }

    /// [`SimHandle::join`] for threads outside an async runtime (panics
    /// inside one, like `oneshot::Receiver::blocking_recv`).
    pub fn join_blocking(&self, client: ClientId) -> Result<EntityId, JoinRefusal> {
        let rx = self
            .request_join(client)
            .map_err(|_| JoinRefusal::Unavailable)?;
        rx.blocking_recv()
            .unwrap_or(Err(JoinRefusal::Unavailable))
            .map(|j| j.avatar)
    }

    /// A client left.
    pub fn leave(&self, client: ClientId) -> Result<(), CommandError> {
        self.send(Command::Leave { client })
    }

    /// A client's input; dropped (and counted) when the channel is full.
    pub fn input(&self, client: ClientId, input: PlayerInput) -> Result<(), CommandError> {
        self.send_from_client(client, FromClient::Input(input))
    }

    /// A client's message, for the rules at the next tick; dropped (and
    /// counted) when the channel is full.
    pub fn message(&self, client: ClientId, message: ReceivedMessage) -> Result<(), CommandError> {
        self.send_from_client(client, FromClient::Message(message))
    }

    /// Inputs and messages the input channel holds at most.
    pub fn input_capacity(&self) -> usize {
        self.input_capacity
    }

    fn send_from_client(&self, client: ClientId, sent: FromClient) -> Result<(), CommandError> {
        self.inputs.try_send((client, sent)).map_err(|e| match e {
            TrySendError::Full(_) => {
                self.stats.commands_dropped.fetch_add(1, Ordering::Relaxed);
                CommandError::Busy
            }
            TrySendError::Disconnected(_) => CommandError::Stopped,
        })
    }

    /// Stops real-time ticking.
    pub fn pause(&self) -> Result<(), CommandError> {
        self.send(Command::Clock(ClockControl::Pause))
    }

    /// Resumes at the last non-zero time scale.
    pub fn resume(&self) -> Result<(), CommandError> {
        self.send(Command::Clock(ClockControl::Resume))
    }

    /// Simulation seconds per wall second (0..=64; 0 pauses).
    pub fn set_time_scale(&self, scale: f64) -> Result<(), CommandError> {
        self.send(Command::Clock(ClockControl::Speed(scale)))
    }

    /// Runs exactly `n` more ticks, pausing first if the clock runs.
    pub fn step(&self, n: u64) -> Result<(), CommandError> {
        self.send(Command::Clock(ClockControl::Step(n)))
    }

    /// Runs up to `tick`, then pauses.
    pub fn run_to(&self, tick: u64) -> Result<(), CommandError> {
        self.send(Command::Clock(ClockControl::RunTo(tick)))
    }

    /// Runs `f` on the tick thread between ticks; its result arrives on
    /// the receiver. Commands sent before it have been applied when it
    /// runs.
    pub fn call<R: Send + 'static>(
        &self,
        f: impl FnOnce(&mut Simulation) -> R + Send + 'static,
    ) -> Result<oneshot::Receiver<R>, CommandError> {
        let (tx, rx) = oneshot::channel();
        self.send(Command::Call(SimCall(Box::new(move |sim| {
            let _ = tx.send(f(sim));
        }))))?;
        Ok(rx)
    }

    /// The latest frame.
    pub fn frame(&self) -> Arc<Frame> {
        self.frames.borrow().clone()
    }

    /// A receiver that wakes on every new frame (`changed().await`).
    pub fn subscribe(&self) -> watch::Receiver<Arc<Frame>> {
        self.frames.clone()
    }

    /// Why the game rules ended the match, once they have.
    pub fn match_over(&self) -> watch::Receiver<Option<String>> {
        self.stats.match_over.subscribe()
    }

    /// The shared counters.
    pub fn stats(&self) -> &SimStats {
        &self.stats
    }

    /// How the tick thread ended; `None` while it runs.
    pub fn exit(&self) -> Option<SimExit> {
        self.exit.borrow().clone()
    }

    /// A receiver that wakes when the tick thread ends, whatever the
    /// reason (`wait_for(Option::is_some)`).
    pub fn watch_exit(&self) -> watch::Receiver<Option<SimExit>> {
        self.exit.clone()
    }

    /// Asks the thread to stop after what it is doing now (its loop, or
    /// the call it is running), without waiting; it ends the recording
    /// with a keyframe on its way out.
    pub fn stop(&self) {
        // In order after the commands sent before, when there is room;
        // else at the top of the thread's next loop.
        if let Err(TrySendError::Full(_)) = self.control.try_send(Command::Shutdown) {
            self.stopping.store(true, Ordering::SeqCst);
        }
    }

    /// Stops the thread and waits, at most `timeout`, until it has ended
    /// (its last act is to report its [`exit`](Self::exit), after the
    /// recording's final keyframe): true if it did. A thread stuck longer
    /// (in a call that never returns, say) is left behind, to end with the
    /// process.
    pub async fn stop_within(&self, timeout: Duration) -> bool {
        self.stop();
        let mut exit = self.watch_exit();
        let ended = tokio::time::timeout(timeout, exit.wait_for(Option::is_some)).await;
        matches!(ended, Ok(Ok(_)))
    }

    /// Stops the thread and waits for it, however long it takes.
    pub fn shutdown(mut self) {
        self.stop();
        if let Some(t) = self.thread.take() {
            let _ = t.join();
        }
    }
}

impl Drop for SimHandle {
    fn drop(&mut self) {
        // The thread also stops when it sees the channels closed.
        self.stop();
    }
}
