//! The Inertia client SDK.

pub mod clock;
pub mod entities;
pub mod interp;
pub mod stats;
