//! The client's estimate of the server's tick as a function of its own
//! monotonic clock.
//!
//! Every snapshot carries the tick it describes, the server's time scale
//! and whether the server is paused. [`ServerClock`] turns those arrivals
//! into a smooth, piecewise-linear *arrival timeline*: the tick of the
//! freshest snapshot a client should have in hand at a given local time,
//! as if every packet took the shortest delay seen lately.
//!
//! - Jitter: within a stretch of constant time scale, each arrival gives an
//!   offset `tick − rate × local_time`; the timeline follows the *maximum*
//!   of those offsets over a sliding window (the minimum-delay envelope),
//!   so late packets never drag it back. The offset moves towards that
//!   envelope at a bounded slew (a few percent of the tick rate), so the
//!   estimate never jumps on ordinary jitter.
//! - Time scale and pause: a change of scale or pause state starts a new
//!   segment, re-anchored at the arrival that announced it. While paused the
//!   timeline holds the paused tick.
//! - Reverse play: a negative time scale means the server plays recorded
//!   history backwards; the segment's rate (`tick_hz × time_scale`) is then
//!   negative and ticks that *decrease* in step with it are the normal flow.
//!   Everything above holds in the direction of play (the envelope is the
//!   lowest offset, the estimate runs down). A change of direction (forwards
//!   or paused to reverse, or back) is a new segment like any change of
//!   scale, not a discontinuity, as long as the tick carries on from near
//!   the newest one (either way: the server may have moved on before it
//!   turned).
//! - Reordering: with sequence numbers (which always increase, whichever
//!   way the ticks run), a packet older than the newest one is reported
//!   [`Observation::Late`]; without them, a small step against the
//!   direction of play is taken for reordering and a large one for a seek.
//! - Discontinuities: a tick that goes against the direction of play (a
//!   rewind or seek) or far ahead of the estimate along it (a seek
//!   forwards), or a change of direction far from the newest tick, restarts
//!   the timeline and is reported as [`Observation::Discontinuity`]. Packets
//!   of the old timeline that straggle in afterwards are reported
//!   [`Observation::Stale`].
//!
//! Everything is pure: times are passed in as seconds of the client's local
//! monotonic clock.

use std::collections::VecDeque;

/// How a [`ServerClock`] estimates and what it takes for a discontinuity.
/// Times in seconds of the client's local clock.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ClockConfig {
    /// The server's tick rate at time scale 1, ticks/s.
    pub tick_hz: f64,
    /// How far back arrivals count towards the minimum-delay envelope, s.
    pub window_s: f64,
    /// The most the estimate may run fast or slow to reach the envelope, as
    /// a fraction of the tick rate (0.05 = up to 5 % fast or slow).
    pub slew: f64,
    /// An envelope further than this from the estimate is snapped to at
    /// once rather than slewed to, s of ticks at the current rate.
    pub snap_s: f64,
    /// How much older than the newest tick a packet may be and still count
    /// as reordered rather than a seek backwards, s of ticks at the larger
    /// of the nominal and the current rate (used when packets carry no
    /// sequence number), and how long after a discontinuity stragglers of
    /// the old timeline are dropped, s.
    pub reorder_window_s: f64,
    /// A tick further ahead of the estimate than this (plus the time since
    /// the last arrival) is a seek forwards, s of ticks at the larger of the
    /// nominal and the current rate.
    pub jump_forward_s: f64,
}

impl ClockConfig {
    /// Defaults for a server ticking at `tick_hz` ticks/s.
    pub fn new(tick_hz: f64) -> Self {
        Self {
            tick_hz,
            window_s: 2.0,
            slew: 0.05,
            snap_s: 0.25,
            reorder_window_s: 0.25,
            jump_forward_s: 1.0,
        }
    }
}

impl Default for ClockConfig {
    /// Defaults for the default 60 Hz tick.
    fn default() -> Self {
        Self::new(60.0)
    }
}

/// The timing part of a snapshot header.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SnapshotMeta {
    /// The snapshot's sequence number (wrapping), when the transport has
    /// one; it tells reordering from seeking for certain.
    pub seq: Option<u16>,
    /// The tick the snapshot describes.
    pub tick: u64,
    /// The server's time scale when it was sent (1 = real time; 0 = paused;
    /// negative while history plays backwards, −1 = real time in reverse).
    pub time_scale: f32,
    /// True while the server is paused (ticks do not advance).
    pub paused: bool,
}

/// A break in the server's timeline: a seek, a rewind, or a jump forwards
/// (reverse play at a steady rate is not one).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Discontinuity {
    /// Local time of the arrival that revealed it, s.
    pub local_time: f64,
    /// The newest tick of the old timeline.
    pub from_tick: u64,
    /// The first tick of the new timeline.
    pub to_tick: u64,
}

impl Discontinuity {
    /// True when the new timeline starts at a lower tick (a rewind or a
    /// seek back).
    pub fn is_backwards(&self) -> bool {
        self.to_tick < self.from_tick
    }
}

/// What [`ServerClock::observe`] made of a snapshot's arrival.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Observation {
    /// The newest snapshot so far, on the current timeline.
    InOrder,
    /// Older than the newest snapshot (reordered or duplicated) but on the
    /// current timeline: still worth keeping for interpolation.
    Late,
    /// A straggler from before the last discontinuity: drop it.
    Stale,
    /// The timeline broke; the clock restarted on the new one, of which
    /// this snapshot is the first.
    Discontinuity(Discontinuity),
}

/// The direction ticks run under a header's `time_scale` and `paused`: −1
/// while history plays backwards (a negative, finite scale, not paused),
/// else +1 (a step taken while paused moves the tick forwards).
pub fn direction_of(time_scale: f32, paused: bool) -> f64 {
    if !paused && time_scale.is_finite() && time_scale < 0.0 {
        -1.0
    } else {
        1.0
    }
}

/// True when sequence number `a` is older than `b` (wrapping, half range).
pub fn seq_older(a: u16, b: u16) -> bool {
    a != b && b.wrapping_sub(a) < 0x8000
}

/// A stretch of constant tick rate.
#[derive(Debug, Clone)]
struct Segment {
    /// Ticks per local second (0 while paused, negative in reverse).
    rate: f64,
    /// Arrivals in this segment as (local time, offset `tick − rate·t`).
    samples: VecDeque<(f64, f64)>,
    /// The estimate's offset at `t_u`, ticks.
    offset: f64,
    /// The offset the estimate slews towards, ticks.
    target: f64,
    /// When `offset` was last set, s.
    t_u: f64,
}

impl Segment {
    fn offset_at(&self, slew: f64, t: f64) -> f64 {
        let reach = slew * self.rate.abs() * (t - self.t_u).max(0.0);
        self.offset + (self.target - self.offset).clamp(-reach, reach)
    }
}

/// Samples of arrival excess kept for the jitter estimate.
const EXCESS_SAMPLES: usize = 64;
/// Seconds of estimate history kept for [`ServerClock::local_time_of_tick`].
const HISTORY_S: f64 = 5.0;
/// The most history knots kept.
const HISTORY_KNOTS: usize = 1024;

/// The server's tick as a function of local time, estimated from snapshot
/// arrivals and round-trip samples. See the [module docs](self).
#[derive(Debug, Clone)]
pub struct ServerClock {
    config: ClockConfig,
    segment: Option<Segment>,
    time_scale: f32,
    paused: bool,
    /// The direction of play of the current segment, ±1.
    dir: f64,
    /// After a change of direction (no sequence numbers): until when a
    /// packet of the old direction near the newest tick is taken for
    /// reordering, and the old direction.
    turned: Option<(f64, f64)>,
    newest_tick: Option<u64>,
    newest_seq: Option<u16>,
    last_arrival: Option<f64>,
    /// Consecutive in-window backward steps (no sequence numbers).
    stale_run: u32,
    /// After a discontinuity: until when stragglers are dropped, the old
    /// timeline's tick range, and the new timeline's first sequence number.
    guard: Option<(f64, u64, u64, Option<u16>)>,
    /// Knots (local time, estimated tick) of the estimate's recent past.
    knots: VecDeque<(f64, f64)>,
    excess: VecDeque<f64>,
    mean_excess: f64,
    interval: Option<f64>,
    rtt: Option<f64>,
}

impl ServerClock {
    /// A clock for a server ticking at `tick_hz` ticks/s, other settings
    /// default.
    pub fn new(tick_hz: f64) -> Self {
        Self::with_config(ClockConfig::new(tick_hz))
    }

    /// A clock with the given settings.
    pub fn with_config(config: ClockConfig) -> Self {
        Self {
            config,
            segment: None,
            time_scale: 1.0,
            paused: false,
            dir: 1.0,
            turned: None,
            newest_tick: None,
            newest_seq: None,
            last_arrival: None,
            stale_run: 0,
            guard: None,
            knots: VecDeque::new(),
            excess: VecDeque::new(),
            mean_excess: 0.0,
            interval: None,
            rtt: None,
        }
    }

    /// The settings.
    pub fn config(&self) -> &ClockConfig {
        &self.config
    }

    /// Records a snapshot header that arrived at `local_time` (s) and says
    /// how it relates to the timeline so far.
    pub fn observe(&mut self, local_time: f64, meta: SnapshotMeta) -> Observation {
        let t = local_time;
        let scale = if meta.paused || !meta.time_scale.is_finite() {
            0.0
        } else {
            meta.time_scale
        };
        let paused = scale == 0.0;
        let dir = direction_of(scale, paused);
        let hz = self.config.tick_hz;
        let Some(newest) = self.newest_tick else {
            self.restart(t, meta, scale);
            return Observation::InOrder;
        };

        // Stragglers from before the last discontinuity.
        if let Some((until, lo, hi, first_seq)) = self.guard {
            if t > until {
                self.guard = None;
            } else {
                let stale = match (meta.seq, first_seq) {
                    (Some(s), Some(f)) => seq_older(s, f),
                    _ => (lo..=hi).contains(&meta.tick),
                };
                if stale {
                    return Observation::Stale;
                }
            }
        }

        let rate_now = self.tick_rate();
        let reach = hz.max(rate_now.abs()).max(hz * f64::from(scale).abs());
        let late_by_seq = match (meta.seq, self.newest_seq) {
            (Some(s), Some(n)) => Some(seq_older(s, n) || s == n),
            _ => None,
        };
        if late_by_seq == Some(true) {
            self.note_excess(t, meta.tick);
            return Observation::Late;
        }
        let step = meta.tick as f64 - newest as f64;
        let since = self.last_arrival.map_or(0.0, |a| (t - a).max(0.0));
        let tolerance = (reach * self.config.reorder_window_s).ceil() + 2.0;
        if dir != self.dir {
            if late_by_seq.is_none() {
                // Without sequence numbers, a packet of the old direction
                // just after a turn was sent before it.
                if let Some((until, old)) = self.turned {
                    if t <= until && dir == old && step.abs() <= tolerance {
                        self.note_excess(t, meta.tick);
                        return Observation::Late;
                    }
                }
            }
            // A turn carries on from about the newest tick, either way: the
            // old direction may have gone on a little before it turned.
            let turn_tolerance = reach * (since + self.config.reorder_window_s) + 2.0;
            if step.abs() > turn_tolerance {
                return self.discontinuity(t, newest, meta, scale);
            }
            self.turned = Some((t + self.config.reorder_window_s, self.dir));
            self.stale_run = 0;
        } else {
            // Ticks against the direction of play.
            let back = -self.dir * step;
            if back > 0.0 {
                // In sequence, a tick that goes back is a rewind, however
                // small.
                let seek = late_by_seq == Some(false) || back > tolerance || self.stale_run >= 2;
                if !seek {
                    self.stale_run += 1;
                    self.note_excess(t, meta.tick);
                    return Observation::Late;
                }
                return self.discontinuity(t, newest, meta, scale);
            }
            self.stale_run = 0;
            let d = self.dir;
            let predicted = self
                .arrival_tick(t)
                .map_or(d * newest as f64, |e| d * e)
                .max(d * newest as f64);
            let forward_tolerance = reach * (self.config.jump_forward_s + since) + 2.0;
            if d * meta.tick as f64 > predicted + forward_tolerance {
                return self.discontinuity(t, newest, meta, scale);
            }
        }

        // In order on the current timeline.
        if let Some(last) = self.last_arrival {
            let gap = t - last;
            if (0.0..1.0).contains(&gap) {
                self.interval = Some(match self.interval {
                    Some(i) => i + 0.1 * (gap - i),
                    None => gap,
                });
            }
        }
        self.last_arrival = Some(t);
        self.newest_tick = Some(meta.tick);
        if meta.seq.is_some() {
            self.newest_seq = meta.seq;
        }
        let before = self.arrival_tick(t).unwrap_or(meta.tick as f64);
        self.push_knot(t, before);
        if paused != self.paused || (!paused && scale != self.time_scale) {
            self.time_scale = scale;
            self.paused = paused;
            self.start_segment(t, meta.tick, f64::from(scale) * hz);
        } else if paused {
            // Held at the paused tick; a step while paused moves it.
            if let Some(seg) = &mut self.segment {
                seg.offset = meta.tick as f64;
                seg.target = seg.offset;
                seg.t_u = t;
            }
        } else {
            self.note_excess(t, meta.tick);
            let cfg = self.config;
            let mean_excess = self.mean_excess;
            if let Some(seg) = &mut self.segment {
                seg.offset = seg.offset_at(cfg.slew, t);
                seg.t_u = t;
                seg.samples.push_back((t, meta.tick as f64 - seg.rate * t));
                while seg
                    .samples
                    .front()
                    .is_some_and(|&(ts, _)| ts < t - cfg.window_s)
                {
                    seg.samples.pop_front();
                }
                let n = seg.samples.len() as f64;
                // The freshest offsets: the highest going forwards, the
                // lowest in reverse.
                let d = seg.rate.signum();
                let envelope = d * seg
                    .samples
                    .iter()
                    .map(|&(_, o)| d * o)
                    .fold(f64::NEG_INFINITY, f64::max);
                seg.target = envelope + seg.rate * 2.0 * mean_excess / (n + 1.0);
                if (seg.target - seg.offset).abs() > seg.rate.abs() * cfg.snap_s {
                    seg.offset = seg.target;
                }
            }
        }
        let after = self.arrival_tick(t).unwrap_or(meta.tick as f64);
        self.push_knot(t, after);
        Observation::InOrder
    }

    /// Like [`observe`](Self::observe) for a header without a sequence
    /// number: `tick`, `time_scale` and `paused` as the snapshot says.
    pub fn observe_tick(
        &mut self,
        local_time: f64,
        tick: u64,
        time_scale: f32,
        paused: bool,
    ) -> Observation {
        self.observe(
            local_time,
            SnapshotMeta {
                seq: None,
                tick,
                time_scale,
                paused,
            },
        )
    }

    /// Records a round-trip time sample, s (smoothed as TCP does, 1/8).
    pub fn rtt_sample(&mut self, seconds: f64) {
        if !(seconds.is_finite() && seconds >= 0.0) {
            return;
        }
        self.rtt = Some(match self.rtt {
            Some(r) => r + (seconds - r) / 8.0,
            None => seconds,
        });
    }

    /// The smoothed round-trip time, s, once a sample came in.
    pub fn rtt(&self) -> Option<f64> {
        self.rtt
    }

    /// The tick of the freshest snapshot that should be in hand at
    /// `local_time` (s), fractional, on the minimum-delay envelope; `None`
    /// before the first snapshot.
    pub fn arrival_tick(&self, local_time: f64) -> Option<f64> {
        let seg = self.segment.as_ref()?;
        if seg.rate == 0.0 {
            return Some(seg.offset);
        }
        Some(seg.rate * local_time + seg.offset_at(self.config.slew, local_time))
    }

    /// The server's current tick at `local_time` (s), fractional: the
    /// arrival timeline plus half the smoothed round trip. `None` before
    /// the first snapshot.
    pub fn estimated_tick(&self, local_time: f64) -> Option<f64> {
        let arrival = self.arrival_tick(local_time)?;
        Some(arrival + self.tick_rate() * self.rtt.unwrap_or(0.0) / 2.0)
    }

    /// The arrival timeline at a past or present local time (s), from the
    /// history kept (a few seconds); `None` before the first snapshot.
    pub fn arrival_tick_at(&self, local_time: f64) -> Option<f64> {
        let &(t_last, _) = self.knots.back()?;
        if local_time >= t_last {
            return self.arrival_tick(local_time);
        }
        let mut later = None;
        for &(t, e) in self.knots.iter().rev() {
            if t <= local_time {
                return Some(match later {
                    Some((t1, e1)) if t1 > t => e + (e1 - e) * (local_time - t) / (t1 - t),
                    _ => e,
                });
            }
            later = Some((t, e));
        }
        self.knots.front().map(|&(_, e)| e)
    }

    /// The latest local time (s) at which the arrival timeline was at or
    /// before `tick` in its direction of play (at or above it in reverse),
    /// as seen at `now` (s): when `tick` arrived, on the envelope. In the
    /// future when `tick` is ahead of the timeline; the end of a pause for
    /// the paused tick. `None` before the first snapshot.
    pub fn local_time_of_tick(&self, tick: f64, now: f64) -> Option<f64> {
        self.local_time_reached(tick, now, f64::NEG_INFINITY)
    }

    /// Like [`local_time_of_tick`](Self::local_time_of_tick), looking no
    /// further back than `since` (s): the answer is at least `since`. Where
    /// the timeline turned, `since` is when its current direction began, so
    /// that a tick it passed the other way before is not taken.
    pub fn local_time_reached(&self, tick: f64, now: f64, since: f64) -> Option<f64> {
        let d = self.dir;
        let e_now = self.arrival_tick(now)?;
        if d * e_now <= d * tick {
            let rate = self.tick_rate();
            return Some(if rate != 0.0 {
                now + (tick - e_now) / rate
            } else {
                now
            });
        }
        let mut later = (now, e_now);
        for &(t, e) in self.knots.iter().rev() {
            if t > now {
                continue;
            }
            let (t1, e1) = later;
            if d * e1 <= d * tick || t1 <= since {
                return Some(t1.max(since));
            }
            if d * e <= d * tick {
                let at = if d * e1 > d * e {
                    t + (t1 - t) * (tick - e) / (e1 - e)
                } else {
                    t1
                };
                return Some(at.max(since));
            }
            later = (t, e);
        }
        // Older than the history: at the nominal rate before it.
        let (t0, e0) = later;
        let at = t0 - d * (e0 - tick) / self.config.tick_hz.max(self.tick_rate().abs());
        Some(at.max(since))
    }

    /// The server's time scale as last announced (0 while paused).
    pub fn time_scale(&self) -> f32 {
        self.time_scale
    }

    /// True while the server says it is paused.
    pub fn paused(&self) -> bool {
        self.paused
    }

    /// The server's current tick rate, ticks/s (0 while paused, negative
    /// while history plays backwards).
    pub fn tick_rate(&self) -> f64 {
        self.segment.as_ref().map_or(0.0, |s| s.rate)
    }

    /// The direction the timeline runs now: −1 in reverse play, else +1.
    pub fn direction(&self) -> f64 {
        self.dir
    }

    /// The newest tick received on the current timeline.
    pub fn newest_tick(&self) -> Option<u64> {
        self.newest_tick
    }

    /// How much later than the envelope snapshots arrive: the 95th
    /// percentile over the last 64 arrivals, s.
    pub fn jitter(&self) -> f64 {
        if self.excess.is_empty() {
            return 0.0;
        }
        let mut sorted: Vec<f64> = self.excess.iter().copied().collect();
        sorted.sort_by(f64::total_cmp);
        sorted[((sorted.len() - 1) as f64 * 0.95).round() as usize]
    }

    /// The smoothed time between snapshot arrivals, s, once two came in.
    pub fn snapshot_interval(&self) -> Option<f64> {
        self.interval
    }

    fn note_excess(&mut self, t: f64, tick: u64) {
        let rate = self.tick_rate();
        let Some(e) = self.arrival_tick(t) else {
            return;
        };
        if rate == 0.0 {
            return;
        }
        // How far the tick is behind the envelope, s (either direction).
        let excess = ((e - tick as f64) / rate).max(0.0);
        if excess > 2.0 {
            return;
        }
        self.mean_excess += 0.05 * (excess - self.mean_excess);
        if self.excess.len() == EXCESS_SAMPLES {
            self.excess.pop_front();
        }
        self.excess.push_back(excess);
    }

    fn push_knot(&mut self, t: f64, e: f64) {
        self.knots.push_back((t, e));
        while self.knots.len() > HISTORY_KNOTS
            || self.knots.front().is_some_and(|&(k, _)| k < t - HISTORY_S)
        {
            self.knots.pop_front();
        }
    }

    fn start_segment(&mut self, t: f64, tick: u64, rate: f64) {
        let (offset, samples) = if rate == 0.0 {
            (tick as f64, VecDeque::new())
        } else {
            let o = tick as f64 - rate * t;
            (o + rate * self.mean_excess, VecDeque::from([(t, o)]))
        };
        self.dir = if rate < 0.0 { -1.0 } else { 1.0 };
        self.segment = Some(Segment {
            rate,
            samples,
            offset,
            target: offset,
            t_u: t,
        });
    }

    fn restart(&mut self, t: f64, meta: SnapshotMeta, scale: f32) {
        self.time_scale = scale;
        self.paused = scale == 0.0;
        self.newest_tick = Some(meta.tick);
        self.newest_seq = meta.seq;
        self.last_arrival = Some(t);
        self.stale_run = 0;
        self.turned = None;
        self.knots.clear();
        self.start_segment(t, meta.tick, f64::from(scale) * self.config.tick_hz);
        let e = self.arrival_tick(t).unwrap_or(meta.tick as f64);
        self.push_knot(t, e);
    }

    fn discontinuity(
        &mut self,
        t: f64,
        newest: u64,
        meta: SnapshotMeta,
        scale: f32,
    ) -> Observation {
        let reach = self.config.tick_hz.max(self.tick_rate().abs());
        let span = (reach * self.config.reorder_window_s).ceil() as u64 + 2;
        // Packets sent just before the jump may carry ticks a little past
        // the newest one seen.
        self.guard = Some((
            t + self.config.reorder_window_s,
            newest.saturating_sub(span),
            newest.saturating_add(span),
            meta.seq,
        ));
        self.restart(t, meta, scale);
        Observation::Discontinuity(Discontinuity {
            local_time: t,
            from_tick: newest,
            to_tick: meta.tick,
        })
    }
}

#[cfg(test)]
mod tests;
