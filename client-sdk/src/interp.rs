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
//!   arrival timeline at the render delay; it never runs backwards.
//! - Position is Hermite-interpolated when both snapshots carry velocities
//!   (else linear); rotation is slerped along the shortest arc.
//! - Past the newest snapshot it extrapolates with velocity for at most
//!   [`InterpConfig::max_extrapolation`] seconds of simulation time (of
//!   local time when fast-forwarding), then holds (a stall).
//! - When fresh data replaces an extrapolation, the difference is blended
//!   out over [`InterpConfig::correction_smoothing`] instead of popping.
//! - A discontinuity (seek, rewind) flushes the buffer, is reported as an
//!   [`InterpEvent`], and rendering restarts on the new timeline.
//! - Entities absent from recent snapshots (not sent this time, at rest)
//!   keep their last state; [`InterpolationBuffer::remove`] forgets one.
//!
//! Times are seconds of the client's local monotonic clock, passed in.

use std::collections::{BTreeMap, VecDeque};

use glam::{DQuat, DVec3};
use inertia_protocol::{EntityId, EntityState};

use crate::clock::{ClockConfig, Discontinuity, Observation, ServerClock, SnapshotMeta};

/// One entity as a snapshot shows it.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EntityView {
    /// The entity.
    pub id: EntityId,
    /// Position of its origin, m.
    pub position: DVec3,
    /// Orientation (unit quaternion).
    pub rotation: DQuat,
    /// Linear velocity, m/s of simulation time, when the snapshot has it.
    pub linear_velocity: Option<DVec3>,
    /// Angular velocity (world frame), rad/s of simulation time, when the
    /// snapshot has it.
    pub angular_velocity: Option<DVec3>,
    /// True when the body is at rest (asleep): it is never extrapolated.
    pub at_rest: bool,
}

impl From<&EntityState> for EntityView {
    fn from(s: &EntityState) -> Self {
        Self {
            id: s.id,
            position: s.position,
            rotation: s.rotation,
            linear_velocity: Some(s.linear_velocity),
            angular_velocity: Some(s.angular_velocity),
            at_rest: s.asleep,
        }
    }
}

/// A received snapshot: its header and the entities it carries (possibly
/// not all of them: entities out of view or not sent this time are absent).
#[derive(Debug, Clone, PartialEq)]
pub struct Snapshot {
    /// Sequence number, tick, time scale and pause state.
    pub meta: SnapshotMeta,
    /// The entities in it.
    pub entities: Vec<EntityView>,
}

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
    /// the tick rate (the least is 0: it never runs backwards).
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

/// The world as drawn at one local time.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct Frame {
    /// The (fractional) server tick rendered.
    pub render_tick: f64,
    /// The entities, by id.
    pub entities: Vec<RenderedEntity>,
}

impl Frame {
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
    time_scale: f32,
    paused: bool,
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
    snaps: BTreeMap<u64, SnapInfo>,
    entities: BTreeMap<EntityId, VecDeque<(u64, EntityView)>>,
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
    frame: Frame,
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
            snaps: BTreeMap::new(),
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
            frame: Frame::default(),
        }
    }

    /// The settings.
    pub fn config(&self) -> &InterpConfig {
        &self.config
    }

    /// The server clock fed by [`push`](Self::push).
    pub fn clock(&self) -> &ServerClock {
        &self.clock
    }

    /// The server clock, to feed it round-trip samples.
    pub fn clock_mut(&mut self) -> &mut ServerClock {
        &mut self.clock
    }

    /// Takes in a snapshot that arrived at `local_time` (s). Returns what
    /// the clock made of it; on a discontinuity the buffer is flushed first
    /// and an [`InterpEvent::Discontinuity`] queued.
    pub fn push(&mut self, local_time: f64, snapshot: Snapshot) -> Observation {
        let meta = snapshot.meta;
        let observation = self.clock.observe(local_time, meta);
        match observation {
            Observation::Stale => {
                self.stats.dropped += 1;
                return observation;
            }
            Observation::Discontinuity(d) => {
                self.snaps.clear();
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
        // Too old to ever be drawn.
        if let Some(r) = self.render_tick {
            let bracket = self.snaps.range(..=r.floor() as u64).next_back();
            if bracket.is_some_and(|(&t, _)| meta.tick < t) {
                self.stats.dropped += 1;
                return observation;
            }
        }
        let info = SnapInfo {
            time_scale: if meta.time_scale.is_finite() {
                meta.time_scale.max(0.0)
            } else {
                0.0
            },
            paused: meta.paused,
        };
        let in_order = !matches!(observation, Observation::Late);
        self.snaps
            .entry(meta.tick)
            .and_modify(|old| {
                old.paused |= info.paused;
                if in_order {
                    old.time_scale = info.time_scale;
                }
            })
            .or_insert(info);
        self.primed |= self.snaps.len() >= 2;
        for view in snapshot.entities {
            let samples = self.entities.entry(view.id).or_default();
            let at = samples.partition_point(|&(t, _)| t < meta.tick);
            match samples.get_mut(at) {
                Some(s) if s.0 == meta.tick => s.1 = view,
                _ => samples.insert(at, (meta.tick, view)),
            }
            if samples.len() > self.config.max_snapshots {
                samples.pop_front();
            }
        }
        self.prune();
        observation
    }

    /// Forgets an entity (despawned or out of view for good).
    pub fn remove(&mut self, id: EntityId) {
        self.entities.remove(&id);
        self.drawn.remove(&id);
    }

    /// Advances the render clock to `local_time` (s) and draws the world
    /// at the render tick.
    pub fn sample(&mut self, local_time: f64) -> &Frame {
        let t = local_time;
        let dt = self.last_sample.map_or(0.0, |l| (t - l).max(0.0));
        self.last_sample = Some(t.max(self.last_sample.unwrap_or(t)));
        self.update_delay(dt);
        let (Some((&oldest, _)), Some((&newest, &newest_info))) =
            (self.snaps.first_key_value(), self.snaps.last_key_value())
        else {
            self.frame.entities.clear();
            return &self.frame;
        };
        let limit = newest as f64 + self.extrapolation_ticks(&newest_info);
        let render = match self.render_tick {
            None => {
                let start = self
                    .clock
                    .arrival_tick_at(t - self.delay)
                    .unwrap_or(oldest as f64);
                start.clamp(oldest as f64, newest as f64)
            }
            Some(r) => {
                let rate = self.rate_at(r);
                let depth = self
                    .clock
                    .local_time_of_tick(r, t)
                    .map_or(self.delay, |at| t - at);
                let lag = depth - self.delay;
                let mut next = if lag > self.config.resync_after {
                    let to = self
                        .clock
                        .arrival_tick_at(t - self.delay)
                        .unwrap_or(r)
                        .min(newest as f64);
                    if to > r {
                        self.stats.resyncs += 1;
                        self.queue(InterpEvent::Resync {
                            from_tick: r,
                            to_tick: to,
                        });
                    }
                    to
                } else {
                    // Too close to the arrival edge, slow down within
                    // the delay; too far behind, catch up gently.
                    let time = if lag < 0.0 {
                        self.config.correction_time.min(self.delay)
                    } else {
                        self.config.correction_time
                    };
                    let speed = (1.0 + lag / time).clamp(0.0, self.config.max_speedup);
                    r + rate * speed * dt
                };
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
                next.max(r)
            }
        };
        self.render_tick = Some(render);
        let rate = self.rate_at(render);
        self.stats.buffer_ms = if rate > 0.0 {
            ((newest as f64 - render) / rate * 1000.0).max(0.0)
        } else {
            0.0
        };
        self.prune();
        self.draw(render, dt);
        &self.frame
    }

    /// The frame drawn by the last [`sample`](Self::sample).
    pub fn frame(&self) -> &Frame {
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
            snapshots: self.snaps.len(),
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

    /// The server's tick rate along the timeline at tick `r`, ticks/s: the
    /// time scale the server ran at between the snapshots around it (the
    /// faster of the two; real time for steps taken while paused).
    fn rate_at(&self, r: f64) -> f64 {
        let hz = self.config.clock.tick_hz;
        let before = self.snaps.range(..=r.floor() as u64).next_back();
        let after = self.snaps.range(r.floor() as u64 + 1..).next();
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
    /// the one at or before it) and any beyond the size bound.
    fn prune(&mut self) {
        let max = self.config.max_snapshots.max(2);
        while self.snaps.len() > max {
            self.snaps.pop_first();
        }
        let Some(r) = self.render_tick else {
            return;
        };
        let keep_from = self
            .snaps
            .range(..=r.floor() as u64)
            .next_back()
            .map(|(&t, _)| t);
        if let Some(from) = keep_from {
            while self.snaps.first_key_value().is_some_and(|(&t, _)| t < from) {
                self.snaps.pop_first();
            }
        }
        for samples in self.entities.values_mut() {
            while samples.len() >= 2 && samples[1].0 as f64 <= r {
                samples.pop_front();
            }
        }
    }

    fn draw(&mut self, r: f64, dt: f64) {
        let hz = self.config.clock.tick_hz;
        let max_ahead = self
            .snaps
            .last_key_value()
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
            let Some(&(ta, a)) = after.checked_sub(1).and_then(|i| samples.get(i)) else {
                // Not there yet at the render tick.
                continue;
            };
            let ahead = ((r - ta as f64) / hz).clamp(0.0, max_ahead);
            let drawn = self.drawn.entry(id).or_insert(Drawn {
                extrapolated: false,
                offset: DVec3::ZERO,
                turn: DQuat::IDENTITY,
            });
            drawn.offset *= decay;
            drawn.turn = DQuat::IDENTITY.slerp(drawn.turn, decay).normalize();
            let (position, rotation, extrapolated) = match samples.get(after) {
                Some(&(tb, b)) => {
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
                        let (p, q) = extrapolate(&a, ahead);
                        drawn.offset += p - position;
                        drawn.turn = (drawn.turn * q * rotation.inverse()).normalize();
                    }
                    (position, rotation, false)
                }
                None => {
                    let (position, rotation) = extrapolate(&a, ahead);
                    (position, rotation, ahead > 0.0 && !a.at_rest)
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
/// velocities (held when at rest or without them).
fn extrapolate(a: &EntityView, ahead: f64) -> (DVec3, DQuat) {
    if a.at_rest || ahead <= 0.0 {
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

#[cfg(test)]
mod tests {
    use super::*;

    fn snapshot(seq: u16, tick: u64, x: f64, vx: Option<f64>) -> Snapshot {
        Snapshot {
            meta: SnapshotMeta {
                seq: Some(seq),
                tick,
                time_scale: 1.0,
                paused: false,
            },
            entities: vec![EntityView {
                id: 7,
                position: DVec3::new(x, 0.0, 0.0),
                rotation: DQuat::IDENTITY,
                linear_velocity: vx.map(|v| DVec3::new(v, 0.0, 0.0)),
                angular_velocity: None,
                at_rest: false,
            }],
        }
    }

    #[test]
    fn hermite_is_exact_for_cubics_and_slerp_takes_the_short_way() {
        // x(t) = t³ on [1, 2]: velocities 3 and 12.
        let p = hermite(
            DVec3::X,
            DVec3::X * 3.0,
            DVec3::X * 8.0,
            DVec3::X * 12.0,
            1.0,
            0.5,
        );
        assert!((p.x - 1.5f64.powi(3)).abs() < 1e-12);
        let a = DQuat::from_rotation_y(0.1);
        let b = -DQuat::from_rotation_y(0.3);
        let m = slerp(a, b, 0.5);
        assert!(m.angle_between(DQuat::from_rotation_y(0.2)) < 1e-9);
    }

    #[test]
    fn a_steady_stream_renders_behind_by_the_delay_and_in_between() {
        let mut buf = InterpolationBuffer::new(60.0);
        let mut frames = 0;
        let mut t = 0.0;
        for k in 0..120u64 {
            // 30 Hz snapshots, 2 ticks apart, moving 1 m per tick.
            let arrive = k as f64 / 30.0 + 0.05;
            while t < arrive {
                let f = buf.sample(t);
                if let Some(e) = f.get(7) {
                    assert!((e.position.x - f.render_tick).abs() < 1e-9);
                    frames += 1;
                }
                t += 1.0 / 144.0;
            }
            buf.push(
                arrive,
                snapshot(k as u16, 2 * k, 2.0 * k as f64, Some(60.0)),
            );
        }
        assert!(frames > 400);
        let stats = buf.stats();
        assert_eq!(stats.stalls, 0);
        assert_eq!(stats.extrapolations, 0);
        let lag = (buf.clock().arrival_tick(t).unwrap() - buf.render_tick().unwrap()) / 60.0;
        assert!(
            (lag - buf.delay()).abs() < 0.02,
            "lag {lag} delay {}",
            buf.delay()
        );
        // 2 intervals and a margin.
        assert!((0.06..0.09).contains(&buf.delay()), "delay {}", buf.delay());
    }

    #[test]
    fn an_entity_absent_from_later_snapshots_holds_within_the_bound() {
        let mut buf = InterpolationBuffer::new(60.0);
        buf.push(0.0, snapshot(0, 0, 0.0, Some(60.0)));
        let mut other = snapshot(1, 2, 0.0, None);
        other.entities[0].id = 8;
        buf.push(0.01, other);
        // Render far ahead: 7 is extrapolated by at most 0.1 s (6 m).
        for k in 0..200 {
            buf.sample(k as f64 * 0.01);
        }
        let f = buf.sample(2.0);
        let e = f.get(7).unwrap();
        assert!(e.extrapolated);
        assert!(e.position.x <= 6.0 + 1e-9);
        assert_eq!(buf.stats().stalls, 1);
        buf.remove(7);
        assert!(buf.sample(2.1).get(7).is_none());
    }
}
