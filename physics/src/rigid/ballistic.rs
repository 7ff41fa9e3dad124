//! Analytic ballistic paths for game AI: where a thrown point will be,
//! where its arc peaks, and how to throw to hit a target.
//!
//! # Design note
//!
//! **Motion.** A point starts at `p₀` with velocity `v₀` under uniform
//! gravity `g` (m/s², any direction) and an optional linear drag rate
//! `k` (1/s), the continuous form of a body's linear damping:
//! `dv/dt = g − k v`. With `x = k t`,
//!
//! ```text
//! v(t) = v₀ e^(−x) + g t φ₁(x)
//! p(t) = p₀ + v₀ t φ₁(x) + g t² φ₂(x)
//! φ₁(x) = (1 − e^(−x)) / x        φ₂(x) = (x − 1 + e^(−x)) / x²
//! ```
//!
//! so `k = 0` (`φ₁ = 1`, `φ₂ = ½`) is the textbook `p₀ + v₀ t + ½ g t²`.
//! `φ₂` cancels catastrophically for small `x`, so both are summed as their
//! Taylor series (`Σ (−x)ⁿ / (n + 1)!` and `Σ (−x)ⁿ / (n + 2)!`) for
//! `|x| < 1/4` and taken from `expm1` above: the two agree to rounding at
//! the switch, and `k → 0` tends smoothly to the drag-free path.
//!
//! **Apex.** The time where the velocity stops rising against gravity
//! (`v · ĝ = 0`): `t = u / |g|` without drag, `t = ln(1 + k u / |g|) / k`
//! with it (`u` the initial speed against gravity; `ln_1p` keeps it exact
//! as `k → 0`).
//!
//! **Aiming** (no drag). The launch velocity that reaches `d = to − from`
//! after `t` seconds is `d / t − ½ g t`; asking for its length to be the
//! launch speed `v` gives a quadratic in `t²`,
//! `¼|g|² t⁴ − (v² + d·g) t² + |d|² = 0`, which is the classic
//! `tan θ = (v² ± √(v⁴ − g(g x² + 2 y v²))) / (g x)` written without
//! angles, so it holds for any gravity direction and for targets straight
//! above or below. With `a = |g||d| − d·g` and `b = |g||d| + d·g`
//! (`a b = |d × g|²`; the smaller of the two is computed as that quotient,
//! so neither cancels), the target is in reach iff `v² ≥ a`, i.e. the
//! least launch speed is `√a`, and the two flight times are
//!
//! ```text
//! t_low  = 2 |d| / (√(v² − a) + √(v² + b))
//! t_high = (√(v² − a) + √(v² + b)) / |g|
//! ```
//!
//! free of cancellation. Without gravity there is one straight shot, given
//! as both arcs.

use glam::DVec3;

use crate::error::{finite, finite3, non_negative, positive, PhysicsError};
use crate::handle::BodyHandle;

/// [`World::predict_landing`](crate::World::predict_landing) walks the
/// path in chords that bulge off it by at most this much, m (unless that
/// would take more than [`LANDING_MAX_CHORDS`]).
pub const LANDING_SAGITTA: f64 = 0.01;

/// The most chords [`World::predict_landing`](crate::World::predict_landing)
/// cuts a path into; longer flights get longer chords (each bulging by
/// `|a| Δt² / 8`, `a` the largest acceleration on the path).
pub const LANDING_MAX_CHORDS: usize = 2048;

/// A hit chord is halved, keeping the first half that still hits, until it
/// bulges off the path by less than this, m.
pub const LANDING_FINE_SAGITTA: f64 = 1e-6;

/// Below this `|k t|` the drag factors are summed as series.
const SERIES_SWITCH: f64 = 0.25;
/// Terms of the series (the next one is below 1e-20 at the switch).
const SERIES_TERMS: u32 = 13;

/// `Σ_{n<SERIES_TERMS} (−x)ⁿ / (n + offset)!`.
fn series(x: f64, offset: u32) -> f64 {
    let mut term = 1.0;
    for m in 2..=offset {
        term /= f64::from(m);
    }
    let mut sum = 0.0;
    for n in 0..SERIES_TERMS {
        sum += term;
        term *= -x / f64::from(n + 1 + offset);
    }
    sum
}

/// `(1 − e^(−x)) / x`, 1 at `x = 0`.
fn phi1(x: f64) -> f64 {
    if x.abs() < SERIES_SWITCH {
        series(x, 1)
    } else {
        -(-x).exp_m1() / x
    }
}

/// `(x − 1 + e^(−x)) / x²`, ½ at `x = 0`.
fn phi2(x: f64) -> f64 {
    if x.abs() < SERIES_SWITCH {
        series(x, 2)
    } else {
        (x + (-x).exp_m1()) / (x * x)
    }
}

/// The closed-form path of a point under uniform gravity and linear drag
/// (see the module note).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Trajectory {
    origin: DVec3,
    velocity: DVec3,
    gravity: DVec3,
    drag: f64,
}

/// The highest point of a path, against gravity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Apex {
    /// When the path peaks, s after its start (>= 0).
    pub time: f64,
    /// Where, m.
    pub point: DVec3,
}

/// Where a body's swept path first meets another body (see
/// [`World::predict_landing`](crate::World::predict_landing)).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Landing {
    /// Time of impact, s from now.
    pub time: f64,
    /// The contact point on the body that was hit, m, world (the centre of
    /// the touching points when a face lands flat).
    pub point: DVec3,
    /// Unit surface normal of the body that was hit at `point`, pointing
    /// out of it (towards the arriving body).
    pub normal: DVec3,
    /// The arriving body's centre of mass at impact, m, world.
    pub center_of_mass: DVec3,
    /// The arriving body's velocity at impact, m/s.
    pub velocity: DVec3,
    /// The body that was hit.
    pub body: BodyHandle,
}

impl Trajectory {
    /// The path from `origin` (m) at `velocity` (m/s) under `gravity`
    /// (m/s²) with linear drag rate `drag` (1/s; 0 for none).
    ///
    /// ```
    /// use inertia_physics::glam::DVec3;
    /// use inertia_physics::rigid::ballistic::Trajectory;
    ///
    /// let g = DVec3::new(0.0, -10.0, 0.0);
    /// let path = Trajectory::new(DVec3::ZERO, DVec3::new(3.0, 4.0, 0.0), g, 0.0).unwrap();
    /// assert!(path.position(0.8).distance(DVec3::new(2.4, 0.0, 0.0)) < 1e-15);
    /// let apex = path.apex().unwrap();
    /// assert!((apex.time - 0.4).abs() < 1e-15 && (apex.point.y - 0.8).abs() < 1e-15);
    /// ```
    ///
    /// # Errors
    /// [`PhysicsError::NonFinite`] for a non-finite vector or drag,
    /// [`PhysicsError::Negative`] for `drag < 0`.
    pub fn new(
        origin: DVec3,
        velocity: DVec3,
        gravity: DVec3,
        drag: f64,
    ) -> Result<Self, PhysicsError> {
        Ok(Self {
            origin: finite3("trajectory origin", origin)?,
            velocity: finite3("trajectory velocity", velocity)?,
            gravity: finite3("trajectory gravity", gravity)?,
            drag: non_negative("trajectory drag", drag)?,
        })
    }

    /// The start point, m.
    pub fn origin(&self) -> DVec3 {
        self.origin
    }

    /// The velocity at the start, m/s.
    pub fn initial_velocity(&self) -> DVec3 {
        self.velocity
    }

    /// Gravity, m/s².
    pub fn gravity(&self) -> DVec3 {
        self.gravity
    }

    /// Linear drag rate, 1/s.
    pub fn drag(&self) -> f64 {
        self.drag
    }

    /// Position `t` seconds after the start, m (`t < 0` runs the path
    /// backwards).
    pub fn position(&self, t: f64) -> DVec3 {
        let x = self.drag * t;
        self.origin + self.velocity * (t * phi1(x)) + self.gravity * (t * t * phi2(x))
    }

    /// Velocity `t` seconds after the start, m/s.
    pub fn velocity(&self, t: f64) -> DVec3 {
        let x = self.drag * t;
        self.velocity * (-x).exp() + self.gravity * (t * phi1(x))
    }

    /// Acceleration `t` seconds after the start, m/s²: `g − k v(t)`.
    pub fn acceleration(&self, t: f64) -> DVec3 {
        (self.gravity - self.velocity * self.drag) * (-self.drag * t).exp()
    }

    /// The largest `|acceleration|` over `t >= 0`, m/s² (at the start: drag
    /// only lets it decay).
    pub fn max_acceleration(&self) -> f64 {
        self.acceleration(0.0).length()
    }

    /// The top of the arc: the time (>= 0) and point where the velocity
    /// stops rising against gravity. `None` without gravity or when the
    /// path already falls at the start (it is then highest at its start).
    pub fn apex(&self) -> Option<Apex> {
        let g = self.gravity.length();
        if g == 0.0 {
            return None;
        }
        let rise = -self.velocity.dot(self.gravity) / g;
        if rise < 0.0 {
            return None;
        }
        let time = if self.drag == 0.0 {
            rise / g
        } else {
            (self.drag * rise / g).ln_1p() / self.drag
        };
        Some(Apex {
            time,
            point: self.position(time),
        })
    }
}

/// `(a, b) = (|g||d| − d·g, |g||d| + d·g)`, each >= 0, `a b = |d × g|²`,
/// the smaller computed as that quotient so it does not cancel.
fn reach_terms(d: DVec3, g: DVec3) -> (f64, f64) {
    let gd = g.length() * d.length();
    let dot = d.dot(g);
    let cross = d.cross(g).length_squared();
    let quotient = |big: f64| if big > 0.0 { cross / big } else { 0.0 };
    if dot <= 0.0 {
        let a = gd - dot;
        (a, quotient(a))
    } else {
        let b = gd + dot;
        (quotient(b), b)
    }
}

/// The low and high arcs as (velocity, time of flight).
type Arcs = [(DVec3, f64); 2];

fn arcs(from: DVec3, to: DVec3, speed: f64, gravity: DVec3) -> Result<Option<Arcs>, PhysicsError> {
    finite3("launch point", from)?;
    finite3("launch target", to)?;
    finite3("gravity", gravity)?;
    positive("launch speed", speed)?;
    let d = to - from;
    let dist = finite("launch distance", d.length())?;
    if dist == 0.0 {
        return Err(PhysicsError::Invalid {
            what: "launch target",
            why: "coincides with the launch point".into(),
        });
    }
    let g = gravity.length();
    let v2 = speed * speed;
    let (low, high) = if g == 0.0 {
        (dist / speed, dist / speed)
    } else {
        let (a, b) = reach_terms(d, gravity);
        if v2 < a {
            return Ok(None);
        }
        let sum = (v2 - a).sqrt() + (v2 + b).sqrt();
        (2.0 * dist / sum, sum / g)
    };
    let velocity = |t: f64| d / t - gravity * (0.5 * t);
    let out = [(velocity(low), low), (velocity(high), high)];
    for (v, t) in out {
        finite3("launch velocity", v)?;
        finite("time of flight", t)?;
    }
    Ok(Some(out))
}

/// The launch velocities (m/s) of length `speed` (m/s) that carry a point
/// from `from` to `to` (m) under `gravity` (m/s², any direction) without
/// drag: `[low, high]`, the flatter arc first. `None` when `to` is out of
/// reach at that speed (see [`min_speed_to_reach`]). A target straight
/// above gives two vertical shots (reaching it rising, then falling), one
/// straight below a shot down and one up and back. Without gravity both
/// are the straight shot.
///
/// ```
/// use inertia_physics::glam::DVec3;
/// use inertia_physics::rigid::ballistic::{launch_velocities, time_of_flight, Trajectory};
///
/// let g = DVec3::new(0.0, -9.81, 0.0);
/// let to = DVec3::new(10.0, 2.0, 0.0);
/// let [low, high] = launch_velocities(DVec3::ZERO, to, 15.0, g).unwrap().unwrap();
/// let [t_low, t_high] = time_of_flight(DVec3::ZERO, to, 15.0, g).unwrap().unwrap();
/// assert!(low.y < high.y && t_low < t_high);
/// for (v, t) in [(low, t_low), (high, t_high)] {
///     assert!((v.length() - 15.0).abs() < 1e-12);
///     let hit = Trajectory::new(DVec3::ZERO, v, g, 0.0).unwrap().position(t);
///     assert!(hit.distance(to) < 1e-12);
/// }
/// ```
///
/// # Errors
/// [`PhysicsError::NonFinite`] for non-finite input (or a result that
/// overflows), [`PhysicsError::NotPositive`] for `speed <= 0`,
/// [`PhysicsError::Invalid`] when `to == from`.
pub fn launch_velocities(
    from: DVec3,
    to: DVec3,
    speed: f64,
    gravity: DVec3,
) -> Result<Option<[DVec3; 2]>, PhysicsError> {
    Ok(arcs(from, to, speed, gravity)?.map(|[l, h]| [l.0, h.0]))
}

/// The flight times (s) of the two arcs of [`launch_velocities`], in the
/// same order (`[low, high]`); `None` when out of reach.
///
/// # Errors
/// As [`launch_velocities`].
pub fn time_of_flight(
    from: DVec3,
    to: DVec3,
    speed: f64,
    gravity: DVec3,
) -> Result<Option<[f64; 2]>, PhysicsError> {
    Ok(arcs(from, to, speed, gravity)?.map(|[l, h]| [l.1, h.1]))
}

/// The least launch speed (m/s) that reaches `to` from `from` (m) under
/// `gravity` (m/s²) without drag: `√(|g| (|d| + h))`, `h` the height of
/// the target against gravity. At that speed both arcs merge; 0 without
/// gravity, for a target straight below or for `to == from`.
///
/// # Errors
/// [`PhysicsError::NonFinite`] for non-finite input.
pub fn min_speed_to_reach(from: DVec3, to: DVec3, gravity: DVec3) -> Result<f64, PhysicsError> {
    finite3("launch point", from)?;
    finite3("launch target", to)?;
    finite3("gravity", gravity)?;
    let (a, _) = reach_terms(to - from, gravity);
    finite("least launch speed", a.sqrt())
}

/// The launch velocity (m/s) that carries a point from `from` to `to` (m)
/// under `gravity` (m/s²), without drag, in exactly `time` seconds:
/// `(to − from) / t − ½ g t`.
///
/// # Errors
/// [`PhysicsError::NonFinite`] for non-finite input,
/// [`PhysicsError::NotPositive`] for `time <= 0`.
pub fn launch_velocity_for_time(
    from: DVec3,
    to: DVec3,
    time: f64,
    gravity: DVec3,
) -> Result<DVec3, PhysicsError> {
    finite3("launch point", from)?;
    finite3("launch target", to)?;
    finite3("gravity", gravity)?;
    positive("flight time", time)?;
    finite3(
        "launch velocity",
        (to - from) / time - gravity * (0.5 * time),
    )
}
