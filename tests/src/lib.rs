//! Helpers for Inertia's end-to-end tests.
