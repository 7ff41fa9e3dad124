//! Position-based deformables on small steps (XPBD): soft bodies (ropes,
//! cloth, volumetric solids, inflated shells) and fluids (position-based
//! fluids).
//!
//! Both follow Macklin et al., "Small Steps in Physics Simulation" (SCA
//! 2019): a step of `dt` is cut into `n` substeps of `h = dt / n`, and each
//! substep predicts the particles' positions from their velocities and
//! gravity, projects every constraint once (XPBD: a constraint `C` with
//! compliance `α` moves its particles by `Δλ ∇C w` with
//! `Δλ = −C / (Σ w |∇C|² + α / h²)`), keeps the particles out of rigid
//! bodies, and takes the new velocities from the positions
//! (`v = (x − x_prev) / h`). Many short substeps of one iteration converge
//! better than few long steps of many iterations, and a compliance of 0
//! gives an inextensible constraint at any step: ropes do not stretch and
//! cloth does not sag like rubber, where mass-spring systems must soften
//! their springs to stay stable.
//!
//! Positions and velocities are kept in single precision, as the GPU keeps
//! them. Every parallel pass is deterministic: constraints are coloured
//! (`colouring.rs`) so a colour's constraints never share a particle, and
//! fluid particles gather from their neighbours in a fixed order.

pub(crate) mod colouring;
pub(crate) mod coupling;
pub mod fluid;
pub(crate) mod grid;
pub(crate) mod scatter;
pub mod soft;
