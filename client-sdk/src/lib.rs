//! The Inertia client SDK.

pub mod clock;
