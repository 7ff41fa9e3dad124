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
//! run each tick as its named, timed stages ([`Simulation::tick`]: inputs,
//! rules before, physics, rules after, record) → publish one frame → sleep
//! on the control channel until the next tick is due.
//!
//! [`Simulation`] is that loop's state without the thread, for tests and
//! tools that want to drive ticks by hand. It is a handful of explicit
//! parts, each in its own file, that the tick's stages and the commands
//! work on: the timelines (live, and history shown), the rules, the input
//! schedule, the recording, the publication of frames and the meter.
//!
//! While recording (see [`crate::record::recorder`]), everything that
//! changes the simulation between ticks — joins, leaves, accepted inputs
//! and messages, live edits — goes into the tick's journal (`Journal` records, written
//! once a loop and before each tick); after each tick the recorder gets
//! its state hash (`TickHash`) and, every
//! [`RecorderConfig::keyframe_ticks`] ticks, the whole
//! [`SimState`](crate::replay::SimState) (`Keyframe`). A session starts
//! with `SessionStart` and a keyframe; the thread's shutdown ends it with a
//! keyframe of the last tick. The same records go into an in-memory
//! [`History`](crate::replay::History) that seeking uses (see
//! [`time_travel`]). The tick thread never
//! waits on the disk: a record the recorder cannot take stops the
//! recording (a gap would break replay).
//!
//! The module is laid out by concept. The parts: `timeline.rs` (the live
//! timeline and the one shown), [`input_schedule`] (inputs waiting for
//! their ticks), [`recording`] (the recording state machine and the
//! journal), [`message_queue`] (clients' messages waiting for the next
//! tick), `publication.rs` (the rules' messages and the catalog for
//! frames) and `meter.rs` (what ticks cost; [`stats`] the counters it shares). What
//! works on them: [`tick`] (one tick's stages and the clock),
//! [`time_travel`] (showing history), [`edit`] (live edits),
//! [`clock_control`] (the one path for pause, speed, step and run-to),
//! [`resume`] (carrying on after a crash) and [`verify`] (re-simulating a
//! recording). Around them: [`config`] (how the loop runs), [`frame`]
//! (what it publishes), [`command`] (what it is asked), [`handle`] (the
//! network layer's side) and [`thread`] (the loop itself).

use std::collections::{BTreeMap, BTreeSet};
use std::sync::Arc;

use inertia_physics::World;
use inertia_protocol::connection::ReceivedMessage;
use inertia_protocol::message::{Delivery, MessageRefusal};
use inertia_protocol::{EntityId, PlayerInput};

use crate::clock::Clock;
use crate::pose_history::PoseHistory;
use crate::properties::PropertyStore;
use crate::replay::{JournalEntry, SimState, StateError};
use crate::rules::{
    ClientId, GameRules, InputRefusal, JoinRefusal, OutgoingMessage, RemovalReason, SimContext,
};
use crate::scene::{BuiltScene, EntityTable};
use meter::TickMeter;
use publication::Publication;
use recording::Recording;
use timeline::{Timeline, Timelines};

pub mod clock_control;
pub mod command;
pub mod config;
pub mod edit;
pub mod frame;
pub mod handle;
pub mod input_schedule;
pub mod message_queue;
mod meter;
mod publication;
pub mod recording;
pub mod resume;
pub mod startup;
pub mod stats;
pub mod thread;
pub mod tick;
pub mod time_travel;
mod timeline;
pub mod verify;

pub use clock_control::ClockControl;
pub use command::{Command, CommandError, FromClient, JoinedAt, SimCall};
pub use config::{SimConfig, DEFAULT_CHECKPOINT_TICKS};
pub use edit::EditError;
pub use frame::{CatalogChange, Frame, RecentMessage, RECENT_CATALOG_CHANGES, RECENT_MESSAGES};
pub use handle::{spawn, SimHandle};
pub use input_schedule::{InputSchedule, Offered, ScheduleConfig};
pub use message_queue::{MessageQueue, MAX_WAITING_MESSAGES};
pub use meter::TickStages;
pub use recording::RecorderOpening;
pub use stats::{SimStats, RATE_WINDOW, TICK_WINDOW};
pub use thread::SimExit;

/// What the simulation is showing.
pub use inertia_protocol::admin::TimeMode;

/// The tick loop's state, without the thread: explicit parts, each with
/// its own file, that the tick and the commands work on.
pub struct Simulation {
    /// The live timeline, and history shown in its place
    /// ([`timeline`], [`time_travel`]).
    timelines: Timelines,
    /// The game rules; their own state is that of the timeline shown
    /// (the live one's is put aside in the [`time_travel::ShownHistory`]
    /// meanwhile).
    rules: Box<dyn GameRules>,
    /// Messages the rules sent in the current call.
    sent: Vec<OutgoingMessage>,
    /// What left the world unasked in the current tick, for the rules'
    /// `on_removed`.
    removed: Vec<(EntityId, RemovalReason)>,
    /// The live clients' inputs waiting for their ticks
    /// ([`input_schedule`]).
    inputs: InputSchedule,
    /// The live clients' messages waiting for the next tick
    /// ([`message_queue`]).
    messages: MessageQueue,
    /// The recording, the current tick's journal and the history held
    /// for seeking ([`recording`]).
    recording: Recording,
    /// What frames are published from besides the timeline shown
    /// ([`publication`]).
    publication: Publication,
    /// What ticks and their stages cost, and the shared counters
    /// ([`meter`]).
    meter: TickMeter,
    config: SimConfig,
    scene_name: String,
    /// A tick is under way (still set after a panic inside one: the state
    /// is then half a tick and not worth a keyframe).
    in_tick: bool,
}

/// Ticks of pose window the rules ask for, within the configured cap.
fn rewind_window(rules: &dyn GameRules, config: &SimConfig) -> usize {
    crate::pose_history::rewind_ticks(
        rules.rewind_window_ms().min(config.max_rewind_ms),
        config.tick_hz,
    )
}

/// The whole state of timeline `shown` under `rules`, with `applied`
/// entries of the current tick's journal in it.
fn capture(shown: &Timeline, rules: &dyn GameRules, applied: u32) -> SimState {
    SimState {
        tick: shown.world.tick(),
        applied,
        world: shown.world.save(),
        entities: shown.entities.clone(),
        spawn_points: shown.spawn_points.clone(),
        clients: shown.clients.iter().copied().collect(),
        rules: rules.save_state(),
        poses: Some(shown.poses.clone()),
        properties: shown.properties.to_bytes(),
    }
}

impl std::fmt::Debug for Simulation {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Simulation")
            .field("tick", &self.shown().world.tick())
            .field("entities", &self.shown().entities.len())
            .field("clients", &self.shown().clients.len())
            .field("clock", &self.shown().clock)
            .finish()
    }
}

impl Simulation {
    /// The timeline shown, ticked and streamed: history while it is
    /// shown, else the live one.
    fn shown(&self) -> &Timeline {
        self.timelines.shown()
    }

    /// [`Self::shown`], to change.
    fn shown_mut(&mut self) -> &mut Timeline {
        self.timelines.shown_mut()
    }

    /// A simulation of a built scene under `rules`.
    pub fn new(scene: BuiltScene, rules: Box<dyn GameRules>, config: SimConfig) -> Self {
        let clock =
            Clock::new(config.tick_hz, config.max_catch_up_ticks).with_tick(scene.world.tick());
        let mut poses = PoseHistory::new(rewind_window(rules.as_ref(), &config));
        // A schema the protocol refuses is no schema (the server checks it
        // before it starts one).
        let properties = Some(rules.properties())
            .filter(|s| s.validate().is_ok())
            .unwrap_or_default();
        poses.record(scene.world.tick(), &scene.world, &scene.entities);
        let mut sim = Simulation {
            publication: Publication::new(&scene.entities),
            timelines: Timelines {
                live: Timeline {
                    world: scene.world,
                    entities: scene.entities,
                    clients: BTreeSet::new(),
                    spawn_points: scene.spawn_points,
                    clock,
                    poses,
                    properties: PropertyStore::new(Arc::new(properties)),
                },
                past: None,
            },
            rules,
            sent: Vec::new(),
            removed: Vec::new(),
            messages: MessageQueue::default(),
            inputs: InputSchedule::new(ScheduleConfig::for_tick_rate(config.tick_hz)),
            recording: Recording::new(&config),
            meter: TickMeter::new(config.tick_hz, config.metrics.clone()),
            config,
            scene_name: scene.name,
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
            soft_bodies_by_name: BTreeMap::new(),
            fluids_by_name: BTreeMap::new(),
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

    /// The whole state of what is shown now, with `applied` entries of
    /// the current tick's journal in it.
    pub fn capture(&self, applied: u32) -> SimState {
        capture(self.shown(), self.rules.as_ref(), applied)
    }

    /// The state to save in a checkpoint: the shown state, with every
    /// journal entry of its tick applied so far.
    pub fn checkpoint(&self) -> SimState {
        let applied = if self.timelines.is_live() {
            self.recording.applied_at_tick()
        } else {
            0
        };
        self.capture(applied)
    }

    /// Makes `state` the shown state (the world, entities, clients, spawn
    /// points and rules). On error nothing changes.
    pub fn restore(&mut self, state: &SimState) -> Result<(), StateError> {
        let mut properties = self.shown().properties.clone();
        properties
            .restore(&state.properties)
            .map_err(StateError::Properties)?;
        let old_rules = self.rules.save_state();
        self.rules
            .restore_state(&state.rules)
            .map_err(StateError::Rules)?;
        if let Err(e) = self.shown_mut().world.restore(&state.world) {
            let _ = self.rules.restore_state(&old_rules);
            return Err(StateError::World(e.to_string()));
        }
        let window = rewind_window(self.rules.as_ref(), &self.config);
        let shown = self.shown_mut();
        shown.properties = properties;
        shown.entities = state.entities.clone();
        shown.spawn_points = state.spawn_points.clone();
        shown.clients = state.clients.iter().copied().collect();
        shown.clock = shown.clock.clone().with_tick(state.tick);
        // The state's window, with its own capacity: re-simulation must
        // reach back exactly as far as the run that saved it. A state
        // without one (a fresh scene, format version 1) starts a window
        // of the configured length at its tick.
        match &state.poses {
            Some(poses) => shown.poses = poses.clone(),
            None => shown.poses = PoseHistory::new(window),
        }
        let shown = self.timelines.shown_mut();
        if shown
            .poses
            .span()
            .is_none_or(|(_, newest)| newest != state.tick)
        {
            shown
                .poses
                .record(state.tick, &shown.world, &shown.entities);
        }
        self.publication.timeline_swapped();
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
            JournalEntry::Message(client, delivery, bytes) => {
                let _ = self.message_here(*client, *delivery, bytes);
            }
            JournalEntry::Edit(edit) => {
                let _ = self.edit_here(edit);
            }
        }
    }

    /// The world.
    pub fn world(&self) -> &World {
        &self.shown().world
    }

    /// The entity table.
    pub fn entities(&self) -> &EntityTable {
        &self.shown().entities
    }

    /// The clock.
    pub fn clock(&self) -> &Clock {
        &self.shown().clock
    }

    /// The clock, to pause, scale or step it.
    pub fn clock_mut(&mut self) -> &mut Clock {
        &mut self.shown_mut().clock
    }

    /// Replaces the world with a freshly built scene, as [`Self::load`]
    /// replaces it with a checkpoint: the rules keep their state, nobody is
    /// in the new world until the connected clients join it again, and a
    /// recording goes on as a new session. Returns the new state hash.
    pub fn load_scene(&mut self, built: BuiltScene, operator: &str) -> Result<u64, StateError> {
        let state = SimState {
            tick: built.world.tick(),
            applied: 0,
            world: built.world.save(),
            entities: built.entities,
            spawn_points: built.spawn_points,
            clients: Vec::new(),
            rules: self.rules.save_state(),
            poses: None,
            properties: Vec::new(),
        };
        self.load(&state, operator)
    }

    /// Hands an allocation's match settings to the game rules
    /// ([`GameRules::configure_match`]), on the live timeline. While
    /// recording, the recording restarts so its new session begins with a
    /// keyframe holding the rules as configured (as a `load` does).
    pub fn configure_match(
        &mut self,
        settings: &crate::orchestrator::MatchSettings,
    ) -> Result<(), String> {
        self.go_live();
        self.flush_journal();
        self.with_ctx(|rules, ctx| rules.configure_match(settings, ctx))?;
        if self.recording.is_on() {
            self.record_admin_edit("allocation", "match configured");
            self.stop_recording();
            self.start_recording()?;
        }
        Ok(())
    }

    /// Whether the game rules have ended the match, and why: asked of the
    /// live timeline only (history shown never ends it).
    pub fn match_over(&self) -> Option<String> {
        if self.timelines.past.is_some() {
            return None;
        }
        let mut why = self.rules.match_over()?;
        inertia_protocol::control::truncate_utf8(
            &mut why,
            inertia_protocol::control::MAX_REASON_BYTES,
        );
        Some(why)
    }

    /// The shared counters.
    pub fn stats(&self) -> Arc<SimStats> {
        self.meter.stats().clone()
    }

    fn dt(&self) -> f64 {
        self.shown().clock.dt()
    }

    fn with_ctx<R>(&mut self, f: impl FnOnce(&mut dyn GameRules, &mut SimContext<'_>) -> R) -> R {
        let tick = self.shown().world.tick();
        let dt = self.dt();
        // The shown timeline, borrowed apart from the rules and messages.
        let shown = self.timelines.shown_mut();
        let parts = crate::rules::TimelineParts {
            world: &mut shown.world,
            entities: &mut shown.entities,
            spawn_points: &shown.spawn_points,
            properties: &mut shown.properties,
        };
        let mut ctx = SimContext::new(parts, &mut self.sent, tick, dt, self.config.limits)
            .with_poses(&shown.poses);
        let r = f(self.rules.as_mut(), &mut ctx);
        let rewinds = ctx.rewinds();
        self.meter.rewound(rewinds.asked, rewinds.clamped);
        r
    }

    /// The moving bodies' poses kept for lag compensation (of the
    /// timeline shown).
    pub fn pose_history(&self) -> &PoseHistory {
        &self.shown().poses
    }

    /// The number the next message the rules send will get
    /// ([`RecentMessage::number`]).
    pub fn next_message_number(&self) -> u64 {
        self.publication.next_number() + self.sent.len() as u64
    }

    /// Hands the messages the rules sent to the next frame.
    fn collect_messages(&mut self) {
        if !self.sent.is_empty() {
            let tick = self.shown().world.tick();
            self.publication.push_messages(tick, self.sent.drain(..));
        }
    }

    /// Tells the rules what left the world unasked since the last call.
    fn tell_removed(&mut self) {
        for (entity, reason) in std::mem::take(&mut self.removed) {
            self.with_ctx(|rules, ctx| rules.on_removed(entity, reason, ctx));
        }
    }

    /// A client joins (refused when full or already in). While history
    /// is shown the client joins the live world.
    pub fn join(&mut self, client: ClientId) -> Result<EntityId, JoinRefusal> {
        if self.timelines.past.is_some() {
            return self.with_live(|s| s.join(client));
        }
        let r = self.join_here(client);
        if r.is_ok() {
            self.journal_push(JournalEntry::Join(client));
        }
        r
    }

    fn join_here(&mut self, client: ClientId) -> Result<EntityId, JoinRefusal> {
        if self.shown().clients.contains(&client) {
            return Err(JoinRefusal::AlreadyJoined(client));
        }
        if self.shown().clients.len() >= self.config.max_clients as usize {
            return Err(JoinRefusal::Full {
                max: self.config.max_clients,
            });
        }
        let r = self.with_ctx(|rules, ctx| rules.on_connect(client, ctx));
        if r.is_ok() {
            self.shown_mut().clients.insert(client);
        }
        self.collect_messages();
        self.update_gauges();
        r
    }

    /// A client leaves (unknown clients are ignored). While history is
    /// shown the client leaves the live world.
    pub fn leave(&mut self, client: ClientId) {
        if self.timelines.past.is_some() {
            return self.with_live(|s| s.leave(client));
        }
        if self.shown().clients.contains(&client) {
            self.leave_here(client);
            self.journal_push(JournalEntry::Leave(client));
        }
    }

    fn leave_here(&mut self, client: ClientId) {
        if self.timelines.past.is_none() {
            self.inputs.forget(client);
            self.messages.forget(client);
        }
        if self.shown_mut().clients.remove(&client) {
            self.meter.client_left(client);
            self.with_ctx(|rules, ctx| rules.on_disconnect(client, ctx));
            self.collect_messages();
            self.update_gauges();
        }
    }

    /// A client's input, as it arrives: held until the tick it is for
    /// (see [`input_schedule`]) and then checked and applied by the rules;
    /// one whose tick has passed is applied at once. Inputs that arrive
    /// while history is shown are dropped (the live world is not running).
    pub fn input(&mut self, client: ClientId, input: &PlayerInput) -> Result<(), InputRefusal> {
        if self.timelines.past.is_some() || !self.timelines.live.clients.contains(&client) {
            return self.refused(client, InputRefusal::NotJoined(client));
        }
        let now = self.timelines.live.world.tick();
        match self.inputs.offer(client, input, now) {
            Offered::Held => Ok(()),
            Offered::Late => self.apply_input(client, input),
            Offered::TooLate => self.refused(
                client,
                InputRefusal::Stale {
                    tick: input.tick,
                    now,
                },
            ),
            Offered::TooEarly => self.refused(
                client,
                InputRefusal::Future {
                    tick: input.tick,
                    now,
                },
            ),
            Offered::Full => {
                let max = self.inputs.config().max_pending;
                self.refused(client, InputRefusal::Backlog { max })
            }
        }
    }

    /// A client's message, as its connection took it: held for the next
    /// live tick (see [`message_queue`]), where the rules get it. Refused
    /// (and counted) from a client not in the live game, or past the
    /// client's backlog. Messages that arrive while history is shown wait
    /// for the live world to run again.
    pub fn message(
        &mut self,
        client: ClientId,
        message: ReceivedMessage,
    ) -> Result<(), MessageRefusal> {
        if !self.timelines.live.clients.contains(&client) {
            return self.message_refused(client, MessageRefusal::NotConnected);
        }
        match self.messages.offer(client, message) {
            Ok(()) => Ok(()),
            Err(refusal) => self.message_refused(client, refusal),
        }
    }

    /// Hands the rules every message waiting for the live tick now (see
    /// [`message_queue`] for the order); each one taken goes into the
    /// journal of this tick.
    fn apply_waiting_messages(&mut self) {
        if self.messages.is_empty() {
            return;
        }
        for (client, message) in self.messages.take_all() {
            if self
                .message_here(client, message.delivery, &message.bytes)
                .is_ok()
            {
                self.meter.message_taken(message.delivery);
                self.journal_push(JournalEntry::Message(
                    client,
                    message.delivery,
                    message.bytes,
                ));
            }
        }
    }

    /// Hands a message to the rules; a refused one is counted.
    fn message_here(
        &mut self,
        client: ClientId,
        delivery: Delivery,
        bytes: &[u8],
    ) -> Result<(), MessageRefusal> {
        let r = self.with_ctx(|rules, ctx| rules.on_message(client, delivery, bytes, ctx));
        self.collect_messages();
        r.or_else(|refusal| self.message_refused(client, refusal))
    }

    /// Counts `refusal` of a message of `client` and returns it.
    fn message_refused(
        &self,
        client: ClientId,
        refusal: MessageRefusal,
    ) -> Result<(), MessageRefusal> {
        self.meter.message_refused(client, &refusal);
        Err(refusal)
    }

    /// How the client's inputs have been arriving against their ticks.
    pub fn input_timing(&self, client: ClientId) -> Option<inertia_protocol::control::InputReport> {
        self.inputs.timing(client)
    }

    /// Hands the rules every input due at the start of the live tick now,
    /// and every second of ticks ends the window of
    /// [`InputReport::min_lead`](inertia_protocol::control::InputReport::min_lead).
    fn apply_due_inputs(&mut self) {
        let now = self.timelines.live.world.tick();
        for (client, input) in self.inputs.due(now) {
            let _ = self.apply_input(client, &input);
        }
        if now % u64::from(self.config.tick_hz.max(1)) == 0 {
            self.inputs.end_window();
        }
    }

    /// Applies an input now: the rules check it, and an accepted one goes
    /// into the journal of this tick.
    fn apply_input(&mut self, client: ClientId, input: &PlayerInput) -> Result<(), InputRefusal> {
        let r = self.input_here(client, input);
        if r.is_ok() {
            self.journal_push(JournalEntry::Input(client, *input));
        }
        r
    }

    /// Counts `refusal` of an input of `client` (per client and reason in
    /// `/metrics`) and returns it.
    fn refused(&self, client: ClientId, refusal: InputRefusal) -> Result<(), InputRefusal> {
        self.meter.input_refused(client, &refusal);
        Err(refusal)
    }

    /// Hands an input to the rules, its view clamped
    /// ([`validate_input`](crate::rules::validate_input)): whatever the
    /// game, the rules never see a view they cannot rewind to. Whether
    /// its client is in was asked once, as it arrived ([`Self::input`]); a
    /// client that left since had its waiting inputs dropped, and a journal
    /// holds only inputs of clients in at the time.
    fn input_here(&mut self, client: ClientId, input: &PlayerInput) -> Result<(), InputRefusal> {
        let input = crate::rules::validate_input(input);
        match self.with_ctx(|rules, ctx| rules.on_input(client, &input, ctx)) {
            Ok(()) => Ok(()),
            Err(refusal) => self.refused(client, refusal),
        }
    }
}
