//! What prediction must know of the server's game to agree with it.

use glam::DVec3;
use inertia_physics::character::WalkSettings;

/// Settings of client-side prediction. The walking controller, gravity and
/// solver substeps must be the server's, or every snapshot corrects the
/// prediction; the defaults are those of the server's default game
/// (`SandboxRules` with `SandboxSettings::default()` on a scene with
/// default world settings).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PredictionConfig {
    /// The avatar's capsule and walking controller.
    pub walk: WalkSettings,
    /// Gravity, m/s² (default 9.81 down).
    pub gravity: DVec3,
    /// Contact solver substeps per tick (default 4, the scenes' default).
    pub solver_substeps: u32,
    /// Largest impulse the server's rules may give, N·s (default 1000,
    /// its `ControlLimits::max_impulse`).
    pub max_impulse: f64,
    /// Largest velocity change one impulse may cause, m/s (default 12,
    /// its `ControlLimits::max_delta_v`).
    pub max_delta_v: f64,
    /// Entities whose bounds come this close to the avatar are put in the
    /// local world, m (default 10: farther ones cannot touch it within a
    /// round trip at walking speed).
    pub neighbour_radius: f64,
    /// An authoritative state within this distance of the prediction is
    /// taken as agreeing (no rollback), m (default 5 mm: about what
    /// quantization leaves).
    pub tolerance: f64,
    /// An authoritative velocity within this of the prediction's is taken
    /// as agreeing, m/s (default 5 cm/s).
    pub velocity_tolerance: f64,
    /// How quickly a correction fades from view: the time constant of the
    /// visual offset's exponential decay, s (default 0.1: gone to 5 % in
    /// 0.3 s, and a 5 cm correction moves the picture 8 mm a tick at most).
    pub smoothing: f64,
    /// A correction larger than this is a teleport: the picture snaps
    /// instead of sliding across, m (default 2).
    pub snap_distance: f64,
}

impl Default for PredictionConfig {
    fn default() -> Self {
        Self {
            walk: WalkSettings::default(),
            gravity: DVec3::new(0.0, -9.81, 0.0),
            solver_substeps: 4,
            max_impulse: 1_000.0,
            max_delta_v: 12.0,
            neighbour_radius: 10.0,
            tolerance: 0.005,
            velocity_tolerance: 0.05,
            smoothing: 0.1,
            snap_distance: 2.0,
        }
    }
}
