//! The simulation's measurements: what each tick and each stage of it
//! cost, how many ticks the clock ran lately, and the counters and gauges
//! it shares with the network layer ([`SimStats`]) and Prometheus
//! ([`Metrics`]).

use std::collections::VecDeque;
use std::sync::atomic::Ordering;
use std::sync::Arc;
use std::time::{Duration, Instant};

use super::startup::{TickCost, TickCostCheck};
use super::stats::{SimStats, RATE_WINDOW, TICK_WINDOW};
use crate::metrics::Metrics;
use crate::replay::HeldBytes;

/// What each stage of the last tick took, wall time (see
/// [`Simulation::tick`](super::Simulation::tick)).
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct TickStages {
    /// Inputs due this tick handed to the rules, and the journal so far
    /// handed to the recorder.
    pub inputs: Duration,
    /// The rules' `before_tick`.
    pub rules_before: Duration,
    /// The physics step, and what it removed taken out of the entity
    /// table.
    pub physics: Duration,
    /// The rules' `after_tick`, the poses kept for lag compensation and
    /// the messages the rules sent.
    pub rules_after: Duration,
    /// The tick's hash, keyframe or checkpoint handed to the recording.
    pub record: Duration,
}

impl TickStages {
    /// The whole tick.
    pub fn total(&self) -> Duration {
        self.inputs + self.rules_before + self.physics + self.rules_after + self.record
    }
}

/// Times one stage after another: each [`Stopwatch::lap`] is the time
/// since the one before.
#[derive(Debug)]
pub(super) struct Stopwatch(Instant);

impl Stopwatch {
    /// Starts timing now.
    pub(super) fn start() -> Self {
        Self(Instant::now())
    }

    /// The time since the last lap (or the start).
    pub(super) fn lap(&mut self) -> Duration {
        let now = Instant::now();
        let lap = now - self.0;
        self.0 = now;
        lap
    }
}

/// The simulation's measurements, kept on the tick thread.
#[derive(Debug)]
pub(super) struct TickMeter {
    /// Counters read by the network layer at any time.
    stats: Arc<SimStats>,
    /// Where to report to Prometheus, if anywhere.
    metrics: Option<Metrics>,
    /// The stages of the last tick.
    last: TickStages,
    /// Durations of the last [`TICK_WINDOW`] ticks.
    recent_ticks: VecDeque<Duration>,
    /// When ticks ran lately, with how many, within [`RATE_WINDOW`].
    recent_runs: VecDeque<(Instant, u32)>,
    /// The first live ticks' cost against the budget, said once.
    startup: TickCostCheck,
    started: Instant,
}

impl TickMeter {
    /// Measurements of a simulation ticking at `tick_hz`, reported to
    /// `metrics` too when given.
    pub(super) fn new(tick_hz: u32, metrics: Option<Metrics>) -> Self {
        Self {
            stats: Arc::new(SimStats::default()),
            metrics,
            last: TickStages::default(),
            recent_ticks: VecDeque::with_capacity(TICK_WINDOW),
            recent_runs: VecDeque::new(),
            startup: TickCostCheck::new(tick_hz),
            started: Instant::now(),
        }
    }

    /// The shared counters.
    pub(super) fn stats(&self) -> &Arc<SimStats> {
        &self.stats
    }

    /// A tick ran in `stages`; `live` when it was the live timeline's
    /// (only those count towards the startup verdict, returned once).
    pub(super) fn ticked(&mut self, stages: TickStages, live: bool) -> Option<TickCost> {
        self.last = stages;
        let took = stages.total();
        if self.recent_ticks.len() == TICK_WINDOW {
            self.recent_ticks.pop_front();
        }
        self.recent_ticks.push_back(took);
        self.stats.ticks.fetch_add(1, Ordering::Relaxed);
        self.stats
            .last_tick_ns
            .store(took.as_nanos() as u64, Ordering::Relaxed);
        if let Some(m) = &self.metrics {
            m.tick_duration.observe(took.as_secs_f64());
        }
        if live {
            self.startup.observe(took)
        } else {
            None
        }
    }

    /// The clock ran `n` ticks in one loop at `now`, and hit its catch-up
    /// cap `overruns` more times (`dropped` ticks dropped so far).
    pub(super) fn ran(&mut self, n: u32, now: Instant, overruns: u64, dropped: u64) {
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
        if overruns > 0 {
            self.stats.overruns.fetch_add(overruns, Ordering::Relaxed);
            self.stats.dropped_ticks.store(dropped, Ordering::Relaxed);
            if let Some(m) = &self.metrics {
                m.tick_overruns.inc_by(overruns);
            }
        }
    }

    /// The stages of the last tick.
    pub(super) fn last_stages(&self) -> TickStages {
        self.last
    }

    /// Wall time of the last tick.
    pub(super) fn last_tick(&self) -> Duration {
        self.last.total()
    }

    /// What the first live ticks cost, once measured.
    pub(super) fn startup_cost(&self) -> Option<TickCost> {
        self.startup.verdict()
    }

    /// The 99th percentile of the last [`TICK_WINDOW`] tick durations
    /// (zero before the first tick).
    pub(super) fn tick_p99(&self) -> Duration {
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
    pub(super) fn achieved_rate(&self) -> f64 {
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

    /// An input of `client` the rules or the schedule refused.
    pub(super) fn input_refused(&self, client: u64, refusal: &crate::rules::InputRefusal) {
        self.stats.inputs_rejected.fetch_add(1, Ordering::Relaxed);
        if let Some(m) = &self.metrics {
            m.input_refused(client, refusal.reason());
        }
    }

    /// A message of `client` the tick thread or the rules refused.
    pub(super) fn message_refused(
        &self,
        client: u64,
        refusal: &inertia_protocol::message::MessageRefusal,
    ) {
        if let Some(m) = &self.metrics {
            m.message_refused(client, refusal.reason());
        }
    }

    /// A message the rules took.
    pub(super) fn message_taken(&self, delivery: inertia_protocol::message::Delivery) {
        if let Some(m) = &self.metrics {
            m.message_received(delivery.label());
        }
    }

    /// `client` left: its series in `/metrics` go.
    pub(super) fn client_left(&self, client: u64) {
        if let Some(m) = &self.metrics {
            m.forget_client(client);
        }
    }

    /// Lag-compensated queries the rules made, `clamped` of them at the
    /// oldest pose kept.
    pub(super) fn rewound(&self, asked: u64, clamped: u64) {
        if asked > 0 {
            self.stats.rewinds.fetch_add(asked, Ordering::Relaxed);
            self.stats
                .rewinds_clamped
                .fetch_add(clamped, Ordering::Relaxed);
        }
    }

    /// A physics step failed.
    pub(super) fn step_failed(&self) {
        self.stats.step_errors.fetch_add(1, Ordering::Relaxed);
    }

    /// The recorder dropped a record (the recording stops).
    pub(super) fn record_gap(&self) {
        self.stats.record_gaps.fetch_add(1, Ordering::Relaxed);
    }

    /// The gauges: bodies in the world shown, clients in the live game,
    /// and the memory the history held for seeking takes.
    pub(super) fn gauges(&self, bodies: u64, clients: u64, held: Option<HeldBytes>) {
        self.stats.bodies.store(bodies, Ordering::Relaxed);
        self.stats.clients.store(clients, Ordering::Relaxed);
        if let Some(m) = &self.metrics {
            m.bodies.set(bodies as i64);
            m.connected_clients.set(clients as i64);
            if let Some(held) = held {
                for (part, bytes) in held.parts() {
                    m.set_seek_memory(part, bytes);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_p99_and_the_stages_come_from_the_ticks_measured() {
        let mut meter = TickMeter::new(60, None);
        assert_eq!(meter.tick_p99(), Duration::ZERO);
        for ms in 1..=100u64 {
            let stages = TickStages {
                physics: Duration::from_millis(ms),
                ..TickStages::default()
            };
            meter.ticked(stages, false);
        }
        assert_eq!(meter.tick_p99(), Duration::from_millis(99));
        assert_eq!(meter.last_tick(), Duration::from_millis(100));
        assert_eq!(meter.stats().ticks.load(Ordering::Relaxed), 100);
        assert!(
            meter.startup_cost().is_none(),
            "ticks of history shown say nothing of the live cost"
        );
    }
}
