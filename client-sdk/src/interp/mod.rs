//! Snapshot interpolation: what the game draws each frame.
//!
//! [`InterpolationBuffer`] keeps the snapshots received lately and renders
//! the world at a *render tick* that trails the [`ServerClock`]'s arrival
//! timeline by a render delay, so that there is (nearly) always a snapshot
//! on either side of it.
//!
//! - The render delay adapts: `interval × interval_factor + jitter ×
//!   jitter_factor + margin`, from the measured snapshot interval and
//!   arrival jitter, bounded, and moved towards its target slowly.
//! - The render tick advances at the server's tick rate *at that point of
//!   the timeline* (the time scale carried by the snapshots around it), so a
//!   pause freezes the picture exactly at the paused tick and slow motion
//!   and fast-forward play smoothly when the render tick reaches them. A
//!   gentle correction (a few percent) keeps the wall-clock depth behind the
//!   arrival timeline at the render delay; it never runs against the
//!   direction of play.
//! - Position is Hermite-interpolated when both snapshots carry velocities
//!   (else linear); rotation is slerped along the shortest arc.
//! - Past the newest snapshot it extrapolates with velocity for at most
//!   [`InterpConfig::max_extrapolation`] seconds of simulation time (of
//!   local time when fast-forwarding), then holds (a stall).
//! - When fresh data replaces an extrapolation, the difference is blended
//!   out over [`InterpConfig::correction_smoothing`] instead of popping.
//! - Reverse play (a negative time scale: the server plays recorded
//!   history backwards, ticks decreasing) is motion backwards, not a break:
//!   the timeline is kept as *legs* played one way, and the render tick
//!   moves down through a reverse leg at `|time scale| × tick rate`, the
//!   render delay applied in the direction of play (above the newest tick
//!   while reversing). Where the timeline turned, the render tick plays on
//!   to the turning tick, then back. States are keyed by tick, so the
//!   Hermite interpolation between the two that bracket the render tick
//!   holds either way (velocities are d(position)/d(simulation time));
//!   extrapolation past the edge goes along them in the direction of play.
//! - A discontinuity (seek, rewind) flushes the buffer, is reported as an
//!   [`InterpEvent`], and rendering restarts on the new timeline.
//! - Entities absent from recent snapshots (not sent this time, at rest)
//!   keep their last state; [`InterpolationBuffer::remove`] forgets one.
//!
//! Times are seconds of the client's local monotonic clock, passed in.

use std::collections::{BTreeMap, VecDeque};

use glam::{DQuat, DVec3};
use inertia_protocol::EntityId;

use crate::clock::{
    direction_of, ClockConfig, Discontinuity, Observation, ServerClock, SnapshotMeta,
};

/// One entity as a snapshot shows it: the protocol's decoded state.
pub use inertia_protocol::snapshot::ViewEntity;

/// How an [`InterpolationBuffer`] renders. Times in seconds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct InterpConfig {
    /// The server clock's settings (tick rate among them).
    pub clock: ClockConfig,
    /// Render delay per snapshot interval (2 rides out one lost snapshot).
    pub interval_factor: f64,
    /// Render delay per second of measured arrival jitter.
    pub jitter_factor: f64,
    /// Render delay added on top, s.
    pub delay_margin: f64,
    /// The least render delay, s of local time.
    pub min_delay: f64,
    /// The most render delay, s of local time.
    pub max_delay: f64,
    /// The render delay before anything is measured, s.
    pub initial_delay: f64,
    /// How fast the render delay may change, s per s.
    pub delay_slew: f64,
    /// Time constant of the depth correction, s: being this much further
    /// behind than the delay would double the render speed. Ahead of the
    /// delay the render delay itself is used when shorter, so the render
    /// tick slows to a stop as it nears the arrival edge.
    pub correction_time: f64,
    /// The most the render tick may run fast to catch up, as a factor of
    /// the tick rate (the least is 0: it never runs against the direction
    /// of play).
    pub max_speedup: f64,
    /// Further behind than the render delay plus this, the render tick jumps
    /// forwards instead of catching up, s.
    pub resync_after: f64,
    /// The most the picture is extrapolated past an entity's newest state,
    /// s of simulation time, or s of local time while the server runs
    /// faster than real time; beyond it, it holds.
    pub max_extrapolation: f64,
    /// When an entity goes from extrapolated back to interpolated, the
    /// difference is blended out with this time constant instead of
    /// popping, s of local time (0 = pop).
    pub correction_smoothing: f64,
    /// The most snapshots (and samples per entity) kept.
    pub max_snapshots: usize,
}

impl InterpConfig {
    /// Defaults for a server ticking at `tick_hz` ticks/s.
    pub fn new(tick_hz: f64) -> Self {
        Self {
            clock: ClockConfig::new(tick_hz),
            interval_factor: 2.0,
            jitter_factor: 1.0,
            delay_margin: 0.005,
            min_delay: 0.02,
            max_delay: 0.5,
            initial_delay: 0.1,
            delay_slew: 0.02,
            correction_time: 0.25,
            max_speedup: 1.5,
            resync_after: 0.5,
            max_extrapolation: 0.1,
            correction_smoothing: 0.1,
            max_snapshots: 64,
        }
    }
}

impl Default for InterpConfig {
    /// Defaults for the default 60 Hz tick.
    fn default() -> Self {
        Self::new(60.0)
    }
}

/// Something a game may want to react to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum InterpEvent {
    /// The timeline broke (seek, rewind): the buffer was flushed and
    /// rendering restarted on the new timeline. A good moment to cut or
    /// fade.
    Discontinuity(Discontinuity),
    /// The render tick fell so far behind (after an outage) that it jumped
    /// forwards instead of catching up.
    Resync {
        /// Render tick before the jump.
        from_tick: f64,
        /// Render tick after it.
        to_tick: f64,
    },
}

/// One entity as drawn this frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct RenderedEntity {
    /// The entity.
    pub id: EntityId,
    /// Position, m.
    pub position: DVec3,
    /// Orientation (unit quaternion).
    pub rotation: DQuat,
    /// True when the pose was extrapolated past the entity's newest state.
    pub extrapolated: bool,
}

/// The world as drawn at one local time (what a client samples to draw
/// a frame of its own).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Sample {
    /// The (fractional) server tick rendered.
    pub render_tick: f64,
    /// The entities, by id.
    pub entities: Vec<RenderedEntity>,
}

impl Sample {
    /// The entities as (id, position m, rotation).
    pub fn iter(&self) -> impl Iterator<Item = (EntityId, DVec3, DQuat)> + '_ {
        self.entities.iter().map(|e| (e.id, e.position, e.rotation))
    }

    /// One entity, if drawn.
    pub fn get(&self, id: EntityId) -> Option<&RenderedEntity> {
        self.entities
            .binary_search_by_key(&id, |e| e.id)
            .ok()
            .map(|i| &self.entities[i])
    }
}

/// Counters and gauges of an [`InterpolationBuffer`].
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct InterpStats {
    /// Snapshot time in hand ahead of the render tick, ms of local time at
    /// the current rate (0 when extrapolating).
    pub buffer_ms: f64,
    /// The current render delay, ms of local time.
    pub delay_ms: f64,
    /// Snapshots buffered.
    pub snapshots: usize,
    /// Times the render tick passed the newest snapshot by more than the
    /// extrapolation bound (and the picture held).
    pub stalls: u64,
    /// Times the render tick passed the newest snapshot (extrapolation
    /// began).
    pub extrapolations: u64,
    /// Discontinuities (seeks, rewinds) seen.
    pub discontinuities: u64,
    /// Forward jumps after falling far behind.
    pub resyncs: u64,
    /// Snapshots dropped as stragglers of an old timeline or too old to
    /// matter.
    pub dropped: u64,
}

/// The timing of one buffered snapshot.
#[derive(Debug, Clone, Copy)]
struct SnapInfo {
    /// How fast the server ran, either way (|time scale|).
    time_scale: f32,
    paused: bool,
}

/// A stretch of the timeline played one way: forwards (or paused), or
/// backwards. Its snapshots are keyed by `dir × tick`, which increases in
/// the direction of play, so that "ahead" and "behind" read the same both
/// ways.
#[derive(Debug, Clone)]
struct Leg {
    /// +1 forwards or paused, −1 while history plays backwards.
    dir: f64,
    /// Snapshot timing by `dir × tick`.
    snaps: BTreeMap<i64, SnapInfo>,
    /// Local time the leg began with a turn, s (`None` for the first leg
    /// of a timeline).
    start: Option<f64>,
    /// Once the timeline turned: the tick it turned at (the last this leg
    /// plays, the first the next one does) and the local time the turn
    /// arrived, s.
    turn: Option<(u64, f64)>,
}

impl Leg {
    fn new(dir: f64, start: Option<f64>) -> Self {
        Self {
            dir,
            snaps: BTreeMap::new(),
            start,
            turn: None,
        }
    }

    /// The key of `tick` on this leg.
    fn key(&self, tick: u64) -> i64 {
        key(self.dir, tick)
    }

    /// The tick of key `u` on this leg.
    fn tick(&self, u: f64) -> f64 {
        self.dir * u
    }

    /// The last key this leg plays: its turn, else its newest snapshot.
    fn end(&self) -> Option<i64> {
        match self.turn {
            Some((tick, _)) => Some(self.key(tick)),
            None => self.snaps.last_key_value().map(|(&u, _)| u),
        }
    }
}

/// `tick` as a key along direction `dir`.
fn key(dir: f64, tick: u64) -> i64 {
    let t = tick.min(i64::MAX as u64) as i64;
    if dir < 0.0 {
        -t
    } else {
        t
    }
}

/// How an entity was last drawn: whether extrapolated, and the visual
/// correction still being blended out (added to position, applied before
/// rotation).
#[derive(Debug, Clone, Copy)]
struct Drawn {
    extrapolated: bool,
    offset: DVec3,
    turn: DQuat,
}

/// Received snapshots and the render clock. See the [module docs](self).
#[derive(Debug, Clone)]
pub struct InterpolationBuffer {
    config: InterpConfig,
    clock: ServerClock,
    /// The legs of the timeline from the one the render tick is on to the
    /// one snapshots arrive on now.
    legs: VecDeque<Leg>,
    entities: BTreeMap<EntityId, VecDeque<(u64, ViewEntity)>>,
    drawn: BTreeMap<EntityId, Drawn>,
    render_tick: Option<f64>,
    last_sample: Option<f64>,
    delay: f64,
    extrapolating: bool,
    stalled: bool,
    /// Two ticks have arrived on this timeline (before that the render tick
    /// waits at the first rather than extrapolating).
    primed: bool,
    stats: InterpStats,
    events: VecDeque<InterpEvent>,
    frame: Sample,
}

/// The most events kept unread.
const MAX_EVENTS: usize = 64;

impl InterpolationBuffer {
    /// A buffer for a server ticking at `tick_hz` ticks/s, other settings
    /// default.
    pub fn new(tick_hz: f64) -> Self {
        Self::with_config(InterpConfig::new(tick_hz))
    }

    /// A buffer with the given settings.
    pub fn with_config(config: InterpConfig) -> Self {
        Self {
            config,
            clock: ServerClock::with_config(config.clock),
            legs: VecDeque::new(),
            entities: BTreeMap::new(),
            drawn: BTreeMap::new(),
            render_tick: None,
            last_sample: None,
            delay: config.initial_delay,
            extrapolating: false,
            stalled: false,
            primed: false,
            stats: InterpStats::default(),
            events: VecDeque::new(),
            frame: Sample::default(),
        }
    }

    /// The settings.
    pub fn config(&self) -> &InterpConfig {
        &self.config
    }

    /// The server clock fed by [`push_states`](Self::push_states).
    pub fn clock(&self) -> &ServerClock {
        &self.clock
    }

    /// The server clock, to feed it round-trip samples.
    pub fn clock_mut(&mut self) -> &mut ServerClock {
        &mut self.clock
    }

    /// The direction the render tick moves: −1 while it plays a stretch of
    /// reverse play, else +1.
    pub fn render_direction(&self) -> f64 {
        self.legs.front().map_or(1.0, |l| l.dir)
    }

    /// Takes in a snapshot that arrived at `local_time` (s), given as its
    /// header and the states it carried (possibly not all of the view:
    /// entities out of view or not sent this time are absent), borrowed as
    /// the decoder hands them out: nothing is allocated but the samples
    /// kept. Returns what the clock made of it; on a discontinuity the
    /// buffer is flushed first and an [`InterpEvent::Discontinuity`]
    /// queued.
    pub fn push_states(
        &mut self,
        local_time: f64,
        meta: SnapshotMeta,
        entities: &[ViewEntity],
    ) -> Observation {
        let observation = self.clock.observe(local_time, meta);
        match observation {
            Observation::Stale => {
                self.stats.dropped += 1;
                return observation;
            }
            Observation::Discontinuity(d) => {
                self.legs.clear();
                self.entities.clear();
                self.drawn.clear();
                self.render_tick = None;
                self.primed = false;
                self.extrapolating = false;
                self.stalled = false;
                self.stats.discontinuities += 1;
                self.queue(InterpEvent::Discontinuity(d));
            }
            Observation::InOrder | Observation::Late => {}
        }
        let dir = direction_of(meta.time_scale, meta.paused);
        // Too old to ever be drawn: behind the render tick on the last leg
        // (a leg still to come may pass a tick again).
        if let (Some(r), Some(leg), 1) = (self.render_tick, self.legs.front(), self.legs.len()) {
            if leg.dir == dir {
                let bracket = leg.snaps.range(..=(leg.dir * r).floor() as i64).next_back();
                if bracket.is_some_and(|(&u, _)| leg.key(meta.tick) < u) {
                    self.stats.dropped += 1;
                    return observation;
                }
            }
        }
        let info = SnapInfo {
            time_scale: if meta.time_scale.is_finite() {
                meta.time_scale.abs()
            } else {
                0.0
            },
            paused: meta.paused,
        };
        let in_order = !matches!(observation, Observation::Late);
        if in_order {
            self.note_direction(local_time, meta.tick, dir, info);
        }
        // The leg it belongs to: the newest one played its way.
        let leg = if in_order {
            self.legs.back_mut()
        } else {
            self.legs.iter_mut().rev().find(|l| l.dir == dir)
        };
        if let Some(leg) = leg {
            let u = leg.key(meta.tick);
            if leg.turn.is_none() || Some(u) <= leg.end() {
                leg.snaps
                    .entry(u)
                    .and_modify(|old| {
                        old.paused |= info.paused;
                        if in_order {
                            old.time_scale = info.time_scale;
                        }
                    })
                    .or_insert(info);
            }
        }
        self.primed |= self.legs.iter().map(|l| l.snaps.len()).sum::<usize>() >= 2;
        let render = self.render_tick;
        // Only the entities this snapshot touched are trimmed (in the same
        // visit): the rest are when the picture is next drawn.
        let span = self.prune_legs();
        let max = self.config.max_snapshots;
        let add = |samples: &mut VecDeque<(u64, ViewEntity)>, view: ViewEntity| {
            add_sample(samples, meta.tick, view, max, render);
            if let Some(span) = span {
                trim(samples, span);
            }
        };
        // One walk beside the entities held, then the ones new to the
        // buffer.
        let added = crate::by_id::visit_beside(&mut self.entities, entities, &add);
        if added < entities.len() {
            // New entities (or states out of order): one by one; a sample
            // already added is replaced by itself.
            for &view in entities {
                add(self.entities.entry(view.id).or_default(), view);
            }
        }
        observation
    }

    /// An in-order snapshot at `tick` played in direction `dir`: starts the
    /// first leg, or a new one where the timeline turned.
    fn note_direction(&mut self, local_time: f64, tick: u64, dir: f64, info: SnapInfo) {
        let Some(last) = self.legs.back_mut() else {
            self.legs.push_back(Leg::new(dir, None));
            return;
        };
        if last.dir == dir {
            return;
        }
        // The turn: the furthest the old leg got, by its newest snapshot or
        // this one (the server may have gone on a little before turning).
        let u = last.key(tick);
        let end = last.snaps.last_key_value().map_or(u, |(&n, _)| n.max(u));
        let held = last.snaps.last_key_value().map_or(info, |(_, &i)| i);
        last.snaps.entry(end).or_insert(held);
        let turn = last.tick(end as f64) as u64;
        last.turn = Some((turn, local_time));
        let mut leg = Leg::new(dir, Some(local_time));
        leg.snaps.insert(leg.key(turn), info);
        self.legs.push_back(leg);
    }

    /// The states held for entity `id`, oldest tick first: what the
    /// snapshots that carried it said, each at the tick it described.
    pub fn states(&self, id: EntityId) -> impl Iterator<Item = (u64, &ViewEntity)> + '_ {
        self.entities
            .get(&id)
            .into_iter()
            .flat_map(|samples| samples.iter().map(|(tick, view)| (*tick, view)))
    }

    /// Forgets an entity (despawned or out of view for good).
    pub fn remove(&mut self, id: EntityId) {
        self.entities.remove(&id);
        self.drawn.remove(&id);
    }

    /// Advances the render clock to `local_time` (s) and draws the world
    /// at the render tick.
    pub fn sample(&mut self, local_time: f64) -> &Sample {
        let t = local_time;
        let dt = self.last_sample.map_or(0.0, |l| (t - l).max(0.0));
        self.last_sample = Some(t.max(self.last_sample.unwrap_or(t)));
        self.update_delay(dt);
        let Some(leg) = self.legs.front().filter(|l| !l.snaps.is_empty()) else {
            self.frame.entities.clear();
            return &self.frame;
        };
        let render = match self.render_tick {
            None => {
                let oldest = *leg.snaps.first_key_value().unwrap().0 as f64;
                let end = leg.end().unwrap() as f64;
                let start = self
                    .clock
                    .arrival_tick_at(t - self.delay)
                    .map_or(oldest, |e| leg.dir * e);
                leg.tick(start.clamp(oldest, end))
            }
            Some(r) => self.advance(r, t, dt),
        };
        self.render_tick = Some(render);
        let leg = &self.legs[0];
        let u = leg.dir * render;
        let rate = self.rate_at(leg, u);
        let ahead = leg.end().map_or(0.0, |e| e as f64 - u);
        self.stats.buffer_ms = if rate > 0.0 {
            (ahead / rate * 1000.0).max(0.0)
        } else {
            0.0
        };
        self.prune();
        self.draw(render, dt);
        &self.frame
    }

    /// Moves the render tick on from `r` by `dt` s of local time at `t`,
    /// along the legs of the timeline.
    fn advance(&mut self, r: f64, t: f64, dt: f64) -> f64 {
        let leg = &self.legs[0];
        let d = leg.dir;
        let u = d * r;
        let Some((&newest, &newest_info)) = leg.snaps.last_key_value() else {
            return r;
        };
        let rate = self.rate_at(leg, u);
        let depth = match leg.turn {
            // The timeline turned: the render tick should reach the turn a
            // render delay after the turn arrived.
            Some((turn, at)) => {
                let left = (leg.key(turn) as f64 - u).max(0.0);
                let remaining = if rate > 0.0 { left / rate } else { 0.0 };
                t + remaining - at
            }
            None => self
                .clock
                .local_time_reached(r, t, leg.start.unwrap_or(f64::NEG_INFINITY))
                .map_or(self.delay, |at| t - at),
        };
        let lag = depth - self.delay;
        let turn = leg.turn;
        let limit = newest as f64 + self.extrapolation_ticks(&newest_info);
        let mut next = if lag > self.config.resync_after {
            let to = match turn {
                Some((turn, _)) => leg.key(turn) as f64,
                None => self
                    .clock
                    .arrival_tick_at(t - self.delay)
                    .map_or(u, |e| d * e)
                    .min(newest as f64),
            };
            if to > u {
                self.stats.resyncs += 1;
                self.queue(InterpEvent::Resync {
                    from_tick: r,
                    to_tick: d * to,
                });
            }
            to
        } else {
            // Too close to the arrival edge, slow down within the delay;
            // too far behind, catch up gently.
            let time = if lag < 0.0 {
                self.config.correction_time.min(self.delay)
            } else {
                self.config.correction_time
            };
            // The rule is d(render)/dt = rate × (1 + lag / time), under which
            // a lag decays as exp(−t / time). `lag` is the last picture's,
            // measured now: it already counts the frame that has passed
            // since, which is what moving on by a frame makes up. So the
            // error left is `lag − dt`, corrected over the whole step (not
            // as one Euler step): a frame longer than `time`, as at 10
            // frames a second, then lands on the delay, not past it.
            let error = lag - dt;
            let advance = dt + error * (1.0 - (-dt / time).exp());
            u + rate * advance.clamp(0.0, self.config.max_speedup * dt)
        };
        if let Some((turn, _)) = turn {
            self.extrapolating = false;
            self.stalled = false;
            let end = key(d, turn) as f64;
            if next.max(u) >= end {
                // On to the next leg, carrying what is left of the step.
                let left = next - end;
                self.legs.pop_front();
                let leg = &self.legs[0];
                let start = leg.key(turn) as f64;
                let end = leg.end().map_or(start, |e| e as f64);
                let next = (start + left).min(end).max(start);
                return leg.tick(next);
            }
            return d * next.max(u);
        }
        if newest_info.paused || !self.primed {
            next = next.min(newest as f64);
        }
        if next > newest as f64 {
            if !self.extrapolating {
                self.extrapolating = true;
                self.stats.extrapolations += 1;
            }
            if next >= limit {
                next = limit;
                if !self.stalled {
                    self.stalled = true;
                    self.stats.stalls += 1;
                }
            }
        } else {
            self.extrapolating = false;
            self.stalled = false;
        }
        d * next.max(u)
    }

    /// What the last [`sample`](Self::sample) drew.
    pub fn last_sample(&self) -> &Sample {
        &self.frame
    }

    /// The render tick of the last [`sample`](Self::sample), once there is
    /// one.
    pub fn render_tick(&self) -> Option<f64> {
        self.render_tick
    }

    /// The current render delay, s of local time.
    pub fn delay(&self) -> f64 {
        self.delay
    }

    /// Counters and gauges.
    pub fn stats(&self) -> InterpStats {
        InterpStats {
            delay_ms: self.delay * 1000.0,
            snapshots: self.legs.iter().map(|l| l.snaps.len()).sum(),
            ..self.stats
        }
    }

    /// The next unread event, oldest first.
    pub fn poll_event(&mut self) -> Option<InterpEvent> {
        self.events.pop_front()
    }

    fn queue(&mut self, event: InterpEvent) {
        if self.events.len() == MAX_EVENTS {
            self.events.pop_front();
        }
        self.events.push_back(event);
    }

    fn update_delay(&mut self, dt: f64) {
        let c = &self.config;
        let Some(interval) = self.clock.snapshot_interval() else {
            return;
        };
        let target =
            (interval * c.interval_factor + self.clock.jitter() * c.jitter_factor + c.delay_margin)
                .clamp(c.min_delay, c.max_delay);
        let step = c.delay_slew * dt;
        self.delay += (target - self.delay).clamp(-step, step);
    }

    /// How far past the newest snapshot the picture may be extrapolated,
    /// ticks.
    fn extrapolation_ticks(&self, newest: &SnapInfo) -> f64 {
        let fast = f64::from(newest.time_scale).max(1.0);
        self.config.max_extrapolation * self.config.clock.tick_hz * fast
    }

    /// The server's tick rate along `leg` at key `u` (either way), ticks/s:
    /// the time scale the server ran at between the snapshots around it
    /// (the faster of the two; real time for steps taken while paused).
    fn rate_at(&self, leg: &Leg, u: f64) -> f64 {
        let hz = self.config.clock.tick_hz;
        let before = leg.snaps.range(..=u.floor() as i64).next_back();
        let after = leg.snaps.range(u.floor() as i64 + 1..).next();
        let scale = |i: &SnapInfo| {
            if i.paused {
                0.0
            } else {
                f64::from(i.time_scale)
            }
        };
        match (before, after) {
            (Some((_, a)), Some((_, b))) => {
                // Where the scale changed within the span, the faster one:
                // off by at most one snapshot interval either way, where
                // the slower one could stretch a speed-up's ticks to many.
                let s = scale(a).max(scale(b));
                if s > 0.0 {
                    hz * s
                } else {
                    // Stepping while paused: play the steps at real time.
                    hz
                }
            }
            (Some((_, a)), None) => hz * scale(a),
            (None, Some((_, b))) => hz * scale(b).max(1.0),
            (None, None) => 0.0,
        }
    }

    /// Drops snapshots and samples the render tick has left behind (keeping
    /// the one at or before it, in the direction of play) and any beyond
    /// the size bound. Entity states are kept over the ticks any leg still
    /// to play spans.
    fn prune(&mut self) {
        if let Some(span) = self.prune_legs() {
            self.entities.values_mut().for_each(|s| trim(s, span));
        }
    }

    /// Drops the snapshots the render tick has left behind and any beyond
    /// the size bound, and gives the ticks entity samples are kept over
    /// (`None` before the first picture).
    fn prune_legs(&mut self) -> Option<(f64, f64)> {
        let max = self.config.max_snapshots.max(2);
        for leg in &mut self.legs {
            while leg.snaps.len() > max {
                leg.snaps.pop_first();
            }
        }
        let r = self.render_tick?;
        let leg = self.legs.front_mut()?;
        let keep_from = leg
            .snaps
            .range(..=(leg.dir * r).floor() as i64)
            .next_back()
            .map(|(&u, _)| u);
        if let Some(from) = keep_from {
            while leg.snaps.first_key_value().is_some_and(|(&u, _)| u < from) {
                leg.snaps.pop_first();
            }
        }
        // The ticks still to be drawn.
        let (mut lo, mut hi) = (r, r);
        for leg in &self.legs {
            for &u in leg.snaps.keys() {
                let tick = leg.tick(u as f64);
                lo = lo.min(tick);
                hi = hi.max(tick);
            }
        }
        Some((lo, hi))
    }

    fn draw(&mut self, r: f64, dt: f64) {
        let hz = self.config.clock.tick_hz;
        let dir = self.render_direction();
        let max_ahead = self
            .legs
            .back()
            .and_then(|l| l.snaps.last_key_value())
            .map_or(0.0, |(_, info)| self.extrapolation_ticks(info) / hz);
        let smoothing = self.config.correction_smoothing;
        let decay = if smoothing > 0.0 {
            (-dt / smoothing).exp()
        } else {
            0.0
        };
        self.frame.render_tick = r;
        self.frame.entities.clear();
        self.drawn.retain(|id, _| self.entities.contains_key(id));
        for (&id, samples) in &self.entities {
            let after = samples.partition_point(|&(t, _)| (t as f64) <= r);
            let below = after.checked_sub(1).and_then(|i| samples.get(i)).copied();
            let above = samples.get(after).copied();
            // The state at the edge of what is in hand, in the direction of
            // play, and how far past it the render tick is (s of simulation
            // time, negative in reverse).
            let edge = if dir < 0.0 { above.or(below) } else { below };
            let Some((te, e)) = edge else {
                // Not there yet at the render tick.
                continue;
            };
            let ahead = ((r - te as f64) / hz).clamp(-max_ahead, max_ahead);
            let drawn = self.drawn.entry(id).or_insert(Drawn {
                extrapolated: false,
                offset: DVec3::ZERO,
                turn: DQuat::IDENTITY,
            });
            drawn.offset *= decay;
            drawn.turn = DQuat::IDENTITY.slerp(drawn.turn, decay).normalize();
            let (position, rotation, extrapolated) = match (below, above) {
                (Some((ta, a)), Some((tb, b))) => {
                    let span = (tb - ta) as f64;
                    let s = ((r - ta as f64) / span).clamp(0.0, 1.0);
                    let h = span / hz;
                    let position = match (a.linear_velocity, b.linear_velocity) {
                        (Some(va), Some(vb)) => hermite(a.position, va, b.position, vb, h, s),
                        _ => a.position.lerp(b.position, s),
                    };
                    let rotation = slerp(a.rotation, b.rotation, s);
                    if drawn.extrapolated && smoothing > 0.0 {
                        // Keep drawing where the extrapolation was and
                        // blend the difference out.
                        let (p, q) = extrapolate(&e, ahead);
                        drawn.offset += p - position;
                        drawn.turn = (drawn.turn * q * rotation.inverse()).normalize();
                    }
                    (position, rotation, false)
                }
                _ => {
                    let (position, rotation) = extrapolate(&e, ahead);
                    (position, rotation, ahead != 0.0 && !e.at_rest)
                }
            };
            drawn.extrapolated = extrapolated;
            // Under a micrometre and a microradian: done.
            if drawn.offset.length_squared() < 1e-12 && drawn.turn.w.abs() > 1.0 - 1e-13 {
                drawn.offset = DVec3::ZERO;
                drawn.turn = DQuat::IDENTITY;
            }
            self.frame.entities.push(RenderedEntity {
                id,
                position: position + drawn.offset,
                rotation: (drawn.turn * rotation).normalize(),
                extrapolated,
            });
        }
    }
}

/// The pose of `a` carried `ahead` seconds of simulation time along its
/// velocities (back along them when negative; held when at rest or
/// without them).
fn extrapolate(a: &ViewEntity, ahead: f64) -> (DVec3, DQuat) {
    if a.at_rest || ahead == 0.0 {
        return (a.position, a.rotation);
    }
    let position = a.position + a.linear_velocity.unwrap_or_default() * ahead;
    let rotation = match a.angular_velocity {
        Some(w) => (DQuat::from_scaled_axis(w * ahead) * a.rotation).normalize(),
        None => a.rotation,
    };
    (position, rotation)
}

/// Cubic Hermite between `p0` (velocity `v0`) and `p1` (velocity `v1`),
/// `h` seconds apart, at fraction `s`.
fn hermite(p0: DVec3, v0: DVec3, p1: DVec3, v1: DVec3, h: f64, s: f64) -> DVec3 {
    let s2 = s * s;
    let s3 = s2 * s;
    let h00 = 2.0 * s3 - 3.0 * s2 + 1.0;
    let h10 = s3 - 2.0 * s2 + s;
    let h01 = -2.0 * s3 + 3.0 * s2;
    let h11 = s3 - s2;
    p0 * h00 + v0 * (h * h10) + p1 * h01 + v1 * (h * h11)
}

/// Spherical interpolation along the shortest arc.
fn slerp(a: DQuat, b: DQuat, s: f64) -> DQuat {
    let b = if a.dot(b) < 0.0 { -b } else { b };
    a.slerp(b, s).normalize()
}

/// Puts the state `view` of `tick` among an entity's samples (in tick
/// order, replacing one of the same tick); beyond `max` samples drops the
/// one furthest from the render tick `render`.
fn add_sample(
    samples: &mut VecDeque<(u64, ViewEntity)>,
    tick: u64,
    view: ViewEntity,
    max: usize,
    render: Option<f64>,
) {
    if samples.back().is_none_or(|s| s.0 < tick) {
        // In order, as nearly every snapshot is.
        samples.push_back((tick, view));
    } else {
        let at = samples.partition_point(|&(t, _)| t < tick);
        match samples.get_mut(at) {
            Some(s) if s.0 == tick => s.1 = view,
            _ => samples.insert(at, (tick, view)),
        }
    }
    if samples.len() > max {
        let r = render.unwrap_or(f64::INFINITY);
        let front = samples.front().map_or(0.0, |s| (r - s.0 as f64).abs());
        let back = samples.back().map_or(0.0, |s| (r - s.0 as f64).abs());
        if front >= back {
            samples.pop_front();
        } else {
            samples.pop_back();
        }
    }
}

/// Drops an entity's samples outside the ticks `(lo, hi)` still to be
/// drawn, keeping the one at or before `lo` and the one at or after `hi`.
fn trim(samples: &mut VecDeque<(u64, ViewEntity)>, (lo, hi): (f64, f64)) {
    while samples.len() >= 2 && samples[1].0 as f64 <= lo {
        samples.pop_front();
    }
    while samples.len() >= 2 && samples[samples.len() - 2].0 as f64 >= hi {
        samples.pop_back();
    }
}

/// A snapshot as the tests send it: its header and the states it
/// carries.
#[cfg(test)]
#[derive(Debug, Clone)]
struct Sent {
    meta: SnapshotMeta,
    entities: Vec<ViewEntity>,
}

/// Pushes a snapshot the tests sent, as the driver pushes what it decoded.
#[cfg(test)]
fn push(buffer: &mut InterpolationBuffer, local_time: f64, sent: Sent) -> Observation {
    buffer.push_states(local_time, sent.meta, &sent.entities)
}

#[cfg(test)]
mod tests;

#[cfg(test)]
mod walk_tests;

#[cfg(test)]
mod reverse_tests;
