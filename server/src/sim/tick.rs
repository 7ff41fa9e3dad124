//! One tick (rules, physics step, clean-up, rules, records), the clock
//! deciding how many are due, and the tick's own measurements.

use std::sync::atomic::Ordering;
use std::time::{Duration, Instant};

use inertia_protocol::EntityId;

use super::stats::{RATE_WINDOW, TICK_WINDOW};
use super::{startup, Simulation};
use crate::rules::{GameEvent, RemovalReason};

impl Simulation {
    /// Runs one tick: rules, physics step, clean-up, rules.
    pub fn tick(&mut self) {
        let _span = tracing::debug_span!("tick", tick = self.shown().world.tick() + 1).entered();
        if self.view.is_none() {
            self.apply_due_inputs();
        }
        self.flush_journal();
        self.in_tick = true;
        let t0 = Instant::now();
        self.with_ctx(|rules, ctx| rules.before_tick(ctx));
        let dt = self.dt();
        let shown = super::shown_of(&mut self.view, &mut self.live);
        match shown.world.step(dt) {
            Ok(report) => {
                let mut removed = |id: Option<EntityId>, reason: RemovalReason| {
                    if let Some(entity) = id {
                        self.ctx_events.push(GameEvent::Removed { entity, reason });
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
            Err(e) => {
                // Only a bad dt fails a step, and dt is fixed and checked.
                self.stats.step_errors.fetch_add(1, Ordering::Relaxed);
                tracing::error!(error = %e, "physics step failed");
            }
        }
        self.with_ctx(|rules, ctx| rules.after_tick(ctx));
        // The tick as published: what clients will draw as this tick.
        let shown = super::shown_of(&mut self.view, &mut self.live);
        shown
            .poses
            .record(shown.world.tick(), &shown.world, &shown.entities);
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
        let before = self.shown().clock.overruns();
        let n = self.shown_mut().clock.advance(wall_elapsed);
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
        let overruns = self.shown().clock.overruns() - before;
        if overruns > 0 {
            self.stats.overruns.fetch_add(overruns, Ordering::Relaxed);
            self.stats
                .dropped_ticks
                .store(self.shown().clock.dropped_ticks(), Ordering::Relaxed);
            if let Some(m) = &self.config.metrics {
                m.tick_overruns.inc_by(overruns);
            }
        }
        self.update_gauges();
        n
    }

    /// The 64-bit state hash of the world now.
    pub fn state_hash(&self) -> u64 {
        self.shown().world.state_hash()
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

    pub(super) fn update_gauges(&self) {
        let bodies = self.shown().world.bodies().count() as u64;
        self.stats.bodies.store(bodies, Ordering::Relaxed);
        self.stats
            .clients
            .store(self.live_clients() as u64, Ordering::Relaxed);
        if let Some(m) = &self.config.metrics {
            m.bodies.set(bodies as i64);
            m.connected_clients.set(self.live_clients() as i64);
            if let Some(h) = &self.history {
                for (part, bytes) in h.held().parts() {
                    m.set_seek_memory(part, bytes);
                }
            }
        }
    }
}
