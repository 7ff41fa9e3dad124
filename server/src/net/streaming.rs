//! How the server streams the world to every client: how snapshots are
//! coded, how often, and within what budget.

use std::sync::Arc;

use inertia_protocol::property::PropertySchema;
use inertia_protocol::snapshot::SnapshotConfig;
use inertia_protocol::SessionConfig;

/// The server's snapshot stream, the same for every client.
#[derive(Debug, Clone)]
pub struct Streaming {
    /// How snapshots are coded.
    pub snapshot: SnapshotConfig,
    /// Snapshots per wall second, Hz.
    pub snapshot_hz: u32,
    /// Physics ticks per simulation second, Hz.
    pub tick_hz: u32,
    /// Per-client budget, bytes per second.
    pub budget_bytes_per_sec: u64,
    /// The game's properties, which every snapshot carries.
    pub properties: Arc<PropertySchema>,
}

impl Streaming {
    /// How each client's session codes its snapshots: the server's coding
    /// within its per-client budget, one snapshot's worth.
    pub fn session_config(&self) -> SessionConfig {
        let budget = self.budget_bytes_per_sec / u64::from(self.snapshot_hz.max(1));
        SessionConfig {
            properties: self.properties.clone(),
            ..SessionConfig::new(self.snapshot, budget as usize)
        }
    }
}
