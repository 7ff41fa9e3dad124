//! Emitters: spouts that add particles to a fluid over simulation time.
//!
//! An emitter fires *shots*: shot `k` is due at `start + k · interval`
//! seconds of simulation time (none after `stop`). A shot is the nozzle's
//! pattern of particles: every point of a square lattice `spacing` apart,
//! across the nozzle (perpendicular to the velocity), within `radius` of
//! its centre, all moving at the emitter's velocity. At the end of each
//! step the fluid fires every shot that has come due, each placed where it
//! would be had it left the nozzle on time (`velocity · (now − t_k)`
//! downstream), so a jet looks the same at any tick rate.
//!
//! Everything is worked out from the world's time and the count of shots
//! fired so far, both in the saved state: a restored world emits the same
//! particles at the same steps. A shot that finds no room (the emitter's
//! `limit` or the fluid's cap reached) adds only what fits, in the
//! pattern's order; shots due while there is no room at all are skipped.

use glam::DVec3;

use crate::error::{finite, finite3, non_negative, positive, PhysicsError};
use crate::limits;

/// Most emitters one fluid may have.
pub const MAX_FLUID_EMITTERS: usize = 64;

/// Most particles one shot of an emitter may hold.
pub const MAX_NOZZLE_PARTICLES: usize = 4096;

/// How late (s) a shot may be found due and still count as on time: the
/// world's clock is a running sum of steps, a little off a round time.
const TIME_SLACK: f64 = 1e-9;

/// A spout that adds particles to its fluid over simulation time (see the
/// module notes for when and where).
#[derive(Debug, Clone, PartialEq)]
pub struct FluidEmitter {
    /// Centre of the nozzle, m.
    pub position: DVec3,
    /// Velocity of the particles let out, m/s; its direction is the
    /// nozzle's axis, so it must not be zero.
    pub velocity: DVec3,
    /// Radius of the nozzle, m, >= 0 (0: one particle a shot).
    pub radius: f64,
    /// Time between shots, s; `None`: `spacing / speed`, a continuous jet.
    /// At least `spacing / speed`, so that a shot has left the nozzle
    /// before the next one comes out.
    pub interval: Option<f64>,
    /// When the first shot is due, s of simulation time, >= 0.
    pub start: f64,
    /// No shot is due after this time, s (>= `start`); `None`: never
    /// stops.
    pub stop: Option<f64>,
    /// Most particles it adds in all, > 0; `None`: until the fluid's cap.
    pub limit: Option<u64>,
}

impl FluidEmitter {
    /// A one-particle jet at `position` (m) with `velocity` (m/s),
    /// starting at time 0 and never stopping.
    pub fn new(position: DVec3, velocity: DVec3) -> Self {
        Self {
            position,
            velocity,
            radius: 0.0,
            interval: None,
            start: 0.0,
            stop: None,
            limit: None,
        }
    }

    /// Checks every field for a fluid whose particles are `spacing` m
    /// apart; the first problem found is returned.
    pub fn validate(&self, spacing: f64) -> Result<(), PhysicsError> {
        positive("fluid particle spacing", spacing)?;
        finite3("fluid emitter position", self.position)?;
        limits::position("fluid emitter position (m)", self.position)?;
        crate::error::direction("fluid emitter velocity", self.velocity)?;
        let speed = self.velocity.length();
        limits::in_range("fluid emitter speed (m/s)", speed, 0.0, limits::MAX_SPEED)?;
        non_negative("fluid emitter radius", self.radius)?;
        // Checked before the pattern is made, so a huge radius does not
        // make a huge pattern first.
        let widest = 2.0 * (MAX_NOZZLE_PARTICLES as f64 / std::f64::consts::PI).sqrt();
        if self.radius > widest * spacing {
            return Err(PhysicsError::OutOfRange {
                what: "fluid emitter radius (m)",
                value: self.radius,
                min: 0.0,
                max: widest * spacing,
            });
        }
        let shot = self.nozzle(spacing).len();
        if shot > MAX_NOZZLE_PARTICLES {
            return Err(PhysicsError::Invalid {
                what: "fluid emitter radius",
                why: format!(
                    "a shot of {shot} particles is more than {MAX_NOZZLE_PARTICLES}: use a smaller nozzle"
                ),
            });
        }
        if let Some(interval) = self.interval {
            positive("fluid emitter interval", interval)?;
            if interval * speed < spacing * (1.0 - 1e-9) {
                return Err(PhysicsError::Invalid {
                    what: "fluid emitter interval",
                    why: format!(
                        "shots {interval} s apart at {speed} m/s are {} m apart, closer than the spacing {spacing} m: they would overlap",
                        interval * speed
                    ),
                });
            }
        }
        non_negative("fluid emitter start", self.start)?;
        limits::in_range("fluid emitter start (s)", self.start, 0.0, limits::MAX_TIME)?;
        if let Some(stop) = self.stop {
            finite("fluid emitter stop", stop)?;
            if stop < self.start {
                return Err(PhysicsError::Invalid {
                    what: "fluid emitter stop",
                    why: format!("{stop} s is before its start, {} s", self.start),
                });
            }
        }
        if self.limit == Some(0) {
            return Err(PhysicsError::NotPositive {
                what: "fluid emitter limit",
                value: 0.0,
            });
        }
        Ok(())
    }

    /// The time between shots for a fluid `spacing` m apart, s.
    pub fn shot_interval(&self, spacing: f64) -> f64 {
        self.interval
            .unwrap_or_else(|| spacing / self.velocity.length())
    }

    /// Where one shot's particles are, relative to the nozzle's centre, m,
    /// in the order they are let out: rows across the nozzle, the centre
    /// particle among them.
    pub fn nozzle(&self, spacing: f64) -> Vec<DVec3> {
        let axis = self.velocity.normalize_or_zero();
        let (u, v) = if axis == DVec3::ZERO {
            (DVec3::X, DVec3::Z)
        } else {
            axis.any_orthonormal_pair()
        };
        let n = (self.radius / spacing + 1e-9).floor() as i64;
        let r2 = self.radius * self.radius + 1e-9 * spacing * spacing;
        let mut out = Vec::new();
        for j in -n..=n {
            for i in -n..=n {
                let offset = u * (i as f64 * spacing) + v * (j as f64 * spacing);
                if offset.length_squared() <= r2 {
                    out.push(offset);
                }
            }
        }
        out
    }
}

/// An emitter at work: its description and how far it has got.
#[derive(Debug, Clone, PartialEq)]
pub struct EmitterState {
    pub(crate) desc: FluidEmitter,
    /// One shot's particles, relative to the nozzle, m (derived).
    pub(crate) nozzle: Vec<DVec3>,
    /// Time between shots, s (derived).
    pub(crate) interval: f64,
    /// Shots fired or skipped so far.
    pub(crate) shots: u64,
    /// Particles added so far.
    pub(crate) emitted: u64,
}

impl EmitterState {
    /// A checked emitter for a fluid `spacing` m apart that has fired
    /// `shots` shots and added `emitted` particles.
    pub(crate) fn new(
        desc: FluidEmitter,
        spacing: f64,
        shots: u64,
        emitted: u64,
    ) -> Result<Self, PhysicsError> {
        desc.validate(spacing)?;
        if let Some(limit) = desc.limit {
            if emitted > limit {
                return Err(PhysicsError::Invalid {
                    what: "fluid emitter",
                    why: format!("{emitted} particles emitted, past its limit of {limit}"),
                });
            }
        }
        Ok(Self {
            nozzle: desc.nozzle(spacing),
            interval: desc.shot_interval(spacing),
            desc,
            shots,
            emitted,
        })
    }

    /// Its description.
    pub fn desc(&self) -> &FluidEmitter {
        &self.desc
    }

    /// Shots fired (or skipped for want of room) so far.
    pub fn shots(&self) -> u64 {
        self.shots
    }

    /// Particles it has added so far.
    pub fn emitted(&self) -> u64 {
        self.emitted
    }

    /// Particles in one full shot.
    pub fn shot_size(&self) -> usize {
        self.nozzle.len()
    }

    /// When shot `k` is due, s.
    pub(crate) fn due_time(&self, k: u64) -> f64 {
        self.desc.start + k as f64 * self.interval
    }

    /// How many shots are due by `now` (s): those with
    /// `start + k · interval <= min(now, stop)`.
    pub(crate) fn due_by(&self, now: f64) -> u64 {
        let last = match self.desc.stop {
            Some(stop) => now.min(stop),
            None => now,
        };
        if last + TIME_SLACK < self.desc.start {
            return 0;
        }
        let k = ((last - self.desc.start + TIME_SLACK) / self.interval).floor();
        // `as` saturates: a due count past u64 is as good as endless.
        (k as u64).saturating_add(1)
    }

    /// How many shots were due strictly before `now` (s): the shots an
    /// emitter added at `now` skips, so it does not fire its past at once.
    pub(crate) fn due_before(&self, now: f64) -> u64 {
        self.due_by(now - 2.0 * TIME_SLACK)
    }

    /// Whether it will add no more particles (its limit reached, or no
    /// shot is due after `now`).
    pub fn is_done(&self, now: f64) -> bool {
        let spent = self.desc.limit.is_some_and(|l| self.emitted >= l);
        let stopped = self
            .desc
            .stop
            .is_some_and(|stop| self.shots >= self.due_by(stop.max(now)));
        spent || stopped
    }
}
