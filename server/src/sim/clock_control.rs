//! Clock control: pause, resume, speed, step and run-to, one path for an
//! operator's admin call, a [`super::SimHandle`] method and a test alike.
//!
//! The requests follow the operator's expectations: steps add up while
//! paused (a step on a running clock pauses it first, and is refused
//! before the pause if the queue cannot take it), and any request that
//! sets the clock going makes history that plays backwards play forward.
//! A request the clock refuses changes nothing.

use super::Simulation;
use crate::clock::ClockError;

/// A request to the simulation clock.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum ClockControl {
    /// Stop real-time ticking (ticks still queued by a step are dropped).
    Pause,
    /// Resume at the last non-zero time scale.
    Resume,
    /// Simulation seconds per wall second (0..=64; 0 pauses).
    Speed(f64),
    /// Run exactly this many more ticks, then stay paused.
    Step(u64),
    /// Run up to this tick, then pause.
    RunTo(u64),
}

impl Simulation {
    /// Carries out a clock request; on error nothing changed.
    pub fn control_clock(&mut self, request: ClockControl) -> Result<(), ClockError> {
        let clock = &mut self.shown_mut().clock;
        match request {
            ClockControl::Pause => {
                clock.pause();
                return Ok(());
            }
            ClockControl::Resume => clock.resume(),
            ClockControl::Speed(scale) => clock.set_time_scale(scale)?,
            ClockControl::Step(ticks) => {
                if !clock.paused() {
                    clock.check_queue(ticks)?;
                    clock.pause();
                }
                clock.step(ticks)?;
            }
            ClockControl::RunTo(tick) => clock.run_to(tick)?,
        }
        self.play_forward();
        Ok(())
    }
}
