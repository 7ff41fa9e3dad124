//! Typed errors. Every fallible call says what was wrong and changes nothing
//! when it fails: validation happens before any state is touched.

use crate::handle::{
    BodyForceHandle, BodyHandle, ForceHandle, JointHandle, ParticleHandle, SpringHandle,
    SystemHandle,
};

/// Why a call into the [`World`](crate::World) was refused.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum PhysicsError {
    /// The world already holds [`crate::WorldConfig::max_bodies`] rigid
    /// bodies.
    #[error("the world already holds its limit of {max} rigid bodies")]
    TooManyBodies {
        /// The limit.
        max: usize,
    },
    /// A number that must be finite was NaN or infinite.
    #[error("{what} must be finite, got {value}")]
    NonFinite {
        /// Which input was bad, e.g. "particle position".
        what: &'static str,
        /// The offending value (one component for vectors).
        value: f64,
    },
    /// A mass was zero, negative or not finite. Use `pinned` for immovable particles.
    #[error("mass must be finite and > 0 kg, got {0}")]
    NonPositiveMass(f64),
    /// A quantity that must be strictly positive (time step, stiffness scale, ...) was not.
    #[error("{what} must be > 0, got {value}")]
    NotPositive {
        /// Which input was bad.
        what: &'static str,
        /// The offending value.
        value: f64,
    },
    /// A quantity that must be zero or positive (drag, area, damping, ...) was negative.
    #[error("{what} must be >= 0, got {value}")]
    Negative {
        /// Which input was bad.
        what: &'static str,
        /// The offending value.
        value: f64,
    },
    /// A quantity outside the range the engine keeps finite (see
    /// [`crate::limits`]).
    #[error("{what} must be within {min}..={max}, got {value}")]
    OutOfRange {
        /// Which input was bad.
        what: &'static str,
        /// The offending value (a magnitude for vectors).
        value: f64,
        /// The least allowed.
        min: f64,
        /// The greatest allowed.
        max: f64,
    },
    /// A direction vector had zero (or non-finite) length.
    #[error("{0} must be a non-zero direction")]
    ZeroDirection(&'static str),
    /// A spring with rest length zero, or joining a particle to itself.
    #[error("spring is degenerate: {0}")]
    DegenerateSpring(&'static str),
    /// The opening angle of Barnes–Hut must lie in (0, 2].
    #[error("Barnes-Hut opening angle theta must be in (0, 2], got {0}")]
    BadTheta(f64),
    /// The system handle is stale or was never issued.
    #[error("unknown particle system {0:?}")]
    UnknownSystem(SystemHandle),
    /// The particle handle is stale or was never issued.
    #[error("unknown particle {0:?}")]
    UnknownParticle(ParticleHandle),
    /// The spring handle is stale or was never issued.
    #[error("unknown spring {0:?}")]
    UnknownSpring(SpringHandle),
    /// The body handle is stale or was never issued.
    #[error("unknown rigid body {0:?}")]
    UnknownBody(BodyHandle),
    /// The attachment handle is stale or was never issued.
    #[error("unknown attachment {0:?}")]
    UnknownAttachment(crate::handle::AttachmentHandle),
    /// The soft body handle is stale or was never issued.
    #[error("unknown soft body {0:?}")]
    UnknownSoftBody(crate::handle::SoftBodyHandle),
    /// The fluid handle is stale or was never issued.
    #[error("unknown fluid {0:?}")]
    UnknownFluid(crate::handle::FluidHandle),
    /// The joint handle is stale or was never issued.
    #[error("unknown joint {0:?}")]
    UnknownJoint(JointHandle),
    /// The body force handle is stale or was never issued.
    #[error("unknown body force {0:?}")]
    UnknownBodyForce(BodyForceHandle),
    /// The force handle is stale or was never issued.
    #[error("unknown force {0:?}")]
    UnknownForce(ForceHandle),
    /// Two handles that must be in the same particle system are not.
    #[error("particles {0:?} and {1:?} are in different systems")]
    DifferentSystems(ParticleHandle, ParticleHandle),
    /// A builder argument was out of range (e.g. a cloth with one row).
    #[error("invalid {what}: {why}")]
    Invalid {
        /// Which argument.
        what: &'static str,
        /// What is wrong with it.
        why: String,
    },
    /// A group id above [`MAX_GROUPS`](crate::MAX_GROUPS).
    #[error("group id {0} is out of range (max {max})", max = crate::MAX_GROUPS - 1)]
    GroupOutOfRange(u32),
    /// The thread pool could not be built.
    #[error("could not build the worker thread pool: {0}")]
    ThreadPool(String),
    /// The GPU backend was requested but is unavailable.
    #[error("GPU backend unavailable: {0}")]
    Gpu(String),
}

/// Checks that `v` is finite.
pub(crate) fn finite(what: &'static str, v: f64) -> Result<f64, PhysicsError> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(PhysicsError::NonFinite { what, value: v })
    }
}

/// Checks that every component of `v` is finite.
pub(crate) fn finite3(what: &'static str, v: glam::DVec3) -> Result<glam::DVec3, PhysicsError> {
    for c in v.to_array() {
        finite(what, c)?;
    }
    Ok(v)
}

/// Checks that `v` is finite and >= 0.
pub(crate) fn non_negative(what: &'static str, v: f64) -> Result<f64, PhysicsError> {
    finite(what, v)?;
    if v < 0.0 {
        Err(PhysicsError::Negative { what, value: v })
    } else {
        Ok(v)
    }
}

/// Checks that `v` is finite and > 0.
pub(crate) fn positive(what: &'static str, v: f64) -> Result<f64, PhysicsError> {
    finite(what, v)?;
    if v > 0.0 {
        Ok(v)
    } else {
        Err(PhysicsError::NotPositive { what, value: v })
    }
}

/// Checks that `v` is a finite, non-zero vector and returns it normalised.
pub(crate) fn direction(what: &'static str, v: glam::DVec3) -> Result<glam::DVec3, PhysicsError> {
    finite3(what, v)?;
    let len = v.length();
    if len > 0.0 && len.is_finite() {
        Ok(v / len)
    } else {
        Err(PhysicsError::ZeroDirection(what))
    }
}
