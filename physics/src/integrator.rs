//! Numerical integrators: how one step of `dt` seconds advances position and
//! velocity from the acceleration `a(x, v, t)`.
//!
//! | method | order | force evaluations / step | energy behaviour |
//! |---|---|---|---|
//! | [`ForwardEuler`](Integrator::ForwardEuler) | 1 | 1 | grows: an undamped oscillator swings ever wider |
//! | [`SymplecticEuler`](Integrator::SymplecticEuler) | 1 | 1 | bounded: oscillates around the true value, no drift |
//! | [`Leapfrog`](Integrator::Leapfrog) | 2 | 2 | bounded, time-reversible (kick-drift-kick) |
//! | [`Verlet`](Integrator::Verlet) | 2 | 2 | bounded, time-reversible (position Störmer–Verlet) |
//! | [`Rk4`](Integrator::Rk4) | 4 | 4 | very accurate per step but drifts slowly: not symplectic |
//!
//! "Order" is the global error: halving `dt` divides the error after a fixed
//! simulated time by about `2^order`. The symplectic methods (symplectic
//! Euler, leapfrog, Verlet) conserve a modified energy exactly, so their
//! energy error stays bounded over millions of steps: that is why games use
//! them. Forward Euler is kept because it is the textbook baseline and
//! reproduces the classic lecture tables exactly; RK4 is the accuracy
//! reference for tests and offline work.
//!
//! The equations, for `a_n = a(x_n, v_n, t_n)`:
//!
//! * Forward Euler: `x' = x + v dt`, `v' = v + a dt`.
//! * Symplectic (semi-implicit) Euler: `v' = v + a dt`, `x' = x + v' dt`.
//! * Leapfrog, kick-drift-kick: `v½ = v + a dt/2`, `x' = x + v½ dt`,
//!   `v' = v½ + a(x', v½) dt/2`. Velocity-dependent forces see `v½`.
//! * Verlet (Störmer): `x' = 2x - x_prev + a dt²`; the previous position is
//!   part of the state. It is primed from the velocity as
//!   `x_prev = x - v dt + ½ a dt²`, and re-primed if `dt` changes. The reported velocity is
//!   `(x' - x)/dt + ½ a(x') dt`, which needs a second force evaluation at
//!   the new positions: without it (using `a(x)` instead) the velocity, and
//!   so the energy, is off by `½ ȧ dt²`, several times the error of the
//!   positions.
//! * Classic fourth-order Runge–Kutta on the first-order system `(x, v)`.

/// The integration method of a particle system.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Hash)]
pub enum Integrator {
    /// First order, explicit; energy grows. The textbook baseline.
    ForwardEuler,
    /// First order, symplectic: velocity first, then position with the new velocity.
    #[default]
    SymplecticEuler,
    /// Second order, symplectic kick-drift-kick (velocity Verlet).
    Leapfrog,
    /// Second order, symplectic position Störmer–Verlet with stored previous positions.
    Verlet,
    /// Fourth order Runge–Kutta; the accuracy reference.
    Rk4,
}

impl Integrator {
    /// All methods, in the order above.
    pub const ALL: [Integrator; 5] = [
        Integrator::ForwardEuler,
        Integrator::SymplecticEuler,
        Integrator::Leapfrog,
        Integrator::Verlet,
        Integrator::Rk4,
    ];

    /// The global order of accuracy.
    pub fn order(self) -> u32 {
        match self {
            Integrator::ForwardEuler | Integrator::SymplecticEuler => 1,
            Integrator::Leapfrog | Integrator::Verlet => 2,
            Integrator::Rk4 => 4,
        }
    }

    /// A short stable name ("forward_euler", ...), used in reports and benches.
    pub fn name(self) -> &'static str {
        match self {
            Integrator::ForwardEuler => "forward_euler",
            Integrator::SymplecticEuler => "symplectic_euler",
            Integrator::Leapfrog => "leapfrog",
            Integrator::Verlet => "verlet",
            Integrator::Rk4 => "rk4",
        }
    }

    pub(crate) fn code(self) -> u8 {
        match self {
            Integrator::ForwardEuler => 0,
            Integrator::SymplecticEuler => 1,
            Integrator::Leapfrog => 2,
            Integrator::Verlet => 3,
            Integrator::Rk4 => 4,
        }
    }

    pub(crate) fn from_code(c: u8) -> Option<Self> {
        Self::ALL.get(c as usize).copied()
    }
}
