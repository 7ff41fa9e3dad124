//! Time travel: showing recorded history in place of the live world.
//!
//! History is read-only. A simulation holds two [`Timeline`]s while
//! history is shown: the live one, which stands still (joins and leaves
//! still reach it), and the one shown, a re-simulated past state with a
//! clock of its own, which is what ticks and what clients see. The rules
//! object serves whichever is shown: the live timeline's rules state is
//! put aside in the [`ShownHistory`] until it comes back. From a past tick the
//! operator can:
//!
//! - step or resume: the view plays forward through the recorded journal;
//!   when it reaches the live tick the live world takes over seamlessly
//!   (at the view's time scale), since it is the same state;
//! - reverse: the view plays backwards by seeks, never by integrating
//!   backwards: each block of [`REVERSE_BLOCK`] ticks is re-simulated once
//!   from the nearest earlier state and cached, then shown newest first;
//! - replay `from..=to`: the view plays that stretch forward, then the
//!   live world comes back exactly where it was left;
//! - seek to the live tick: back to the live world at once.
//!
//! A seek to T starts from the nearest state at or before T of the same
//! recording session — the view itself when it is already behind T, a
//! cached state, or a keyframe of the in-memory [`History`] — applies the
//! journal of each tick and steps to T. The state hash at T then equals
//! the recorded one (the reply carries both).

use std::collections::{BTreeMap, BTreeSet};

use inertia_physics::World;

use super::{PoseHistory, Simulation, Timeline};
use crate::clock::Clock;
use crate::replay::{History, SimState, StateError};
use crate::scene::EntityTable;
pub use inertia_protocol::admin::TimeMode;

/// Ticks re-simulated and cached at a time for reverse play.
pub const REVERSE_BLOCK: u64 = 60;
/// Most states the reverse cache holds.
const CACHE_STATES: usize = 3 * REVERSE_BLOCK as usize;

/// Which way the view's clock plays.
#[derive(Debug, Clone, Copy, PartialEq)]
enum Play {
    /// Forward through history; the live tick hands over to the live world.
    Forward,
    /// Forward to `to`, then the live world comes back as it was left.
    Replay { to: u64 },
    /// Backwards, by cached seeks.
    Reverse,
}

/// History being shown.
pub(super) struct ShownHistory {
    /// The timeline shown in place of the live one.
    pub(super) shown: Timeline,
    /// The rules' state for the live timeline, put aside.
    live_rules: Vec<u8>,
    play: Play,
    /// States by tick, each right after its step (reverse play).
    cache: BTreeMap<u64, SimState>,
    /// The shown state is right after its tick's step, with none of that
    /// tick's journal applied (false only for a copy of the live state).
    clean: bool,
}

/// Why a time-travel request was refused (nothing changed).
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum TimeError {
    /// Nothing is recorded, so there is no history to show.
    #[error("there is no recording to travel in; `record on` starts one")]
    NoHistory,
    /// The tick is after the live tick.
    #[error("tick {tick} is in the future (the live tick is {live})")]
    InTheFuture {
        /// The tick asked for.
        tick: u64,
        /// The live tick.
        live: u64,
    },
    /// The tick was not recorded (before the recording, or while it was
    /// off).
    #[error("tick {tick} is not in the recording{}", range_note(*.range))]
    NotRecorded {
        /// The tick asked for.
        tick: u64,
        /// The first and last recorded ticks, if any.
        range: Option<(u64, u64)>,
    },
    /// A stored state did not restore.
    #[error(transparent)]
    State(#[from] StateError),
    /// The engine refused (making the view's world).
    #[error("{0}")]
    World(String),
    /// `to` is before `from`.
    #[error("the replay ends (tick {to}) before it starts (tick {from})")]
    BadRange {
        /// First tick.
        from: u64,
        /// Last tick.
        to: u64,
    },
}

fn range_note(range: Option<(u64, u64)>) -> String {
    match range {
        Some((a, b)) => format!(" (it holds ticks {a} to {b})"),
        None => String::new(),
    }
}

/// What a seek did.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SeekReport {
    /// The tick shown.
    pub tick: u64,
    /// Its state hash now.
    pub state_hash: u64,
    /// The hash recorded for it, if any.
    pub recorded_hash: Option<u64>,
    /// Where re-simulation started.
    pub base_tick: u64,
    /// Ticks re-simulated.
    pub resimulated: u64,
}

impl Simulation {
    /// What is shown: live, or history (paused, forward, backwards or a
    /// replay).
    pub fn mode(&self) -> TimeMode {
        match &self.timelines.past {
            None => TimeMode::Live,
            Some(v) => match v.play {
                Play::Reverse if !self.shown().clock.paused() => TimeMode::Reverse,
                Play::Replay { .. } => TimeMode::Replay,
                _ if self.shown().clock.paused() && self.shown().clock.queued() == 0 => {
                    TimeMode::History
                }
                _ => TimeMode::Forward,
            },
        }
    }

    /// Whether history is shown instead of the live world.
    pub fn showing_history(&self) -> bool {
        self.timelines.past.is_some()
    }

    /// The live world's tick.
    pub fn live_tick(&self) -> u64 {
        self.timelines.live.world.tick()
    }

    /// Clients in the live game.
    pub fn live_clients(&self) -> usize {
        self.timelines.live.clients.len()
    }

    /// Gives the rules `state` and returns the one they had: the rules
    /// object serves whichever timeline is shown.
    fn trade_rules(&mut self, state: &[u8]) -> Vec<u8> {
        let had = self.rules.save_state();
        if let Err(e) = self.rules.restore_state(state) {
            // The bytes came from these rules.
            tracing::error!(error = %e, "the rules refused their own state");
        }
        had
    }

    /// What clients see changed timelines: remake the catalog and gauges.
    fn timeline_changed(&mut self) {
        self.publication.timeline_swapped();
        self.update_gauges();
    }

    /// Runs `f` on the live timeline while history is shown (joins and
    /// leaves), then shows history again.
    pub(super) fn with_live<R>(&mut self, f: impl FnOnce(&mut Simulation) -> R) -> R {
        let Some(mut view) = self.timelines.past.take() else {
            return f(self);
        };
        let shown_rules = self.trade_rules(&view.live_rules);
        let r = f(self);
        self.flush_journal();
        view.live_rules = self.trade_rules(&shown_rules);
        self.timelines.past = Some(view);
        self.timeline_changed();
        r
    }

    /// Shows an empty timeline in place of the live one (filled next),
    /// paused; the live one stands still meanwhile.
    fn enter_view(&mut self) -> Result<(), TimeError> {
        if self.timelines.past.is_some() {
            return Ok(());
        }
        self.flush_journal();
        let world = World::new(*self.timelines.live.world.config())
            .map_err(|e| TimeError::World(e.to_string()))?;
        let mut clock = Clock::new(self.config.tick_hz, self.config.max_catch_up_ticks)
            .with_tick(self.timelines.live.world.tick());
        clock.pause();
        let shown = Timeline {
            world,
            entities: EntityTable::new(),
            clients: BTreeSet::new(),
            spawn_points: self.timelines.live.spawn_points.clone(),
            clock,
            poses: PoseHistory::new(self.timelines.live.poses.capacity()),
            properties: crate::properties::PropertyStore::new(
                self.timelines.live.properties.schema().clone(),
            ),
        };
        self.timelines.past = Some(ShownHistory {
            shown,
            live_rules: self.rules.save_state(),
            play: Play::Forward,
            cache: BTreeMap::new(),
            clean: false,
        });
        self.timeline_changed();
        Ok(())
    }

    /// Shows the live timeline again, as it was left.
    pub fn go_live(&mut self) {
        if let Some(view) = self.timelines.past.take() {
            self.trade_rules(&view.live_rules);
            self.timeline_changed();
            tracing::info!(tick = self.timelines.live.world.tick(), "live again");
        }
    }

    fn history_range_error(&self, tick: u64) -> TimeError {
        TimeError::NotRecorded {
            tick,
            range: self.recording.history.as_ref().and_then(History::range),
        }
    }

    /// Checks that `tick` can be shown.
    fn check_target(&self, tick: u64) -> Result<(), TimeError> {
        let live = self.live_tick();
        if tick > live {
            return Err(TimeError::InTheFuture { tick, live });
        }
        let history = self
            .recording
            .history
            .as_ref()
            .ok_or(TimeError::NoHistory)?;
        if tick != live && !history.reachable(tick) {
            return Err(self.history_range_error(tick));
        }
        Ok(())
    }

    /// Shows tick `tick` of the recording, paused (the live tick: the
    /// live world, paused).
    pub fn seek(&mut self, tick: u64) -> Result<SeekReport, TimeError> {
        self.check_target(tick)?;
        if tick == self.live_tick() {
            self.go_live();
            self.shown_mut().clock.pause();
            return Ok(self.report_shown());
        }
        self.enter_view()?;
        let report = self.show(tick, None)?;
        if let Some(v) = &mut self.timelines.past {
            v.play = Play::Forward;
        }
        self.shown_mut().clock.pause();
        Ok(report)
    }

    /// Plays history backwards from the tick shown (the live tick when
    /// live) at `speed` simulated seconds per wall second.
    pub fn reverse(&mut self, speed: f64) -> Result<(), TimeError> {
        if self.recording.history.is_none() {
            return Err(TimeError::NoHistory);
        }
        if self.timelines.past.is_none() {
            // Start from a copy of the live state.
            let now = self.checkpoint();
            self.enter_view()?;
            self.restore(&now)?;
        }
        self.shown_mut()
            .clock
            .set_time_scale(speed)
            .map_err(|e| TimeError::World(e.to_string()))?;
        if let Some(v) = &mut self.timelines.past {
            v.play = Play::Reverse;
        }
        Ok(())
    }

    /// Plays ticks `from..=to` of the recording at `speed`, then shows the
    /// live world again where it was left.
    pub fn replay(&mut self, from: u64, to: u64, speed: f64) -> Result<SeekReport, TimeError> {
        if to < from {
            return Err(TimeError::BadRange { from, to });
        }
        self.check_target(to)?;
        let report = self.seek(from)?;
        if self.timelines.past.is_none() {
            // `from` is the live tick: nothing to replay.
            return Ok(report);
        }
        self.shown_mut()
            .clock
            .set_time_scale(speed)
            .map_err(|e| TimeError::World(e.to_string()))?;
        if let Some(v) = &mut self.timelines.past {
            v.play = Play::Replay { to };
        }
        Ok(report)
    }

    /// Makes the view play forward (an operator's step, resume or speed
    /// while reversing).
    pub fn play_forward(&mut self) {
        if let Some(v) = &mut self.timelines.past {
            if v.play == Play::Reverse {
                v.play = Play::Forward;
            }
        }
    }

    /// Runs `n` ticks the clock says are due, whichever way the shown
    /// timeline plays.
    pub(super) fn run_due(&mut self, n: u32) {
        let mut left = n;
        while left > 0 {
            let Some(view) = &self.timelines.past else {
                for _ in 0..left {
                    self.tick();
                }
                return;
            };
            match view.play {
                Play::Reverse => {
                    self.reverse_by(u64::from(left));
                    return;
                }
                Play::Forward | Play::Replay { .. } => {
                    let end = match view.play {
                        Play::Replay { to } => to.min(self.timelines.live.world.tick()),
                        _ => self.timelines.live.world.tick(),
                    };
                    if self.shown().world.tick() >= end {
                        let replay = matches!(view.play, Play::Replay { .. });
                        self.finish_forward();
                        if replay {
                            // The live world comes back as it was left:
                            // what the replay's clock still owed is dropped.
                            return;
                        }
                        continue;
                    }
                    self.view_step();
                    left -= 1;
                }
            }
        }
        if let Some(v) = &self.timelines.past {
            let end = match v.play {
                Play::Replay { to } => Some(to.min(self.timelines.live.world.tick())),
                Play::Forward => Some(self.timelines.live.world.tick()),
                Play::Reverse => None,
            };
            if end.is_some_and(|e| self.shown().world.tick() >= e) {
                self.finish_forward();
            }
        }
    }

    /// The view reached the end of its forward play: a replay returns to
    /// the live world as it was; forward play hands its clock over.
    fn finish_forward(&mut self) {
        let Some(view) = &self.timelines.past else {
            return;
        };
        match view.play {
            Play::Replay { .. } => {
                self.go_live();
            }
            _ => {
                let scale = self.shown().clock.time_scale();
                let queued = self.shown().clock.queued();
                self.go_live();
                if scale > 0.0 {
                    let _ = self.shown_mut().clock.set_time_scale(scale);
                } else {
                    self.shown_mut().clock.pause();
                }
                // What was queued fits in the queue again.
                let _ = self.shown_mut().clock.step(queued);
            }
        }
    }

    /// One forward tick of the view: the recorded journal of its tick,
    /// then the step.
    fn view_step(&mut self) {
        let t = self.shown().world.tick();
        let clean = self.timelines.past.as_ref().is_some_and(|v| v.clean);
        if !clean {
            // A copy of the live state already holds its tick's journal.
            if let Some(v) = &mut self.timelines.past {
                v.clean = true;
            }
        } else if let Some(history) = self.recording.history.take() {
            for e in history.journal_at(t) {
                self.apply_entry(e);
            }
            self.recording.history = Some(history);
        }
        self.tick();
    }

    /// Moves the view `n` ticks back (stopping, paused, at the start of
    /// its recording session).
    fn reverse_by(&mut self, n: u64) {
        let now = self.shown().world.tick();
        let first = self
            .recording
            .history
            .as_ref()
            .and_then(|h| h.session_of(now))
            .unwrap_or(now);
        let target = now.saturating_sub(n).max(first);
        if target < now {
            if let Err(e) = self.show(target, Some(target.saturating_sub(REVERSE_BLOCK))) {
                tracing::warn!(error = %e, "reverse play stopped");
                self.shown_mut().clock.pause();
                return;
            }
        }
        if target <= first {
            self.shown_mut().clock.pause();
        }
    }

    /// Shows `target` (in the view): from the nearest state at or before it
    /// of the same session, re-simulating the journal. States at ticks
    /// from `cache_from` on are cached on the way.
    fn show(&mut self, target: u64, cache_from: Option<u64>) -> Result<SeekReport, TimeError> {
        let mut history = self.recording.history.take().ok_or(TimeError::NoHistory)?;
        history.collect_packed();
        let r = self.show_with(&history, target, cache_from);
        self.recording.history = Some(history);
        r
    }

    fn show_with(
        &mut self,
        history: &History,
        target: u64,
        cache_from: Option<u64>,
    ) -> Result<SeekReport, TimeError> {
        let session = history
            .session_of(target)
            .ok_or_else(|| self.history_range_error(target))?;
        let in_session = |t: u64| t >= session && t <= target;
        let Some(view) = self.timelines.past.as_mut() else {
            return Err(TimeError::NoHistory);
        };
        // Candidates: the view itself, a cached state, a keyframe.
        let here = view.shown.world.tick();
        let current = (view.clean && in_session(here)).then_some(here);
        let cached = view
            .cache
            .range(session..=target)
            .next_back()
            .map(|(&t, _)| t);
        let keyframe = history.base_for(target);
        let best_other = cached.max(keyframe.as_ref().map(|k| k.tick));
        let (base_tick, mut skip) = if current.is_some() && current >= best_other {
            (here, 0)
        } else if cached.is_some() && cached >= keyframe.as_ref().map(|k| k.tick) {
            let t = cached.unwrap_or(target);
            let state = view.cache.get(&t).cloned().ok_or(TimeError::NoHistory)?;
            self.restore(&state)?;
            (t, 0)
        } else {
            let k = keyframe.ok_or_else(|| self.history_range_error(target))?;
            let state = SimState::decode(&k.bytes)?;
            self.restore(&state)?;
            (k.tick, k.applied as usize)
        };
        // Messages of the ticks passed over are not news to anyone.
        let messages_before = self.publication.pending();
        let mut resimulated = 0;
        while self.shown().world.tick() < target {
            let t = self.shown().world.tick();
            for e in history.journal_at(t).iter().skip(skip) {
                self.apply_entry(e);
            }
            skip = 0;
            self.tick();
            resimulated += 1;
            let now = self.shown().world.tick();
            // Reverse play keeps the block below the target, and an anchor
            // every block on the way, so the next block starts near.
            if cache_from.is_some_and(|c| now >= c || now % REVERSE_BLOCK == 0) {
                let state = self.capture(0);
                if let Some(v) = &mut self.timelines.past {
                    v.cache.insert(now, state);
                }
            }
        }
        self.publication.forget_pending_after(messages_before);
        self.sent.clear();
        self.removed.clear();
        if let Some(v) = &mut self.timelines.past {
            v.clean = true;
            if cache_from.is_some() {
                // Playing backwards: what is above the target was shown.
                let _shown = v.cache.split_off(&(target + 1));
                while v.cache.len() > CACHE_STATES {
                    v.cache.pop_first();
                }
            }
        }
        let shown = self.shown_mut();
        shown.clock = shown.clock.clone().with_tick(target);
        Ok(SeekReport {
            tick: target,
            state_hash: self.state_hash(),
            recorded_hash: history.hash_at(target),
            base_tick,
            resimulated,
        })
    }
}

impl Simulation {
    /// The tick shown, its hash and the recorded one (nothing
    /// re-simulated).
    fn report_shown(&self) -> SeekReport {
        let tick = self.shown().world.tick();
        SeekReport {
            tick,
            state_hash: self.state_hash(),
            recorded_hash: self
                .recording
                .history
                .as_ref()
                .and_then(|h| h.hash_at(tick)),
            base_tick: tick,
            resimulated: 0,
        }
    }

    /// The state hash at `tick` and the recorded one, re-simulating a past
    /// tick without changing what is shown.
    pub fn hash_at(&mut self, tick: u64) -> Result<SeekReport, TimeError> {
        if tick == self.shown().world.tick() {
            return Ok(self.report_shown());
        }
        self.check_target(tick)?;
        let clock = self.shown().clock.clone();
        let shown = self
            .timelines
            .past
            .as_ref()
            .map(|v| (v.play, v.clean, self.capture(0)));
        let report = self.seek(tick);
        match shown {
            None => self.go_live(),
            Some((play, clean, state)) => {
                self.enter_view()?;
                self.restore(&state)?;
                if let Some(v) = &mut self.timelines.past {
                    v.play = play;
                    v.clean = clean;
                }
            }
        }
        self.shown_mut().clock = clock;
        report
    }

    /// Replaces the live world with a checkpoint (`load`). History shown
    /// is left first. Clients in the checkpoint who are not connected
    /// leave; connected clients it does not hold join again (new avatars).
    /// A recording goes on as a new session (a recording whose ticks run
    /// past the checkpoint's is moved aside first). Returns the new state
    /// hash. On error nothing changes but the return to the live world.
    pub fn load(&mut self, state: &SimState, operator: &str) -> Result<u64, StateError> {
        self.go_live();
        self.flush_journal();
        let connected = self.shown().clients.clone();
        self.restore(state)?;
        // Inputs meant for ticks of the world replaced.
        self.inputs.clear_pending();
        let recording = self.recording.is_on();
        if recording {
            self.record_admin_edit(operator, &format!("load (tick {})", state.tick));
            self.stop_recording();
        }
        self.recording.forget_journal();
        let saved = self.shown().clients.clone();
        for &client in saved.difference(&connected) {
            self.leave_here(client);
        }
        for &client in connected.difference(&saved) {
            if let Err(e) = self.join_here(client) {
                tracing::warn!(client, error = %e, "a connected client found no room in the loaded world");
            }
        }
        if recording {
            if let Err(e) = self.start_recording() {
                tracing::error!(error = %e, "recording did not restart after the load");
            }
        }
        tracing::info!(operator, tick = state.tick, "checkpoint loaded");
        Ok(self.state_hash())
    }
}
