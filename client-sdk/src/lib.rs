//! The Inertia client SDK.
