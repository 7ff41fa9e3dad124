//! The tick loop: one world stepped at a fixed rate on its own thread.
//!
//! The world lives on a dedicated `std::thread`, never on a tokio worker: a
//! tick is milliseconds of CPU work that would stall every socket task
//! sharing the worker. The network layer talks to it through a
//! [`SimHandle`]:
//!
//! * **commands in** over two bounded channels, drained at the top of each
//!   loop: control (join, leave, pause, time scale, step, shutdown; up to
//!   [`SimConfig::max_control_per_loop`]) and inputs (up to
//!   [`SimConfig::max_inputs_per_loop`]). Sending never blocks; a full
//!   channel refuses the command (counted), so a flood cannot stall a tick;
//! * **frames out**: after the ticks of a loop the thread publishes an
//!   `Arc<Frame>` through a `tokio::sync::watch` channel. Readers clone the
//!   `Arc` and let go, so a slow reader never holds up a tick and a slow
//!   tick never blocks a reader (they keep the previous frame).
//!
//! Each loop: drain commands → ask the [`Clock`] how many ticks are due →
//! per tick `before_tick` (rules turn inputs into forces) → `World::step` →
//! remove what left the world or went non-finite → `after_tick` → publish
//! one frame → sleep on the control channel until the next tick is due.
//!
//! [`Simulation`] is that loop's state without the thread, for tests and
//! tools that want to drive ticks by hand.
//!
//! While recording (see [`crate::record::recorder`]), everything that
//! changes the simulation between ticks — joins, leaves, accepted inputs,
//! live edits — goes into the tick's journal (`Journal` records, written
//! once a loop and before each tick); after each tick the recorder gets
//! its state hash (`TickHash`) and, every
//! [`RecorderConfig::keyframe_ticks`] ticks, the whole
//! [`SimState`](crate::replay::SimState) (`Keyframe`). A session starts
//! with `SessionStart` and a keyframe; the thread's shutdown ends it with a
//! keyframe of the last tick. The same records go into an in-memory
//! [`History`] that seeking uses (see [`timeline`]). The tick thread never
//! waits on the disk: a record the recorder cannot take stops the
//! recording (a gap would break replay).

use std::collections::{BTreeMap, BTreeSet, VecDeque};
use std::panic::{self, AssertUnwindSafe};
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::sync::mpsc::{self, Receiver, RecvTimeoutError, SyncSender, TryRecvError, TrySendError};
use std::sync::{Arc, OnceLock};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use inertia_physics::glam::DVec3;
use inertia_physics::World;
use inertia_protocol::snapshot::{QuantizedFrame, SnapshotConfig};
use inertia_protocol::{EntityDesc, EntityId, EntityState, PlayerInput};
use tokio::sync::{oneshot, watch};

use crate::clock::Clock;
use crate::config::ServerConfig;
use crate::metrics::Metrics;
use crate::record::{Record, Recorder, RecorderConfig};
use crate::replay::{History, JournalEntry, SimState, StateError};
use crate::rules::{
    ClientId, ControlLimits, GameEvent, GameRules, InputError, Refusal, RemovalReason, SimContext,
};
use crate::scene::{BuiltScene, EntityTable};

pub mod edit;
pub mod resume;
pub mod startup;
pub mod timeline;

pub use edit::EditError;

/// Default interval of the in-memory checkpoints seeks start from, ticks.
pub const DEFAULT_CHECKPOINT_TICKS: u64 = 10;

/// Events a [`Frame`] carries: the most recent ones, whatever frame they
/// were first published in.
pub const RECENT_EVENTS: usize = 1024;

/// How the tick loop runs.
#[derive(Debug, Clone)]
pub struct SimConfig {
    /// Ticks per simulation second, Hz.
    pub tick_hz: u32,
    /// Most ticks one loop runs to catch up.
    pub max_catch_up_ticks: u32,
    /// Most clients at once.
    pub max_clients: u32,
    /// Caps on what rules may do to bodies.
    pub limits: ControlLimits,
    /// Capacity of the control channel, commands.
    pub control_capacity: usize,
    /// Capacity of the input channel, inputs.
    pub input_capacity: usize,
    /// Most control commands handled per loop.
    pub max_control_per_loop: usize,
    /// Most inputs handled per loop.
    pub max_inputs_per_loop: usize,
    /// Where to report tick durations, overruns, bodies and clients.
    pub metrics: Option<Metrics>,
    /// Where and how to record; `None`: this simulation cannot record.
    pub recording: Option<RecorderConfig>,
    /// Start recording as the simulation starts (needs `recording`).
    pub record_at_start: bool,
    /// Most bytes of keyframes and checkpoints held in memory for seeking
    /// (every tick's hash and journal entry are held beyond it; see
    /// [`crate::replay::history`]).
    pub history_budget: usize,
    /// While recording, a checkpoint of the whole state is held in memory
    /// every this many ticks (0: none), so a seek re-simulates at most
    /// that many ticks.
    pub checkpoint_ticks: u64,
}

impl Default for SimConfig {
    fn default() -> Self {
        Self::from(&ServerConfig::default())
    }
}

impl From<&ServerConfig> for SimConfig {
    fn from(c: &ServerConfig) -> Self {
        SimConfig {
            tick_hz: c.tick_hz,
            max_catch_up_ticks: c.max_catch_up_ticks,
            max_clients: c.max_clients,
            limits: ControlLimits::default(),
            control_capacity: 256,
            // Four seconds of 60 Hz inputs from every client.
            input_capacity: (c.max_clients as usize * 240).max(1024),
            max_control_per_loop: 64,
            max_inputs_per_loop: (c.max_clients as usize * 8).max(256),
            metrics: None,
            recording: None,
            record_at_start: false,
            history_budget: usize::try_from(c.seek_memory_mb << 20).unwrap_or(usize::MAX),
            checkpoint_ticks: c.checkpoint_ticks,
        }
    }
}

/// What the world looked like after a loop's ticks: the latest state of
/// every entity that can move, plus the catalog of all entities.
#[derive(Debug, Clone)]
pub struct Frame {
    /// Ticks completed (the world's tick).
    pub tick: u64,
    /// Simulation time, s (`tick × dt`).
    pub sim_time: f64,
    /// Simulation seconds per wall second now (0 while paused; negative
    /// while history plays backwards).
    pub time_scale: f64,
    /// Whether real-time ticking is paused.
    pub paused: bool,
    /// States of dynamic and kinematic bodies, free particles and anything
    /// teleported, sorted by id.
    pub entities: Vec<EntityState>,
    /// Every live entity's description; the same `Arc` until it changes.
    pub catalog: Arc<BTreeMap<EntityId, EntityDesc>>,
    /// Changes whenever the catalog does (compare, don't diff).
    pub catalog_version: u64,
    /// The most recent events (at most [`RECENT_EVENTS`]), oldest first,
    /// each with the tick it happened in; the same `Arc` until one
    /// happens.
    pub events: Arc<Vec<(u64, GameEvent)>>,
    /// Wall time of the last tick.
    pub tick_duration: Duration,
    /// Loops that hit the catch-up cap so far.
    pub overruns: u64,
    /// Clients in the game (live).
    pub clients: u32,
    /// The live world's tick (equal to `tick` unless history is shown).
    pub live_tick: u64,
    /// What the clock is showing: live, or which way through history.
    pub mode: TimeMode,
    /// `entities` quantized for snapshots, made by the first connection
    /// that codes this frame and shared by every other (see
    /// [`Frame::quantized`]).
    quantized: OnceLock<QuantizedFrame>,
}

impl Frame {
    /// This frame's entities and clock quantized under `config`, once for
    /// every client: the first caller quantizes, the rest share it. Every
    /// caller must pass the same config (the server has one).
    pub fn quantized(&self, config: &SnapshotConfig) -> &QuantizedFrame {
        self.quantized.get_or_init(|| {
            QuantizedFrame::new(
                self.tick,
                self.time_scale as f32,
                self.paused,
                &self.entities,
                config,
            )
        })
    }
}

/// What the simulation is showing.
pub use inertia_protocol::admin::TimeMode;

/// A command to the tick thread.
#[derive(Debug)]
pub enum Command {
    /// A client joins; the reply carries its avatar or the refusal.
    Join {
        /// The client.
        client: ClientId,
        /// Where the answer goes.
        reply: oneshot::Sender<Result<EntityId, Refusal>>,
    },
    /// A client left.
    Leave {
        /// The client.
        client: ClientId,
    },
    /// A client's input (goes through the input channel).
    Input {
        /// The client.
        client: ClientId,
        /// What it asks.
        input: PlayerInput,
    },
    /// Stop real-time ticking.
    Pause,
    /// Resume at the last non-zero time scale.
    Resume,
    /// Simulation seconds per wall second (0..=64; 0 pauses).
    SetTimeScale(f64),
    /// Run exactly this many ticks (while paused).
    Step(u64),
    /// Run up to this tick, then pause.
    RunTo(u64),
    /// Run a function on the tick thread, between ticks (the admin channel
    /// reads and edits the world this way).
    Call(SimCall),
    /// Stop the thread after publishing a last frame.
    Shutdown,
}

/// A function run on the tick thread with the [`Simulation`], between
/// ticks ([`SimHandle::call`]).
pub struct SimCall(pub Box<dyn FnOnce(&mut Simulation) + Send>);

impl std::fmt::Debug for SimCall {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("SimCall")
    }
}

/// Ticks whose durations [`Simulation::tick_p99`] looks at.
pub const TICK_WINDOW: usize = 600;
/// Wall time over which [`Simulation::achieved_rate`] counts ticks.
pub const RATE_WINDOW: Duration = Duration::from_secs(1);

/// Why a command was not delivered.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
pub enum CommandError {
    /// The channel is full: the tick thread is behind. Dropped; retry later.
    #[error("the simulation is busy; command dropped")]
    Busy,
    /// The tick thread has stopped.
    #[error("the simulation has stopped")]
    Stopped,
}

/// Counters shared with the tick thread (read at any time).
#[derive(Debug, Default)]
pub struct SimStats {
    /// Ticks run.
    pub ticks: AtomicU64,
    /// Loops that hit the catch-up cap.
    pub overruns: AtomicU64,
    /// Simulation ticks dropped by overruns.
    pub dropped_ticks: AtomicU64,
    /// Wall time of the last tick, ns.
    pub last_tick_ns: AtomicU64,
    /// Inputs refused by the rules.
    pub inputs_rejected: AtomicU64,
    /// Commands refused because a channel was full.
    pub commands_dropped: AtomicU64,
    /// Rigid bodies in the world.
    pub bodies: AtomicU64,
    /// Clients in the game.
    pub clients: AtomicU64,
    /// Physics steps that returned an error (should stay 0).
    pub step_errors: AtomicU64,
    /// Recordings stopped because the recorder dropped a record.
    pub record_gaps: AtomicU64,
}

/// The tick loop's state, without the thread.
pub struct Simulation {
    world: World,
    entities: EntityTable,
    spawn_points: Vec<DVec3>,
    rules: Box<dyn GameRules>,
    clock: Clock,
    config: SimConfig,
    clients: BTreeSet<ClientId>,
    catalog: Arc<BTreeMap<EntityId, EntityDesc>>,
    catalog_version: u64,
    ctx_events: Vec<GameEvent>,
    pending_events: Vec<(u64, GameEvent)>,
    recent_events: Arc<Vec<(u64, GameEvent)>>,
    last_tick: Duration,
    stats: Arc<SimStats>,
    /// Durations of the last [`TICK_WINDOW`] ticks.
    recent_ticks: VecDeque<Duration>,
    /// The first live ticks' cost against the budget, said once.
    startup: startup::TickCostCheck,
    /// When ticks ran lately, with how many, within [`RATE_WINDOW`].
    recent_runs: VecDeque<(Instant, u32)>,
    started: Instant,
    scene_name: String,
    recording: Option<Recording>,
    /// A stopped recorder whose thread may still be writing out.
    retired: Option<Recorder>,
    /// Journal entries of the current tick not yet handed to the recorder.
    journal: Vec<JournalEntry>,
    /// Journal entries of the current tick handed over so far.
    journal_at_tick: u32,
    /// The recording held in memory for seeking (kept when recording
    /// stops, until a recording that cannot follow it starts).
    history: Option<History>,
    /// While history is shown: the live state, put aside.
    view: Option<timeline::View>,
    /// The entity table version the catalog was last made from.
    catalog_seen: u64,
    /// The shown state was swapped: remake the catalog.
    catalog_stale: bool,
    /// A recorder is being opened off the tick thread.
    opening_recorder: bool,
    /// A tick is under way (still set after a panic inside one: the state
    /// is then half a tick and not worth a keyframe).
    in_tick: bool,
}

/// A recorder being opened off the tick thread
/// ([`Simulation::prepare_recording`]).
#[derive(Debug)]
pub struct RecorderOpening {
    config: RecorderConfig,
    first_tick: u64,
    retired: Option<Recorder>,
    metrics: Option<Metrics>,
}

impl RecorderOpening {
    /// Waits for an earlier recorder to write out, then opens the
    /// recording directory and starts the recorder thread (disk work: not
    /// on the tick thread).
    pub fn open(self) -> Result<Recorder, String> {
        if let Some(old) = self.retired {
            old.stop();
        }
        Recorder::start(self.config, self.first_tick, self.metrics).map_err(|e| e.to_string())
    }
}

/// A session being recorded.
struct Recording {
    recorder: Recorder,
}

impl std::fmt::Debug for Simulation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Simulation")
            .field("tick", &self.world.tick())
            .field("entities", &self.entities.len())
            .field("clients", &self.clients.len())
            .field("clock", &self.clock)
            .finish()
    }
}

impl Simulation {
    /// A simulation of a built scene under `rules`.
    pub fn new(scene: BuiltScene, rules: Box<dyn GameRules>, config: SimConfig) -> Self {
        let clock =
            Clock::new(config.tick_hz, config.max_catch_up_ticks).with_tick(scene.world.tick());
        let catalog = Arc::new(scene.entities.catalog());
        let catalog_version = scene.entities.version();
        let mut sim = Simulation {
            world: scene.world,
            entities: scene.entities,
            spawn_points: scene.spawn_points,
            rules,
            clock,
            startup: startup::TickCostCheck::new(config.tick_hz),
            config,
            clients: BTreeSet::new(),
            catalog,
            catalog_version,
            ctx_events: Vec::new(),
            pending_events: Vec::new(),
            recent_events: Arc::new(Vec::new()),
            last_tick: Duration::ZERO,
            stats: Arc::new(SimStats::default()),
            recent_ticks: VecDeque::with_capacity(TICK_WINDOW),
            recent_runs: VecDeque::new(),
            started: Instant::now(),
            scene_name: scene.name,
            recording: None,
            retired: None,
            journal: Vec::new(),
            journal_at_tick: 0,
            history: None,
            view: None,
            catalog_seen: catalog_version,
            catalog_stale: false,
            opening_recorder: false,
            in_tick: false,
        };
        sim.update_gauges();
        if sim.config.record_at_start {
            if let Err(e) = sim.start_recording() {
                tracing::error!(error = %e, "cannot record; running without a recording");
            }
        }
        sim
    }

    /// A simulation of a saved state (a keyframe or checkpoint), with a
    /// world of the default configuration.
    pub fn from_state(
        state: &SimState,
        rules: Box<dyn GameRules>,
        config: SimConfig,
    ) -> Result<Self, StateError> {
        let world = World::new(inertia_physics::WorldConfig::default())
            .map_err(|e| StateError::World(e.to_string()))?;
        let scene = BuiltScene {
            world,
            entities: EntityTable::new(),
            bodies_by_name: BTreeMap::new(),
            spawn_points: state.spawn_points.clone(),
            name: String::from("saved state"),
        };
        let mut sim = Simulation::new(
            scene,
            rules,
            SimConfig {
                record_at_start: false,
                ..config
            },
        );
        sim.restore(state)?;
        Ok(sim)
    }

    /// Whether this tick's state is being recorded.
    pub fn recording(&self) -> bool {
        self.recording.is_some()
    }

    /// The recorder, while recording.
    pub fn recorder(&self) -> Option<&Recorder> {
        self.recording.as_ref().map(|r| &r.recorder)
    }

    /// Where recordings go, if this simulation can record.
    pub fn recording_config(&self) -> Option<&RecorderConfig> {
        self.config.recording.as_ref()
    }

    /// Starts a recording session at the current tick: `SessionStart`,
    /// then a keyframe. Nothing happens when already recording.
    pub fn start_recording(&mut self) -> Result<(), String> {
        match self.prepare_recording()? {
            None => Ok(()),
            Some(opening) => {
                let recorder = opening.open();
                self.adopt_recorder(recorder)
            }
        }
    }

    /// The first half of starting a recording without touching the disk
    /// on the tick thread: what [`RecorderOpening::open`] needs (run it
    /// elsewhere, then [`Simulation::adopt_recorder`]). `None` when
    /// already recording.
    pub fn prepare_recording(&mut self) -> Result<Option<RecorderOpening>, String> {
        if self.recording.is_some() {
            return Ok(None);
        }
        if self.opening_recorder {
            return Err("a recording is being started already".into());
        }
        let Some(config) = self.config.recording.clone() else {
            return Err("this server has no recording directory".into());
        };
        if self.view.is_some() {
            return Err("history is being shown; go back to the live tick first".into());
        }
        self.opening_recorder = true;
        Ok(Some(RecorderOpening {
            config,
            first_tick: self.world.tick(),
            retired: self.retired.take(),
            metrics: self.config.metrics.clone(),
        }))
    }

    /// The second half: starts the session on the recorder opened (or
    /// reports why it could not be).
    pub fn adopt_recorder(&mut self, recorder: Result<Recorder, String>) -> Result<(), String> {
        self.opening_recorder = false;
        let recorder = recorder?;
        if self.recording.is_some() || self.view.is_some() {
            recorder.stop();
            return Err("the simulation changed while the recording was being opened".into());
        }
        let tick = self.world.tick();
        // Entries of this tick from before the session are in its keyframe.
        // A session that continues the history held (after `--resume`)
        // counts the ones already recorded for this tick.
        self.journal.clear();
        let budget = self.config.history_budget;
        let history = self.history.get_or_insert_with(|| History::new(budget));
        if recorder.moved_aside().is_some() || history.range().is_some_and(|(_, last)| last > tick)
        {
            // It belonged to a recording that was moved aside.
            *history = History::new(budget);
        }
        let continues = history.range().is_some_and(|(_, last)| last == tick);
        self.journal_at_tick = if continues {
            history.journal_at(tick).len() as u32
        } else {
            0
        };
        let applied = self.journal_at_tick;
        let state = Arc::new(self.capture(applied).encode());
        let start = Record::SessionStart {
            tick,
            tick_hz: self.config.tick_hz,
            scene: self.scene_name.clone(),
        };
        let keyframe = Record::Keyframe {
            tick,
            state: state.as_ref().clone(),
        };
        recorder
            .send(start)
            .and_then(|()| recorder.send(keyframe))
            .map_err(|e| e.to_string())?;
        if let Some(history) = &mut self.history {
            if !continues {
                history.start_session(tick);
            }
            history.add_keyframe(tick, applied, state);
        }
        self.recording = Some(Recording { recorder });
        Ok(())
    }

    /// The recording held in memory for seeking, if any.
    pub fn history(&self) -> Option<&History> {
        self.history.as_ref()
    }

    /// Stops recording (the recorder thread writes out and syncs what it
    /// has on its own; the tick thread does not wait for it).
    pub fn stop_recording(&mut self) {
        if let Some(mut rec) = self.recording.take() {
            rec.recorder.close();
            if let Some(old) = self.retired.replace(rec.recorder) {
                old.stop();
            }
        }
    }

    /// Ends the recording with a keyframe of the current tick and waits
    /// until everything is on disk (shutdown).
    pub fn finish_recording(&mut self) {
        if self.view.is_some() {
            self.go_live();
        }
        self.flush_journal();
        if let Some(rec) = self.recording.take() {
            let tick = self.world.tick();
            let state = self.capture(self.journal_at_tick).encode();
            rec.recorder.finish(Some(Record::Keyframe { tick, state }));
            tracing::info!(tick, "recording ended with a keyframe");
        }
        if let Some(old) = self.retired.take() {
            old.stop();
        }
    }

    /// Whether the state shown is whole: no tick was cut short, and every
    /// body's position and velocities are finite.
    pub fn state_is_sound(&self) -> bool {
        !self.in_tick
            && self.world.bodies().all(|(_, b)| {
                b.center_of_mass().is_finite()
                    && b.linear_velocity().is_finite()
                    && b.angular_velocity().is_finite()
            })
    }

    /// Ends the recording after a failure: with a keyframe of the current
    /// state if [it is sound](Self::state_is_sound), else with what the
    /// recorder has (the last whole tick). Returns whether a keyframe was
    /// written.
    pub fn end_after_failure(&mut self) -> bool {
        if self.state_is_sound() {
            let recording = self.recording.is_some();
            self.finish_recording();
            return recording;
        }
        if let Some(rec) = self.recording.take() {
            rec.recorder.finish(None);
            tracing::warn!(
                tick = self.world.tick(),
                "recording ended without a keyframe: the failure cut a tick short"
            );
        }
        if let Some(old) = self.retired.take() {
            old.stop();
        }
        false
    }

    /// Records an administrator's edit of the world at the current tick
    /// (`who` the operator, `what` a short description).
    pub fn record_admin_edit(&mut self, who: &str, what: &str) {
        let tick = self.world.tick();
        self.send_record(Record::AdminEdit {
            tick,
            who: who.to_string(),
            what: what.as_bytes().to_vec(),
        });
    }

    /// Hands a record to the recorder; a dropped one stops the recording.
    fn send_record(&mut self, record: Record) -> bool {
        let Some(rec) = &self.recording else {
            return false;
        };
        match rec.recorder.send(record) {
            Ok(()) => true,
            Err(e) => {
                self.stats.record_gaps.fetch_add(1, Ordering::Relaxed);
                tracing::error!(
                    error = %e,
                    tick = self.world.tick(),
                    "the recording has a gap and stops here; `record on` starts a new one"
                );
                self.stop_recording();
                false
            }
        }
    }

    /// Notes a change to the live simulation in the current tick's journal
    /// (while recording).
    fn journal_push(&mut self, entry: JournalEntry) {
        if self.recording.is_some() && self.view.is_none() {
            self.journal.push(entry);
        }
    }

    /// Hands the current tick's journal entries so far to the recorder
    /// and the history.
    pub fn flush_journal(&mut self) {
        if self.journal.is_empty() {
            return;
        }
        let entries = std::mem::take(&mut self.journal);
        let tick = self.world.tick();
        let bytes = crate::replay::journal::encode(tick, &entries);
        if self.send_record(Record::Journal {
            tick,
            entries: bytes,
        }) {
            self.journal_at_tick += entries.len() as u32;
            if let Some(h) = &mut self.history {
                h.add_journal(tick, &entries);
            }
        }
    }

    /// The records of the tick just run.
    fn record_tick(&mut self) {
        self.journal_at_tick = 0;
        let Some(rec) = &self.recording else {
            return;
        };
        let tick = self.world.tick();
        let keyframe_ticks = rec.recorder.config().keyframe_ticks.max(1);
        let hash = self.world.state_hash();
        if !self.send_record(Record::TickHash { tick, hash }) {
            return;
        }
        if let Some(h) = &mut self.history {
            h.add_hash(tick, hash);
        }
        let checkpoint_ticks = self.config.checkpoint_ticks;
        if tick % keyframe_ticks == 0 {
            let state = Arc::new(self.capture(0).encode());
            if self.send_record(Record::Keyframe {
                tick,
                state: state.as_ref().clone(),
            }) {
                if let Some(h) = &mut self.history {
                    h.add_keyframe(tick, 0, state);
                }
            }
        } else if checkpoint_ticks > 0 && tick % checkpoint_ticks == 0 {
            let state = self.capture(0).encode();
            if let Some(h) = &mut self.history {
                h.add_checkpoint(tick, state);
            }
        }
    }

    /// The whole state of what is shown now, with `applied` entries of
    /// the current tick's journal in it.
    pub fn capture(&self, applied: u32) -> SimState {
        SimState {
            tick: self.world.tick(),
            applied,
            world: self.world.save(),
            entities: self.entities.clone(),
            spawn_points: self.spawn_points.clone(),
            clients: self.clients.iter().copied().collect(),
            rules: self.rules.save_state(),
        }
    }

    /// The state to save in a checkpoint: the shown state, with every
    /// journal entry of its tick applied so far.
    pub fn checkpoint(&self) -> SimState {
        let applied = if self.view.is_some() {
            0
        } else {
            self.journal_at_tick + self.journal.len() as u32
        };
        self.capture(applied)
    }

    /// Makes `state` the shown state (the world, entities, clients, spawn
    /// points and rules). On error nothing changes.
    pub fn restore(&mut self, state: &SimState) -> Result<(), StateError> {
        let old_rules = self.rules.save_state();
        self.rules
            .restore_state(&state.rules)
            .map_err(StateError::Rules)?;
        if let Err(e) = self.world.restore(&state.world) {
            let _ = self.rules.restore_state(&old_rules);
            return Err(StateError::World(e.to_string()));
        }
        self.entities = state.entities.clone();
        self.spawn_points = state.spawn_points.clone();
        self.clients = state.clients.iter().copied().collect();
        self.clock = self.clock.clone().with_tick(state.tick);
        self.catalog_stale = true;
        self.update_gauges();
        Ok(())
    }

    /// Applies one journal entry to the shown state (as it was applied
    /// when recorded).
    pub fn apply_entry(&mut self, entry: &JournalEntry) {
        match entry {
            JournalEntry::Join(client) => {
                let _ = self.join_here(*client);
            }
            JournalEntry::Leave(client) => self.leave_here(*client),
            JournalEntry::Input(client, input) => {
                let _ = self.input_here(*client, input);
            }
            JournalEntry::Edit(edit) => {
                let _ = self.edit_here(edit);
            }
        }
    }

    /// The world.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// The entity table.
    pub fn entities(&self) -> &EntityTable {
        &self.entities
    }

    /// The clock.
    pub fn clock(&self) -> &Clock {
        &self.clock
    }

    /// The clock, to pause, scale or step it.
    pub fn clock_mut(&mut self) -> &mut Clock {
        &mut self.clock
    }

    /// The shared counters.
    pub fn stats(&self) -> Arc<SimStats> {
        self.stats.clone()
    }

    fn dt(&self) -> f64 {
        self.clock.dt()
    }

    fn with_ctx<R>(&mut self, f: impl FnOnce(&mut dyn GameRules, &mut SimContext<'_>) -> R) -> R {
        let tick = self.world.tick();
        let dt = self.dt();
        let mut ctx = SimContext::new(
            &mut self.world,
            &mut self.entities,
            &self.spawn_points,
            &mut self.ctx_events,
            tick,
            dt,
            self.config.limits,
        );
        f(self.rules.as_mut(), &mut ctx)
    }

    fn collect_events(&mut self) {
        let tick = self.world.tick();
        let mut events = std::mem::take(&mut self.ctx_events);
        events.extend(self.rules.events());
        self.pending_events
            .extend(events.into_iter().map(|e| (tick, e)));
    }

    /// A client joins (refused when full or already in). While history
    /// is shown the client joins the live world.
    pub fn join(&mut self, client: ClientId) -> Result<EntityId, Refusal> {
        if self.view.is_some() {
            return self.with_live(|s| s.join(client));
        }
        let r = self.join_here(client);
        if r.is_ok() {
            self.journal_push(JournalEntry::Join(client));
        }
        r
    }

    fn join_here(&mut self, client: ClientId) -> Result<EntityId, Refusal> {
        if self.clients.contains(&client) {
            return Err(Refusal::AlreadyJoined(client));
        }
        if self.clients.len() >= self.config.max_clients as usize {
            return Err(Refusal::Full {
                max: self.config.max_clients,
            });
        }
        let r = self.with_ctx(|rules, ctx| rules.on_connect(client, ctx));
        if r.is_ok() {
            self.clients.insert(client);
        }
        self.collect_events();
        self.update_gauges();
        r
    }

    /// A client leaves (unknown clients are ignored). While history is
    /// shown the client leaves the live world.
    pub fn leave(&mut self, client: ClientId) {
        if self.view.is_some() {
            return self.with_live(|s| s.leave(client));
        }
        if self.clients.contains(&client) {
            self.leave_here(client);
            self.journal_push(JournalEntry::Leave(client));
        }
    }

    fn leave_here(&mut self, client: ClientId) {
        if self.clients.remove(&client) {
            self.with_ctx(|rules, ctx| rules.on_disconnect(client, ctx));
            self.collect_events();
            self.update_gauges();
        }
    }

    /// A client's input, checked by the rules. Inputs that arrive while
    /// history is shown are dropped (the live world is not running).
    pub fn input(&mut self, client: ClientId, input: &PlayerInput) -> Result<(), InputError> {
        if self.view.is_some() {
            return Err(InputError::NotJoined(client));
        }
        let r = self.input_here(client, input);
        if r.is_ok() {
            self.journal_push(JournalEntry::Input(client, *input));
        }
        r
    }

    fn input_here(&mut self, client: ClientId, input: &PlayerInput) -> Result<(), InputError> {
        let r = if self.clients.contains(&client) {
            self.with_ctx(|rules, ctx| rules.on_input(client, input, ctx))
        } else {
            Err(InputError::NotJoined(client))
        };
        if r.is_err() {
            self.stats.inputs_rejected.fetch_add(1, Ordering::Relaxed);
            if let Some(m) = &self.config.metrics {
                m.inputs_rejected.inc();
            }
        }
        r
    }

    /// Runs one tick: rules, physics step, clean-up, rules.
    pub fn tick(&mut self) {
        let _span = tracing::debug_span!("tick", tick = self.world.tick() + 1).entered();
        self.flush_journal();
        self.in_tick = true;
        let t0 = Instant::now();
        self.with_ctx(|rules, ctx| rules.before_tick(ctx));
        let dt = self.dt();
        match self.world.step(dt) {
            Ok(report) => {
                for h in report.removed_bodies {
                    if let Some(id) = self.entities.remove_body(h) {
                        self.ctx_events.push(GameEvent::Removed {
                            entity: id,
                            reason: RemovalReason::OutOfBounds,
                        });
                    }
                }
                for h in report.quarantined_bodies {
                    let _ = self.world.remove_body(h);
                    if let Some(id) = self.entities.remove_body(h) {
                        self.ctx_events.push(GameEvent::Removed {
                            entity: id,
                            reason: RemovalReason::Quarantined,
                        });
                    }
                }
                for h in report.quarantined {
                    let _ = self.world.remove_particle(h);
                    if let Some(id) = self.entities.by_particle(h) {
                        self.entities.remove(id);
                        self.ctx_events.push(GameEvent::Removed {
                            entity: id,
                            reason: RemovalReason::Quarantined,
                        });
                    }
                }
            }
            Err(e) => {
                // Only a bad dt fails a step, and dt is fixed and checked.
                self.stats.step_errors.fetch_add(1, Ordering::Relaxed);
                tracing::error!(error = %e, "physics step failed");
            }
        }
        self.with_ctx(|rules, ctx| rules.after_tick(ctx));
        self.collect_events();
        self.in_tick = false;
        self.last_tick = t0.elapsed();
        if self.view.is_none() {
            self.record_tick();
            if let Some(cost) = self.startup.observe(self.last_tick) {
                self.say_startup_cost(cost);
            }
        }
        if self.recent_ticks.len() == TICK_WINDOW {
            self.recent_ticks.pop_front();
        }
        self.recent_ticks.push_back(self.last_tick);
        self.stats.ticks.fetch_add(1, Ordering::Relaxed);
        self.stats
            .last_tick_ns
            .store(self.last_tick.as_nanos() as u64, Ordering::Relaxed);
        if let Some(m) = &self.config.metrics {
            m.tick_duration.observe(self.last_tick.as_secs_f64());
        }
    }

    /// Logs what the first live ticks cost against the tick budget: a
    /// warning when the machine cannot keep the configured rate.
    fn say_startup_cost(&self, cost: startup::TickCost) {
        let bodies = self.world.bodies().count();
        let median_ms = cost.median.as_secs_f64() * 1e3;
        let budget_ms = cost.budget.as_secs_f64() * 1e3;
        let percent = cost.share() * 100.0;
        if cost.over_budget() {
            tracing::warn!(
                ticks = cost.ticks,
                median_ms,
                budget_ms,
                bodies,
                "the first {} ticks took {median_ms:.1} ms each (median), {percent:.0} % of the \
                 {budget_ms:.1} ms tick budget: with {bodies} rigid bodies this machine steps \
                 about {:.1} ticks a second, not {}, and the world runs slower than real time; \
                 lower the body count (--max-bodies) or the tick rate, or give the server more CPU",
                cost.ticks,
                cost.sustainable_hz(),
                self.config.tick_hz,
            );
        } else {
            tracing::info!(
                ticks = cost.ticks,
                median_ms,
                budget_ms,
                bodies,
                "the first {} ticks took {median_ms:.2} ms each (median), {percent:.0} % of the \
                 {budget_ms:.1} ms tick budget",
                cost.ticks,
            );
        }
    }

    /// What the first live ticks cost against the tick budget, once
    /// [`startup::STARTUP_TICKS`] have run.
    pub fn startup_cost(&self) -> Option<startup::TickCost> {
        self.startup.verdict()
    }

    /// Runs `n` ticks now, whatever the clock says.
    pub fn run_ticks(&mut self, n: u64) {
        for _ in 0..n {
            self.run_due(1);
        }
        self.update_gauges();
    }

    /// Feeds `wall_elapsed` to the clock and runs the ticks it owes.
    /// Returns how many ran.
    pub fn advance(&mut self, wall_elapsed: Duration) -> u32 {
        let before = self.clock.overruns();
        let n = self.clock.advance(wall_elapsed);
        self.run_due(n);
        let now = Instant::now();
        if n > 0 {
            self.recent_runs.push_back((now, n));
        }
        while self
            .recent_runs
            .front()
            .is_some_and(|(t, _)| now.duration_since(*t) > RATE_WINDOW)
        {
            self.recent_runs.pop_front();
        }
        let overruns = self.clock.overruns() - before;
        if overruns > 0 {
            self.stats.overruns.fetch_add(overruns, Ordering::Relaxed);
            self.stats
                .dropped_ticks
                .store(self.clock.dropped_ticks(), Ordering::Relaxed);
            if let Some(m) = &self.config.metrics {
                m.tick_overruns.inc_by(overruns);
            }
        }
        self.update_gauges();
        n
    }

    /// The 64-bit state hash of the world now.
    pub fn state_hash(&self) -> u64 {
        self.world.state_hash()
    }

    /// The 99th percentile of the last [`TICK_WINDOW`] tick durations
    /// (zero before the first tick).
    pub fn tick_p99(&self) -> Duration {
        let mut d: Vec<Duration> = self.recent_ticks.iter().copied().collect();
        if d.is_empty() {
            return Duration::ZERO;
        }
        d.sort_unstable();
        let i = ((d.len() as f64 * 0.99).ceil() as usize).clamp(1, d.len()) - 1;
        d[i]
    }

    /// Ticks run by the clock per wall second over the last
    /// [`RATE_WINDOW`] (or since start, if shorter), Hz.
    pub fn achieved_rate(&self) -> f64 {
        let now = Instant::now();
        let ran: u64 = self
            .recent_runs
            .iter()
            .filter(|(t, _)| now.duration_since(*t) <= RATE_WINDOW)
            .map(|(_, n)| u64::from(*n))
            .sum();
        let span = now.duration_since(self.started).min(RATE_WINDOW);
        if span.is_zero() {
            return 0.0;
        }
        ran as f64 / span.as_secs_f64()
    }

    /// Clients in the live game.
    pub fn client_count(&self) -> usize {
        self.live_clients()
    }

    fn update_gauges(&self) {
        let bodies = self.world.bodies().count() as u64;
        self.stats.bodies.store(bodies, Ordering::Relaxed);
        self.stats
            .clients
            .store(self.live_clients() as u64, Ordering::Relaxed);
        if let Some(m) = &self.config.metrics {
            m.bodies.set(bodies as i64);
            m.connected_clients.set(self.live_clients() as i64);
            if let Some(h) = &self.history {
                m.set_seek_memory(&h.held());
            }
        }
    }

    /// The frame of the current state, with the most recent
    /// [`RECENT_EVENTS`] events (so a reader that skipped frames still sees
    /// every event, as long as it keeps up within that many).
    pub fn frame(&mut self) -> Frame {
        if !self.pending_events.is_empty() {
            let mut recent: Vec<(u64, GameEvent)> = self.recent_events.as_ref().clone();
            recent.append(&mut self.pending_events);
            let excess = recent.len().saturating_sub(RECENT_EVENTS);
            recent.drain(..excess);
            self.recent_events = Arc::new(recent);
        }
        if self.catalog_stale || self.entities.version() != self.catalog_seen {
            self.catalog = Arc::new(self.entities.catalog());
            self.catalog_seen = self.entities.version();
            self.catalog_version += 1;
            self.catalog_stale = false;
        }
        Frame {
            tick: self.world.tick(),
            sim_time: self.world.time(),
            time_scale: match self.mode() {
                // Clients play backwards where the scale is negative.
                TimeMode::Reverse => -self.clock.time_scale(),
                _ => self.clock.time_scale(),
            },
            paused: self.clock.paused(),
            entities: self.entities.states(&self.world),
            catalog: self.catalog.clone(),
            catalog_version: self.catalog_version,
            events: self.recent_events.clone(),
            tick_duration: self.last_tick,
            overruns: self.clock.overruns(),
            clients: self.live_clients() as u32,
            live_tick: self.live_tick(),
            mode: self.mode(),
            quantized: OnceLock::new(),
        }
    }

    /// Applies one command; false for [`Command::Shutdown`].
    pub fn apply(&mut self, cmd: Command) -> bool {
        match cmd {
            Command::Join { client, reply } => {
                let r = self.join(client);
                // The asker may have given up; the avatar stays until Leave.
                let _ = reply.send(r);
            }
            Command::Leave { client } => self.leave(client),
            Command::Input { client, input } => {
                let _ = self.input(client, &input);
            }
            Command::Pause => self.clock.pause(),
            Command::Resume => self.clock.resume(),
            Command::SetTimeScale(s) => {
                if let Err(e) = self.clock.set_time_scale(s) {
                    tracing::warn!(error = %e, "time scale refused");
                }
            }
            Command::Step(n) => {
                if let Err(e) = self.clock.step(n) {
                    tracing::warn!(error = %e, "step refused");
                }
            }
            Command::RunTo(t) => {
                if let Err(e) = self.clock.run_to(t) {
                    tracing::warn!(error = %e, "run_to refused");
                }
            }
            Command::Call(SimCall(f)) => f(self),
            Command::Shutdown => return false,
        }
        true
    }
}

/// How the tick thread ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum SimExit {
    /// It was asked to stop ([`SimHandle::shutdown`], or every handle
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

/// The network layer's handle on the tick thread. Dropping it stops the
/// thread (after its current loop); [`SimHandle::shutdown`] also waits,
/// and [`SimHandle::stop_within`] waits a bounded time.
#[derive(Debug)]
pub struct SimHandle {
    control: SyncSender<Command>,
    inputs: SyncSender<(ClientId, PlayerInput)>,
    frames: watch::Receiver<Arc<Frame>>,
    catalog: watch::Receiver<u64>,
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
        let (input_tx, input_rx) = mpsc::sync_channel(sim.config.input_capacity.max(1));
        let stats = sim.stats();
        let (frame_tx, frame_rx) = watch::channel(Arc::new(sim.frame()));
        let (catalog_tx, catalog_rx) = watch::channel(0);
        let (exit_tx, exit_rx) = watch::channel(None);
        let stopping = Arc::new(AtomicBool::new(false));
        let stop = stopping.clone();
        let publisher = Publisher {
            frames: frame_tx,
            catalog: catalog_tx,
        };
        let thread = std::thread::Builder::new()
            .name("inertia-tick".into())
            .spawn(move || {
                if let Err(e) = crate::priority::raise_tick_thread() {
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
            frames: frame_rx,
            catalog: catalog_rx,
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
            cmd => self.send(cmd),
        }
    }

    /// Asks for a client to join; await the answer on the receiver.
    pub fn request_join(
        &self,
        client: ClientId,
    ) -> Result<oneshot::Receiver<Result<EntityId, Refusal>>, CommandError> {
        let (reply, rx) = oneshot::channel();
        self.send(Command::Join { client, reply })?;
        Ok(rx)
    }

    /// A client joins: its avatar's entity id, or why not.
    pub async fn join(&self, client: ClientId) -> Result<EntityId, Refusal> {
        let rx = self
            .request_join(client)
            .map_err(|_| Refusal::Unavailable)?;
        rx.await.unwrap_or(Err(Refusal::Unavailable))
    }

    /// [`SimHandle::join`] for threads outside an async runtime (panics
    /// inside one, like `oneshot::Receiver::blocking_recv`).
    pub fn join_blocking(&self, client: ClientId) -> Result<EntityId, Refusal> {
        let rx = self
            .request_join(client)
            .map_err(|_| Refusal::Unavailable)?;
        rx.blocking_recv().unwrap_or(Err(Refusal::Unavailable))
    }

    /// A client left.
    pub fn leave(&self, client: ClientId) -> Result<(), CommandError> {
        self.send(Command::Leave { client })
    }

    /// A client's input; dropped (and counted) when the channel is full.
    pub fn input(&self, client: ClientId, input: PlayerInput) -> Result<(), CommandError> {
        self.inputs.try_send((client, input)).map_err(|e| match e {
            TrySendError::Full(_) => {
                self.stats.commands_dropped.fetch_add(1, Ordering::Relaxed);
                CommandError::Busy
            }
            TrySendError::Disconnected(_) => CommandError::Stopped,
        })
    }

    /// Stops real-time ticking.
    pub fn pause(&self) -> Result<(), CommandError> {
        self.send(Command::Pause)
    }

    /// Resumes at the last non-zero time scale.
    pub fn resume(&self) -> Result<(), CommandError> {
        self.send(Command::Resume)
    }

    /// Simulation seconds per wall second (0..=64; 0 pauses).
    pub fn set_time_scale(&self, scale: f64) -> Result<(), CommandError> {
        self.send(Command::SetTimeScale(scale))
    }

    /// Runs exactly `n` ticks (use while paused).
    pub fn step(&self, n: u64) -> Result<(), CommandError> {
        self.send(Command::Step(n))
    }

    /// Runs up to `tick`, then pauses.
    pub fn run_to(&self, tick: u64) -> Result<(), CommandError> {
        self.send(Command::RunTo(tick))
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

    /// A receiver that wakes only when a frame's catalog or events differ
    /// from the frame before (read the frame with [`SimHandle::frame`]):
    /// for a task per client that keeps the client's catalog, which would
    /// otherwise wake at every tick for nothing.
    pub fn subscribe_catalog(&self) -> watch::Receiver<u64> {
        self.catalog.clone()
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

/// Longest sleep between loops while paused, so the loop notices closed
/// channels.
const IDLE_WAIT: Duration = Duration::from_millis(50);

/// The tick thread: the loop, then the end of the recording. A panic
/// anywhere in the loop (a tick, a command, an admin call) is caught here
/// and reported on `exit`, so the server can fail its health checks, tell
/// the clients and exit for a restart instead of serving a frozen world.
fn run(
    mut sim: Simulation,
    control: Receiver<Command>,
    inputs: Receiver<(ClientId, PlayerInput)>,
    frames: Publisher,
    exit: watch::Sender<Option<SimExit>>,
    stopping: &AtomicBool,
) {
    let looped = panic::catch_unwind(AssertUnwindSafe(|| {
        run_loop(&mut sim, control, inputs, &frames, stopping)
    }));
    let outcome = match looped {
        Ok(()) => match panic::catch_unwind(AssertUnwindSafe(|| sim.finish_recording())) {
            Ok(()) => SimExit::Shutdown,
            Err(payload) => SimExit::Failed {
                reason: panic_message(payload.as_ref()),
                tick: sim.world.tick(),
                keyframe: false,
            },
        },
        Err(payload) => {
            let reason = panic_message(payload.as_ref());
            let tick = sim.world.tick();
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

/// Where the tick thread's frames go: every frame to `frames`, and a
/// count in `catalog` that moves only when a frame's catalog or events
/// differ from the frame before.
struct Publisher {
    frames: watch::Sender<Arc<Frame>>,
    catalog: watch::Sender<u64>,
}

impl Publisher {
    fn publish(&self, frame: Frame) {
        let frame = Arc::new(frame);
        let old = self.frames.send_replace(frame.clone());
        if old.catalog_version != frame.catalog_version || !Arc::ptr_eq(&old.events, &frame.events)
        {
            self.catalog.send_modify(|n| *n = n.wrapping_add(1));
        }
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
    inputs: Receiver<(ClientId, PlayerInput)>,
    frames: &Publisher,
    stopping: &AtomicBool,
) {
    let mut last = Instant::now();
    let mut early: Option<Command> = None;
    loop {
        if stopping.load(Ordering::SeqCst) {
            break;
        }
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
                        frames.publish(sim.frame());
                        return;
                    }
                }
                Err(TryRecvError::Empty) => break,
                Err(TryRecvError::Disconnected) => return,
            }
        }
        for _ in 0..sim.config.max_inputs_per_loop {
            match inputs.try_recv() {
                Ok((client, input)) => {
                    let _ = sim.input(client, &input);
                }
                Err(_) => break,
            }
        }
        let now = Instant::now();
        let ran = sim.advance(now - last);
        last = now;
        // What changed between ticks (joins, edits while paused) reaches
        // the recording now, not at the next tick.
        sim.flush_journal();
        if ran > 0 || changed {
            frames.publish(sim.frame());
        }
        let wait = sim
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
    frames.publish(sim.frame());
}
