//! The range of every physical quantity a rigid body may be given.
//!
//! `f64` reaches 1.8 × 10³⁰⁸, but the solver does not work with single
//! quantities: an effective mass is `1 / (1/m₁ + 1/m₂ + (r × n)·I⁻¹(r × n))`,
//! an impulse is a mass times a speed, an energy a mass times a speed
//! squared, an inertia a mass times a length squared. A body of 10³⁰⁸ kg
//! passes a "finite and positive" check and then overflows to infinity in
//! its inertia, and `∞ × 0` is NaN in the first contact it touches. Bounds
//! on each input keep every such product (at most about five factors) many
//! orders of magnitude inside `f64`, and far inside what a game needs:
//!
//! | quantity | range | why that range |
//! |---|---|---|
//! | mass | 10⁻⁶ kg (a milligram) ..= 10⁹ kg (a million tonnes, a supertanker) | a mass ratio of 10¹⁵ between two touching bodies is already far past what any iterative solver resolves |
//! | density | 10⁻³ ..= 10⁵ kg/m³ | lighter than air to five times osmium |
//! | length | 10⁻⁴ m (0.1 mm) ..= 10⁵ m (100 km): radii, half extents, half heights | below, contact slop dominates; above, positions lose millimetre precision |
//! | coordinate | \|x\| ≤ 10⁷ m | hull and mesh vertices, positions: `f64` keeps 2 nm there |
//! | speed | ≤ 10⁵ m/s (about 300 × the speed of sound) | a rifle bullet is 10³ m/s |
//! | angular speed | ≤ 10⁴ rad/s (1 600 turns a second) | a drill is 10² rad/s |
//!
//! These are checked once, where a body is made ([`RigidBodyDesc`]
//! building, so scene files, operator spawns and game rules all go through
//! the same check) and where a shape is made (sizes). The server's scene
//! loader and admin channel report the same errors with their own context.
//! Particles are not bounded here: their systems (orbits, fluids) have
//! their own scales, checked by their builders.
//!
//! [`RigidBodyDesc`]: crate::rigid::body::RigidBodyDesc

use glam::DVec3;

use crate::error::PhysicsError;

/// Least mass of a dynamic body, kg.
pub const MIN_MASS: f64 = 1e-6;
/// Greatest mass of a dynamic body, kg.
pub const MAX_MASS: f64 = 1e9;
/// Least density of a dynamic body's material, kg/m³.
pub const MIN_DENSITY: f64 = 1e-3;
/// Greatest density of a dynamic body's material, kg/m³.
pub const MAX_DENSITY: f64 = 1e5;
/// Least size of a shape (radius, half extent, half height), m.
pub const MIN_LENGTH: f64 = 1e-4;
/// Greatest size of a shape (radius, half extent, half height), m.
pub const MAX_LENGTH: f64 = 1e5;
/// Greatest absolute coordinate of a position or vertex, m.
pub const MAX_COORDINATE: f64 = 1e7;
/// Greatest speed of a body, m/s.
pub const MAX_SPEED: f64 = 1e5;
/// Greatest angular speed of a body, rad/s.
pub const MAX_ANGULAR_SPEED: f64 = 1e4;
/// Least principal moment of inertia, kg·m² (a milligram 0.1 mm ball has
/// 4 × 10⁻¹⁵).
pub const MIN_INERTIA: f64 = 1e-16;
/// Greatest principal moment of inertia, kg·m² (the heaviest, longest
/// rod has about 10¹⁹).
pub const MAX_INERTIA: f64 = 1e20;

/// Greatest tick count a world may be saved or restored at: 2⁴⁸, almost
/// nine thousand years at 1000 ticks a second. A saved state past it is
/// refused as malformed, so stepping never overflows the count.
pub const MAX_TICK: u64 = 1 << 48;
/// Greatest simulation time a world may be saved or restored at, s (about
/// 31 700 years): past it, adding a tick's length no longer changes the
/// time in f64.
pub const MAX_TIME: f64 = 1e12;

/// Checks that `value` is finite and within `min..=max`.
pub fn in_range(what: &'static str, value: f64, min: f64, max: f64) -> Result<f64, PhysicsError> {
    if value.is_finite() && (min..=max).contains(&value) {
        Ok(value)
    } else {
        Err(PhysicsError::OutOfRange {
            what,
            value,
            min,
            max,
        })
    }
}

/// Checks a dynamic body's mass, kg.
pub fn mass(value: f64) -> Result<f64, PhysicsError> {
    in_range("body mass (kg)", value, MIN_MASS, MAX_MASS)
}

/// Checks a material density, kg/m³.
pub fn density(value: f64) -> Result<f64, PhysicsError> {
    in_range("density (kg/m³)", value, MIN_DENSITY, MAX_DENSITY)
}

/// Checks a shape's size (radius, half extent, half height), m.
pub fn length(what: &'static str, value: f64) -> Result<f64, PhysicsError> {
    in_range(what, value, MIN_LENGTH, MAX_LENGTH)
}

/// Checks that every coordinate of a position or vertex is within
/// ±[`MAX_COORDINATE`], m.
pub fn position(what: &'static str, p: DVec3) -> Result<DVec3, PhysicsError> {
    for c in p.to_array() {
        in_range(what, c, -MAX_COORDINATE, MAX_COORDINATE)?;
    }
    Ok(p)
}

/// Checks a linear velocity's magnitude, m/s.
pub fn velocity(v: DVec3) -> Result<DVec3, PhysicsError> {
    magnitude("body speed (m/s)", v, MAX_SPEED)
}

/// Checks an angular velocity's magnitude, rad/s.
pub fn angular_velocity(w: DVec3) -> Result<DVec3, PhysicsError> {
    magnitude("body angular speed (rad/s)", w, MAX_ANGULAR_SPEED)
}

/// Checks a principal moment of inertia, kg·m².
pub fn inertia(value: f64) -> Result<f64, PhysicsError> {
    in_range(
        "principal moment of inertia (kg·m²)",
        value,
        MIN_INERTIA,
        MAX_INERTIA,
    )
}

fn magnitude(what: &'static str, v: DVec3, max: f64) -> Result<DVec3, PhysicsError> {
    let len = v.length();
    if v.is_finite() && len <= max {
        Ok(v)
    } else {
        Err(PhysicsError::OutOfRange {
            what,
            value: if v.is_finite() { len } else { f64::NAN },
            min: 0.0,
            max,
        })
    }
}

/// `x` clamped to `-limit..=limit` without `f64::clamp`'s panic on a NaN
/// or negative bound: a solver row whose bound went non-finite passes its
/// value through, and the body it drives is quarantined at the end of the
/// step instead of stopping the process.
pub(crate) fn clamp_magnitude(x: f64, limit: f64) -> f64 {
    x.max(-limit).min(limit)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_refuse_what_overflows_and_keep_what_games_use() {
        assert!(mass(1e308).is_err());
        assert!(mass(2e307).is_err());
        assert!(mass(f64::NAN).is_err());
        assert!(mass(0.0).is_err());
        assert_eq!(mass(75.0), Ok(75.0));
        assert_eq!(mass(MAX_MASS), Ok(MAX_MASS));
        assert!(length("radius", 1e-300).is_err());
        assert!(length("radius", 0.5).is_ok());
        assert!(velocity(DVec3::new(1e6, 0.0, 0.0)).is_err());
        assert!(velocity(DVec3::new(f64::INFINITY, 0.0, 0.0)).is_err());
        assert!(velocity(DVec3::new(900.0, 0.0, 0.0)).is_ok());
        assert!(angular_velocity(DVec3::splat(1e5)).is_err());
        assert!(position("p", DVec3::new(0.0, -1e8, 0.0)).is_err());
        // The extreme products stay far inside f64.
        let p = MAX_MASS * MAX_SPEED * MAX_SPEED * MAX_LENGTH * MAX_LENGTH;
        assert!(p < 1e40, "{p}");
        let q = MIN_MASS * MIN_LENGTH * MIN_LENGTH;
        assert!(q > 1e-300);
    }

    #[test]
    fn clamp_magnitude_never_panics() {
        assert_eq!(clamp_magnitude(5.0, 2.0), 2.0);
        assert_eq!(clamp_magnitude(-5.0, 2.0), -2.0);
        assert_eq!(clamp_magnitude(1.0, f64::NAN), 1.0);
        // f64::clamp panics on both of these.
        assert_eq!(clamp_magnitude(1.0, -3.0), -3.0);
        assert_eq!(clamp_magnitude(0.5, f64::INFINITY), 0.5);
    }
}
