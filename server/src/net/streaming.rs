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
    /// Players' replays of the recent past.
    pub replays: ReplaySettings,
}

/// How much of the recent past the server keeps for players' replays,
/// and how many play at once.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ReplaySettings {
    /// The longest past held, s (0: no replays).
    pub window_s: u32,
    /// The most memory the frames held take, bytes (counted within the
    /// seeking memory, `--seek-memory-mb`).
    pub window_bytes: usize,
    /// Replays playing at once, at most.
    pub max_playing: usize,
}

impl Default for ReplaySettings {
    /// None: no past held, no replay plays.
    fn default() -> Self {
        Self {
            window_s: 0,
            window_bytes: 0,
            max_playing: 0,
        }
    }
}

impl Streaming {
    /// The window the snapshot stage keeps for replays.
    pub fn replay_window(&self) -> crate::net::replays::ReplayWindow {
        crate::net::replays::ReplayWindow::new(
            u64::from(self.replays.window_s) * u64::from(self.tick_hz),
            self.replays.window_bytes,
        )
    }

    /// The desk that plays replays, coding them as live snapshots are.
    pub fn replay_desk(&self) -> crate::net::replays::ReplayDesk {
        crate::net::replays::ReplayDesk::new(
            crate::net::replays::ReplayLimits::new(
                self.replays.max_playing,
                self.tick_hz,
                self.snapshot_hz,
            ),
            self.session_config(),
        )
    }

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
