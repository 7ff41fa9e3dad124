//! The snapshot stage: one task codes the snapshots of every client, on
//! published frames, in the server's snapshot slots.
//!
//! A slot opens every `1 / snapshot_hz` s of wall time. It is served on
//! the first frame the tick thread publishes after it opens, so snapshots
//! are aligned with ticks and every client of a slot is served the same
//! frame: quantized once ([`Frame::quantized`]), with each entity's delta
//! coded once per baseline state and shared by every client that needs it
//! ([`SharedDeltas`]). While no frame comes (the clock is paused), a slot
//! is served from the latest frame half a period after it opened, so
//! deferred entities still arrive and clients keep acknowledging.
//!
//! The stage has its own thread ([`spawn`]), at a lower scheduling
//! priority than the tick thread and the network ([`crate::priority`]),
//! so that on a machine short of cores the encoders wait for the tick,
//! never the tick for the encoders.
//!
//! Each client's [`ServerSession`] sits behind a lock it shares with its
//! connection task, which feeds it the client's datagrams (acks and
//! inputs); the stage holds one client's lock at a time, for one encode.
//! Datagrams go out through quinn's `send_datagram`, which only queues.
//!
//! When serving a slot takes too much of the period, or the tick nears its
//! budget, the stage lowers some clients' rates by the policy of
//! [`super::governor`], and counts it in `/metrics`.
//!
//! [`Frame::quantized`]: crate::sim::Frame::quantized

use std::collections::BTreeMap;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use inertia_protocol::snapshot::SharedDeltas;
use inertia_protocol::ServerSession;

use super::governor::{degrade_rank, rate_for, Candidate, Decision, RateGovernor};
use super::NetShared;

/// One connected client as the stage serves it.
#[derive(Debug)]
pub struct Served {
    /// Its connection, for `send_datagram` and the path's datagram size.
    pub connection: quinn::Connection,
    /// Its session (encoder, priorities, inputs), shared with its
    /// connection task.
    pub session: Mutex<ServerSession>,
}

/// The clients the stage serves, by connection number.
#[derive(Debug, Default)]
pub struct ServedClients {
    clients: Mutex<BTreeMap<u64, Arc<Served>>>,
}

impl ServedClients {
    /// Serves `served` as connection `id` until the returned guard drops.
    pub fn add(self: &Arc<Self>, id: u64, served: Arc<Served>) -> ServedGuard {
        if let Ok(mut c) = self.clients.lock() {
            c.insert(id, served);
        }
        ServedGuard {
            clients: self.clone(),
            id,
        }
    }

    /// Puts every client served now into `out` (emptied first), with its
    /// connection number, in connection order.
    fn snapshot_into(&self, out: &mut Vec<(u64, Arc<Served>)>) {
        out.clear();
        if let Ok(c) = self.clients.lock() {
            out.extend(c.iter().map(|(&id, s)| (id, s.clone())));
        }
    }
}

/// Stops serving a client when dropped.
#[derive(Debug)]
pub struct ServedGuard {
    clients: Arc<ServedClients>,
    id: u64,
}

impl Drop for ServedGuard {
    fn drop(&mut self) {
        if let Ok(mut c) = self.clients.clients.lock() {
            c.remove(&self.id);
        }
    }
}

/// Starts the stage on its own thread, named `inertia-snapshots`, with its
/// own single-threaded runtime, at the process's priority (see
/// [`crate::priority`]); it ends when [`run`] does.
pub fn spawn(shared: Arc<NetShared>) -> std::io::Result<std::thread::JoinHandle<()>> {
    std::thread::Builder::new()
        .name("inertia-snapshots".into())
        .spawn(move || {
            match tokio::runtime::Builder::new_current_thread()
                .enable_time()
                .build()
            {
                Ok(runtime) => runtime.block_on(run(shared)),
                Err(e) => tracing::error!(error = %e, "the snapshot stage could not start"),
            }
        })
}

/// Runs the stage until shutdown or until the simulation is gone.
pub async fn run(shared: Arc<NetShared>) {
    let mut frames = shared.sim.subscribe();
    let mut shutdown = shared.shutdown.clone();
    let period = Duration::from_secs_f64(1.0 / f64::from(shared.snapshot_hz.max(1)));
    let mut opens = tokio::time::Instant::now();
    let mut slot: u64 = 0;
    let mut deltas = SharedDeltas::new();
    let mut clients = Vec::new();
    let mut governor = RateGovernor::new(shared.snapshot_hz, shared.tick_hz);
    let mut handed_out = RatesHandedOut::default();
    loop {
        tokio::select! {
            changed = frames.changed() => if changed.is_err() { return },
            _ = tokio::time::sleep_until(opens + period / 2) => {}
            _ = shutdown.changed() => return,
        }
        // Marks the frame seen whichever branch woke the stage.
        let frame = frames.borrow_and_update().clone();
        let now = tokio::time::Instant::now();
        if now < opens {
            continue;
        }
        shared.served.snapshot_into(&mut clients);
        if !clients.is_empty() {
            let serving = Instant::now();
            let degraded = governor.degraded();
            if handed_out.stale(degraded, &clients) {
                set_rates(&clients, degraded);
                handed_out.record(degraded, &clients);
            }
            let quantized = frame.quantized(&shared.snapshot);
            for (_, served) in &clients {
                let max = served.connection.max_datagram_size().unwrap_or(1200);
                let started = Instant::now();
                let bytes = match served.session.lock() {
                    Ok(mut session) => session.poll_snapshot(quantized, &mut deltas, slot, max),
                    Err(_) => None,
                };
                let Some(bytes) = bytes else { continue };
                shared
                    .metrics
                    .snapshot_encode
                    .observe(started.elapsed().as_secs_f64());
                let len = bytes.len();
                if served.connection.send_datagram(bytes.into()).is_ok() {
                    shared.metrics.bytes_sent.inc_by(len as u64);
                    shared.metrics.packets_sent.inc();
                    shared.metrics.snapshot_size.observe(len as f64);
                }
            }
            let decision =
                governor.after_slot(serving.elapsed(), frame.tick_duration, clients.len());
            let direction = match decision {
                Decision::Hold => None,
                Decision::Degrade => Some("degrade"),
                Decision::Restore => Some("restore"),
            };
            if let Some(direction) = direction {
                shared
                    .metrics
                    .snapshot_rate_steps
                    .get_or_create(&[("direction", direction)])
                    .inc();
                tracing::debug!(
                    direction,
                    degraded = governor.degraded(),
                    clients = clients.len(),
                    "snapshot rates"
                );
            }
            shared
                .metrics
                .snapshot_clients_degraded
                .set(governor.degraded() as i64);
            clients.clear();
        }
        slot += 1;
        opens += period;
        // Slots missed while the stage was behind are skipped, not run in
        // a burst.
        if opens <= now {
            opens = now + period;
        }
    }
}

/// Gives the first `degraded` clients by [`degrade_rank`] the lower rate
/// and every other client its full rate.
/// The rates as last handed out: how many clients at the lower rate,
/// among which connections. New clients start at full rate, so while
/// none is lowered there is nothing to hand out.
#[derive(Debug, Default)]
struct RatesHandedOut {
    degraded: usize,
    connections: Vec<u64>,
}

impl RatesHandedOut {
    /// Whether `degraded` lowered among `clients` needs handing out again.
    fn stale(&self, degraded: usize, clients: &[(u64, Arc<Served>)]) -> bool {
        (degraded > 0 || self.degraded > 0)
            && (degraded != self.degraded
                || !clients.iter().map(|(id, _)| id).eq(&self.connections))
    }

    fn record(&mut self, degraded: usize, clients: &[(u64, Arc<Served>)]) {
        self.degraded = degraded;
        self.connections.clear();
        self.connections.extend(clients.iter().map(|(id, _)| *id));
    }
}

fn set_rates(clients: &[(u64, Arc<Served>)], degraded: usize) {
    let mut order: Vec<(Candidate, &Served)> = clients
        .iter()
        .map(|(id, served)| {
            let plays = served
                .session
                .lock()
                .is_ok_and(|session| session.avatar().is_some());
            let candidate = Candidate {
                connection: *id,
                plays,
            };
            (candidate, served.as_ref())
        })
        .collect();
    order.sort_unstable_by_key(|(c, _)| degrade_rank(c));
    for (rank, (_, served)) in order.iter().enumerate() {
        let (divisor, phase) = rate_for(rank, degraded);
        if let Ok(mut session) = served.session.lock() {
            session.set_rate_divisor(divisor, phase);
        }
    }
}
