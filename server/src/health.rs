//! Whether the server is alive and ready, as `/healthz` and `/readyz` (and
//! so an orchestrator) see it.
//!
//! Liveness is not "the process runs": a server whose tick thread has
//! stopped still answers HTTP, but its world is frozen and nobody can
//! join. [`Health::fail`] marks that, for good: both endpoints answer 503
//! with the reason from then on, and the process goes on to exit non-zero
//! so the orchestrator restarts it (`--resume` carries on from the
//! recording).

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Mutex;

/// Readiness and failure, shared by the server and the health endpoints.
#[derive(Debug, Default)]
pub struct Health {
    ready: AtomicBool,
    failure: Mutex<Option<String>>,
}

impl Health {
    /// Not ready, not failed.
    pub fn new() -> Health {
        Health::default()
    }

    /// Sets readiness (scene built and port bound: true; draining: false).
    pub fn set_ready(&self, ready: bool) {
        self.ready.store(ready, Ordering::Release);
    }

    /// Whether new clients should be sent here: ready and not failed.
    pub fn is_ready(&self) -> bool {
        self.ready.load(Ordering::Acquire) && self.failure().is_none()
    }

    /// Marks the server failed (the first reason given is kept).
    pub fn fail(&self, reason: impl Into<String>) {
        self.set_ready(false);
        let mut f = self.failure.lock().unwrap_or_else(|p| p.into_inner());
        f.get_or_insert_with(|| reason.into());
    }

    /// Why the server failed, once it has.
    pub fn failure(&self) -> Option<String> {
        self.failure
            .lock()
            .unwrap_or_else(|p| p.into_inner())
            .clone()
    }
}
