//! The Inertia client SDK.

pub mod clock;
pub mod interp;
