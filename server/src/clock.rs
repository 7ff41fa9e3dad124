//! The simulation clock: how many fixed ticks to run for the wall time that
//! has passed.
//!
//! Wall time only decides *when* ticks run; each tick is exactly `dt`
//! seconds of simulation time. Every loop of the tick thread hands the clock
//! the wall time since the last loop; the clock adds it, scaled by
//! `time_scale`, to an accumulator and answers with the number of whole
//! ticks the accumulator holds — at most `max_catch_up` of them. When the
//! machine cannot keep up, the backlog beyond the cap is dropped and an
//! **overrun** counted, so a slow tick degrades into slow motion instead of
//! a spiral of ever longer catch-ups.
//!
//! `time_scale` 0 is pause (remembered scale restored by [`Clock::resume`]),
//! below 1 slow motion, above 1 fast-forward. While paused, [`Clock::step`]
//! queues an exact number of ticks and [`Clock::run_to`] runs up to a tick
//! and pauses there; those run as fast as the cap allows and never drop
//! ticks.
//!
//! The clock is pure: no `Instant::now()` inside, so tests drive it with
//! made-up wall times.

use std::time::Duration;

/// The accepted time scales above zero: the admin protocol's bounds, so
/// a scale the wire accepts is one the clock runs.
pub use inertia_protocol::admin::{MAX_TIME_SCALE, MIN_TIME_SCALE};

/// The most simulation time [`Clock::step`] and [`Clock::run_to`] may
/// queue, s: an hour. Queued ticks run as fast as the machine allows (some
/// 30 000 a second for a small world), pegging the tick thread's core and
/// flooding the recording for as long as they last, so `step u64::MAX`
/// or `run-to u64::MAX` would do that for ever; more than this is refused.
pub const MAX_QUEUED_SECONDS: f64 = 3600.0;

/// Why a clock request was refused.
#[derive(Debug, Clone, Copy, PartialEq, thiserror::Error)]
pub enum ClockError {
    /// The scale is NaN, negative, between zero and [`MIN_TIME_SCALE`]
    /// or above [`MAX_TIME_SCALE`].
    #[error("time scale must be 0 (pause) or within {MIN_TIME_SCALE}..={MAX_TIME_SCALE}, got {0}")]
    TimeScale(f64),
    /// `run_to` a tick already passed: going back is a replay seek.
    #[error("tick {target} is not after the current tick {current}; seek a recording to go back")]
    InThePast {
        /// The requested tick.
        target: u64,
        /// The current tick.
        current: u64,
    },
    /// `step` or `run_to` would queue more than [`MAX_QUEUED_SECONDS`].
    #[error(
        "{ticks} ticks is more than step and run-to may queue ({max}, an hour of simulation); \
         ask for less, or set a speed"
    )]
    TooFar {
        /// The ticks that would be queued.
        ticks: u64,
        /// The most that may be.
        max: u64,
    },
}

/// The fixed-step clock. See the module docs.
#[derive(Debug, Clone, PartialEq)]
pub struct Clock {
    /// Simulation time per tick, s.
    dt: f64,
    /// Simulation seconds per wall second (0 = paused).
    time_scale: f64,
    /// The scale to return to on resume, > 0.
    resume_scale: f64,
    /// Simulation time owed but not yet run, s (< dt after each advance,
    /// unless capped).
    accumulator: f64,
    /// Most ticks run per advance.
    max_catch_up: u32,
    /// Ticks queued by `step` or `run_to` (they run even when paused).
    queued: u64,
    /// Ticks the clock has handed out.
    tick: u64,
    /// Advances that hit the cap with real-time ticks still owed.
    overruns: u64,
    /// Ticks dropped by those overruns.
    dropped_ticks: u64,
}

impl Clock {
    /// A clock of `tick_hz` ticks per simulation second (≥ 1), at scale 1,
    /// running at most `max_catch_up` (≥ 1) ticks per advance.
    pub fn new(tick_hz: u32, max_catch_up: u32) -> Clock {
        Clock {
            dt: 1.0 / f64::from(tick_hz.max(1)),
            time_scale: 1.0,
            resume_scale: 1.0,
            accumulator: 0.0,
            max_catch_up: max_catch_up.max(1),
            queued: 0,
            tick: 0,
            overruns: 0,
            dropped_ticks: 0,
        }
    }

    /// Starts counting at `tick` (a world restored from a save).
    pub fn with_tick(mut self, tick: u64) -> Clock {
        self.tick = tick;
        self
    }

    /// Simulation time per tick, s.
    pub fn dt(&self) -> f64 {
        self.dt
    }

    /// Ticks handed out so far (the world's tick when every one was run).
    pub fn tick(&self) -> u64 {
        self.tick
    }

    /// Simulation time, s: `tick × dt`.
    pub fn sim_time(&self) -> f64 {
        self.tick as f64 * self.dt
    }

    /// Simulation seconds per wall second; 0 while paused.
    pub fn time_scale(&self) -> f64 {
        self.time_scale
    }

    /// Whether real-time ticking is stopped.
    pub fn paused(&self) -> bool {
        self.time_scale == 0.0
    }

    /// Advances that hit the catch-up cap.
    pub fn overruns(&self) -> u64 {
        self.overruns
    }

    /// Ticks dropped by overruns (simulation time that never happened).
    pub fn dropped_ticks(&self) -> u64 {
        self.dropped_ticks
    }

    /// Ticks still queued by [`Clock::step`] or [`Clock::run_to`].
    pub fn queued(&self) -> u64 {
        self.queued
    }

    /// Sets the time scale (0 pauses; the last non-zero scale is what
    /// [`Clock::resume`] returns to).
    pub fn set_time_scale(&mut self, scale: f64) -> Result<(), ClockError> {
        if scale != 0.0 && !(MIN_TIME_SCALE..=MAX_TIME_SCALE).contains(&scale) {
            return Err(ClockError::TimeScale(scale));
        }
        if scale > 0.0 {
            self.resume_scale = scale;
        }
        self.time_scale = scale;
        Ok(())
    }

    /// Stops real-time ticking and drops any ticks still queued by
    /// [`Clock::step`] or [`Clock::run_to`] (pause means no more ticks);
    /// the partial tick in the accumulator is kept.
    pub fn pause(&mut self) {
        self.time_scale = 0.0;
        self.queued = 0;
    }

    /// Resumes at the last non-zero scale, dropping any queued steps.
    pub fn resume(&mut self) {
        self.time_scale = self.resume_scale;
        self.queued = 0;
    }

    /// The most ticks that may be queued: [`MAX_QUEUED_SECONDS`] of them.
    pub fn max_queued(&self) -> u64 {
        (MAX_QUEUED_SECONDS / self.dt).round() as u64
    }

    /// Refuses a queue of `ticks` beyond [`Clock::max_queued`].
    pub fn check_queue(&self, ticks: u64) -> Result<(), ClockError> {
        let max = self.max_queued();
        if ticks > max {
            return Err(ClockError::TooFar { ticks, max });
        }
        Ok(())
    }

    /// Queues exactly `n` more ticks, run even while paused; refused,
    /// changing nothing, when that would queue more than
    /// [`Clock::max_queued`].
    pub fn step(&mut self, n: u64) -> Result<(), ClockError> {
        let queued = self.queued.saturating_add(n);
        self.check_queue(queued)?;
        self.queued = queued;
        Ok(())
    }

    /// Pauses and queues the ticks up to `target`, which must lie ahead
    /// and within [`Clock::max_queued`]; refused, changing nothing,
    /// otherwise.
    pub fn run_to(&mut self, target: u64) -> Result<(), ClockError> {
        if target <= self.tick {
            return Err(ClockError::InThePast {
                target,
                current: self.tick,
            });
        }
        self.check_queue(target - self.tick)?;
        self.pause();
        self.queued = target - self.tick;
        Ok(())
    }

    /// Adds `wall_elapsed` and returns how many ticks to run now (they are
    /// counted as run). Queued ticks go first; real-time ticks fill the rest
    /// of the cap.
    pub fn advance(&mut self, wall_elapsed: Duration) -> u32 {
        let cap = u64::from(self.max_catch_up);
        let from_queue = self.queued.min(cap);
        self.queued -= from_queue;
        let mut n = from_queue;
        if self.time_scale > 0.0 {
            self.accumulator += wall_elapsed.as_secs_f64() * self.time_scale;
            // A hair of tolerance so 1/60 s of wall time at 60 Hz is a tick
            // despite rounding.
            let owed = ((self.accumulator + self.dt * 1e-9) / self.dt).floor() as u64;
            let room = cap - n;
            let run = owed.min(room);
            self.accumulator = (self.accumulator - run as f64 * self.dt).max(0.0);
            if owed > room {
                self.overruns += 1;
                self.dropped_ticks += owed - room;
                // Keep only the fraction of a tick: the rest never happens.
                self.accumulator = self.accumulator.rem_euclid(self.dt);
            }
            n += run;
        }
        self.tick += n;
        n as u32
    }

    /// Wall time until the next real-time tick falls due; `None` while
    /// paused (wait for a command), zero when queued ticks are waiting.
    pub fn until_next_tick(&self) -> Option<Duration> {
        if self.queued > 0 {
            return Some(Duration::ZERO);
        }
        if self.time_scale <= 0.0 {
            return None;
        }
        let wall = ((self.dt - self.accumulator) / self.time_scale).max(0.0);
        // Bounded scales keep this within a minute; never panic on it.
        Some(Duration::try_from_secs_f64(wall).unwrap_or(Duration::MAX))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FRAME: Duration = Duration::from_micros(16_667);

    fn ms(n: u64) -> Duration {
        Duration::from_millis(n)
    }

    #[test]
    fn real_time_runs_one_tick_per_sixtieth() {
        let mut c = Clock::new(60, 5);
        let ticks: u32 = (0..600).map(|_| c.advance(FRAME)).sum();
        assert!((599..=601).contains(&ticks), "{ticks}");
        assert_eq!(c.tick(), u64::from(ticks));
        assert!((c.sim_time() - 10.0).abs() < 0.02);
    }

    #[test]
    fn partial_ticks_accumulate() {
        let mut c = Clock::new(60, 5);
        assert_eq!(c.advance(ms(10)), 0);
        assert_eq!(c.advance(ms(10)), 1);
        let left = c.until_next_tick().unwrap();
        assert!(left > ms(13) && left < ms(14), "{left:?}");
    }

    #[test]
    fn slow_motion_and_fast_forward() {
        let mut c = Clock::new(60, 10);
        c.set_time_scale(0.25).unwrap();
        let slow: u32 = (0..240).map(|_| c.advance(FRAME)).sum();
        assert!((59..=61).contains(&slow), "quarter speed: {slow}");
        let mut c = Clock::new(60, 10);
        c.set_time_scale(4.0).unwrap();
        let fast: u32 = (0..60).map(|_| c.advance(FRAME)).sum();
        assert!((239..=241).contains(&fast), "4x: {fast}");
        assert_eq!(c.overruns(), 0);
        assert_eq!(
            c.until_next_tick().map(|d| d <= FRAME / 4 + ms(1)),
            Some(true)
        );
        assert!(c.set_time_scale(-1.0).is_err());
        assert!(c.set_time_scale(f64::NAN).is_err());
        assert!(c.set_time_scale(1000.0).is_err());
    }

    /// Pins issue 11 defect 1: `speed 1e-300` passed validation and then
    /// panicked the tick thread converting the wall time to the next tick
    /// into a `Duration`.
    #[test]
    fn issue_11_tiny_time_scale_is_refused_and_never_panics() {
        let mut c = Clock::new(60, 5);
        for s in [1e-300, 5e-324, MIN_TIME_SCALE / 2.0, -0.0001, f64::NAN] {
            assert!(
                matches!(c.set_time_scale(s), Err(ClockError::TimeScale(_))),
                "{s}"
            );
        }
        assert_eq!(c.time_scale(), 1.0, "a refused scale changes nothing");
        c.set_time_scale(MIN_TIME_SCALE).unwrap();
        let wait = c.until_next_tick().unwrap();
        assert!(wait <= Duration::from_secs(18), "{wait:?}");
        c.set_time_scale(0.0).unwrap();
        assert!(c.paused());
    }

    /// Pins issue 11 defect 7: `pause` did not cancel a queued `step` or
    /// `run-to`, so ticks ran on (about 900 a second) while status said
    /// paused.
    #[test]
    fn issue_11_pause_cancels_queued_steps() {
        let mut c = Clock::new(60, 5);
        c.pause();
        c.step(100_000).unwrap();
        assert_eq!(c.advance(Duration::ZERO), 5);
        c.pause();
        assert_eq!(c.queued(), 0);
        assert_eq!(c.until_next_tick(), None, "nothing due while paused");
        assert_eq!(c.advance(ms(100)), 0);
        c.run_to(c.tick() + 1_000).unwrap();
        assert!(c.advance(Duration::ZERO) > 0);
        c.pause();
        assert_eq!(c.advance(ms(100)), 0, "pause stops a run-to too");
        assert_eq!(c.queued(), 0);
    }

    #[test]
    fn pause_stops_and_step_runs_exactly_n() {
        let mut c = Clock::new(60, 5);
        c.advance(FRAME);
        let t0 = c.tick();
        c.pause();
        assert!(c.paused());
        assert_eq!(c.until_next_tick(), None);
        for _ in 0..100 {
            assert_eq!(c.advance(ms(100)), 0);
        }
        assert_eq!(c.tick(), t0);
        c.step(12).unwrap();
        assert_eq!(c.until_next_tick(), Some(Duration::ZERO));
        let mut run = 0;
        while c.queued() > 0 {
            let n = c.advance(Duration::ZERO);
            assert!(n <= 5, "queued steps respect the cap");
            run += n;
        }
        assert_eq!(run, 12);
        assert_eq!(c.tick(), t0 + 12);
        assert_eq!(c.advance(ms(500)), 0, "still paused after the steps");
        c.resume();
        assert_eq!(c.time_scale(), 1.0);
        assert!(c.advance(ms(20)) >= 1);
    }

    /// Pins issue 11's abuse suite finding: `step u64::MAX` and `run-to
    /// u64::MAX` were accepted and ran ticks flat out for ever (some
    /// 30 000 a second), pegging a core and flooding the recording.
    #[test]
    fn issue_11_steps_and_runs_beyond_an_hour_are_refused_and_change_nothing() {
        let mut c = Clock::new(60, 5);
        assert_eq!(c.max_queued(), 216_000);
        c.pause();
        for n in [u64::MAX, 216_001] {
            assert_eq!(
                c.step(n),
                Err(ClockError::TooFar {
                    ticks: n,
                    max: 216_000
                })
            );
        }
        assert_eq!(c.queued(), 0, "a refused step queues nothing");
        c.step(200_000).unwrap();
        assert!(
            matches!(c.step(16_001), Err(ClockError::TooFar { .. })),
            "steps add up to the limit"
        );
        c.step(16_000).unwrap();
        assert_eq!(c.queued(), 216_000);
        c.resume();
        assert_eq!(c.queued(), 0);
        for target in [u64::MAX, c.tick() + 216_001] {
            assert!(matches!(c.run_to(target), Err(ClockError::TooFar { .. })));
        }
        assert!(!c.paused(), "a refused run-to does not pause");
        assert_eq!(c.queued(), 0);
        c.run_to(c.tick() + 216_000).unwrap();
        assert!(c.paused());
        // At 1000 Hz an hour is more ticks.
        assert_eq!(Clock::new(1000, 5).max_queued(), 3_600_000);
    }

    #[test]
    fn pause_via_scale_zero_resumes_at_the_last_scale() {
        let mut c = Clock::new(60, 5);
        c.set_time_scale(0.5).unwrap();
        c.set_time_scale(0.0).unwrap();
        assert!(c.paused());
        assert_eq!(c.advance(ms(1000)), 0);
        c.resume();
        assert_eq!(c.time_scale(), 0.5);
    }

    #[test]
    fn run_to_stops_at_the_tick() {
        let mut c = Clock::new(60, 5);
        c.run_to(23).unwrap();
        let mut total = 0;
        for _ in 0..10 {
            total += c.advance(ms(1));
        }
        assert_eq!(total, 23);
        assert_eq!(c.tick(), 23);
        assert!(c.paused());
        assert_eq!(
            c.run_to(10),
            Err(ClockError::InThePast {
                target: 10,
                current: 23
            })
        );
    }

    #[test]
    fn a_stall_is_capped_and_counted() {
        let mut c = Clock::new(60, 5);
        // One second lost (a debugger, a swap storm): 60 ticks owed.
        let n = c.advance(Duration::from_secs(1));
        assert_eq!(n, 5, "never more than the cap in one loop");
        assert_eq!(c.overruns(), 1);
        assert_eq!(c.dropped_ticks(), 55);
        // The backlog is gone: the next frame runs about one tick.
        assert!(c.advance(FRAME) <= 2);
        assert_eq!(c.overruns(), 1);
    }

    #[test]
    fn fast_forward_past_the_cap_overruns_every_loop() {
        let mut c = Clock::new(60, 5);
        c.set_time_scale(8.0).unwrap();
        for _ in 0..10 {
            assert_eq!(c.advance(FRAME), 5);
        }
        assert_eq!(c.overruns(), 10);
    }
}
