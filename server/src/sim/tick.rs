//! One tick as named, timed stages over the simulation's parts, the clock
//! deciding how many are due, and the gauges.

use std::time::{Duration, Instant};

use inertia_protocol::EntityId;

use super::meter::{Stopwatch, TickMeter, TickStages};
use super::timeline::Timeline;
use super::{startup, Simulation};
use crate::rules::RemovalReason;

impl Simulation {
    /// Runs one tick, stage by stage (each timed, in [`TickStages`]):
    ///
    /// 1. **inputs** — the live clients' waiting messages and the inputs
    ///    due now go to the rules, and the journal so far to the recorder;
    /// 2. **rules before** — the rules' `before_tick` (inputs become
    ///    forces);
    /// 3. **physics** — the world steps; what left it or went non-finite
    ///    leaves the entity table too;
    /// 4. **rules after** — the rules' `on_removed` for what the step took
    ///    out, their `after_tick`, the poses kept for lag compensation,
    ///    and the messages the rules sent, for the next frame;
    /// 5. **record** — the tick's hash (and keyframe or checkpoint) to the
    ///    recording, live only.
    pub fn tick(&mut self) {
        let _span = tracing::debug_span!("tick", tick = self.shown().world.tick() + 1).entered();
        let live = self.timelines.is_live();
        let mut watch = Stopwatch::start();
        let mut stages = TickStages::default();

        if live {
            self.apply_waiting_messages();
            self.apply_due_inputs();
        }
        self.flush_journal();
        stages.inputs = watch.lap();

        self.in_tick = true;
        self.with_ctx(|rules, ctx| rules.before_tick(ctx));
        stages.rules_before = watch.lap();

        let dt = self.dt();
        step_world(
            self.timelines.shown_mut(),
            dt,
            &mut self.removed,
            &self.meter,
        );
        stages.physics = watch.lap();

        self.tell_removed();
        self.with_ctx(|rules, ctx| rules.after_tick(ctx));
        // The tick as published: what clients will draw as this tick.
        let shown = self.timelines.shown_mut();
        shown
            .poses
            .record(shown.world.tick(), &shown.world, &shown.entities);
        self.collect_messages();
        self.in_tick = false;
        stages.rules_after = watch.lap();

        if live {
            self.record_tick();
        }
        stages.record = watch.lap();

        if let Some(cost) = self.meter.ticked(stages, live) {
            self.say_startup_cost(cost);
        }
    }

    /// What each stage of the last tick took.
    pub fn last_tick_stages(&self) -> TickStages {
        self.meter.last_stages()
    }

    /// The records of the tick just run (see [`super::recording`]).
    fn record_tick(&mut self) {
        let tick = self.shown().world.tick();
        let hash = self.state_hash();
        let (timelines, rules) = (&self.timelines, &*self.rules);
        self.recording
            .record_tick(tick, hash, &self.meter, |applied| {
                super::capture(timelines.shown(), rules, applied)
            });
    }

    /// Logs what the first live ticks cost against the tick budget: a
    /// warning when the machine cannot keep the configured rate.
    pub(super) fn say_startup_cost(&self, cost: startup::TickCost) {
        let bodies = self.shown().world.bodies().count();
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
        self.meter.startup_cost()
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
        let before = self.shown().clock.overruns();
        let n = self.shown_mut().clock.advance(wall_elapsed);
        self.run_due(n);
        let clock = &self.shown().clock;
        let (overruns, dropped) = (clock.overruns() - before, clock.dropped_ticks());
        self.meter.ran(n, Instant::now(), overruns, dropped);
        self.update_gauges();
        n
    }

    /// The 64-bit state hash of what is shown now, as the recording keeps
    /// it for each tick: the world's, with the game's properties and the
    /// rules' own state ([`GameRules::state_hash`](crate::rules::GameRules::state_hash))
    /// folded in. A seek that reproduces it reproduced all three.
    pub fn state_hash(&self) -> u64 {
        self.shown().state_hash(self.rules.state_hash())
    }

    /// The game's properties, as shown now.
    pub fn properties(&self) -> &crate::properties::PropertyStore {
        &self.shown().properties
    }

    /// The 99th percentile of the last
    /// [`TICK_WINDOW`](super::TICK_WINDOW) tick durations (zero before the
    /// first tick).
    pub fn tick_p99(&self) -> Duration {
        self.meter.tick_p99()
    }

    /// Ticks run by the clock per wall second over the last
    /// [`RATE_WINDOW`](super::RATE_WINDOW) (or since start, if shorter),
    /// Hz.
    pub fn achieved_rate(&self) -> f64 {
        self.meter.achieved_rate()
    }

    /// Clients in the live game.
    pub fn client_count(&self) -> usize {
        self.live_clients()
    }

    pub(super) fn update_gauges(&self) {
        let bodies = self.shown().world.bodies().count() as u64;
        let held = self.recording.history.as_ref().map(|h| h.held());
        self.meter.gauges(bodies, self.live_clients() as u64, held);
    }
}

/// The physics stage: steps the world of `shown` by `dt` s, and takes
/// what the step removed (out of bounds) or quarantined (non-finite) out
/// of the entity table, each noted in `removed` for the rules.
fn step_world(
    shown: &mut Timeline,
    dt: f64,
    removed: &mut Vec<(EntityId, RemovalReason)>,
    meter: &TickMeter,
) {
    let report = match shown.world.step(dt) {
        Ok(report) => report,
        Err(e) => {
            // Only a bad dt fails a step, and dt is fixed and checked.
            meter.step_failed();
            tracing::error!(error = %e, "physics step failed");
            return;
        }
    };
    let properties = &mut shown.properties;
    let mut removed = |id: Option<EntityId>, reason: RemovalReason| {
        if let Some(entity) = id {
            properties.forget(entity);
            removed.push((entity, reason));
        }
    };
    for h in report.removed_bodies {
        removed(shown.entities.remove_body(h), RemovalReason::OutOfBounds);
    }
    for h in report.quarantined_bodies {
        let _ = shown.world.remove_body(h);
        removed(shown.entities.remove_body(h), RemovalReason::Quarantined);
    }
    for h in report.quarantined {
        let _ = shown.world.remove_particle(h);
        let id = shown.entities.by_particle(h);
        if let Some(id) = id {
            shown.entities.remove(id);
        }
        removed(id, RemovalReason::Quarantined);
    }
    if shown.world.soft_bodies().next().is_some() {
        shown.entities.reshape_soft_bodies(&shown.world);
    }
}
