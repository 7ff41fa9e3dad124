//! Whether the server is alive and ready, as `/healthz` and `/readyz` (and
//! so an orchestrator) see it.
//!
//! Liveness is not "the process runs": a server whose tick thread has
//! stopped still answers HTTP, but its world is frozen and nobody can
//! join. [`Health::fail`] marks that, for good: both endpoints answer 503
//! with the reason from then on, and [`Health::failed`] wakes whoever
//! waits to exit the process non-zero, so the orchestrator restarts it
//! (`--resume` carries on from the recording).

use std::sync::atomic::{AtomicBool, Ordering};

use tokio::sync::watch;

/// Readiness and failure, shared by the server and the health endpoints.
#[derive(Debug)]
pub struct Health {
    ready: AtomicBool,
    failure: watch::Sender<Option<String>>,
}

impl Default for Health {
    fn default() -> Self {
        Health {
            ready: AtomicBool::new(false),
            failure: watch::Sender::new(None),
        }
    }
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
        self.failure.send_if_modified(|f| {
            if f.is_some() {
                return false;
            }
            *f = Some(reason.into());
            true
        });
    }

    /// Why the server failed, once it has.
    pub fn failure(&self) -> Option<String> {
        self.failure.borrow().clone()
    }

    /// Waits until the server fails and returns why; never returns while
    /// it works.
    pub async fn failed(&self) -> String {
        let mut failure = self.failure.subscribe();
        // The sender lives as long as `self`, so the wait only ends in a
        // failure.
        let why = match failure.wait_for(Option::is_some).await {
            Ok(why) => why.clone(),
            Err(_) => None,
        };
        match why {
            Some(why) => why,
            None => std::future::pending().await,
        }
    }
}
