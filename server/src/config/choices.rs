//! Settings that pick one of a few ways: how log lines are written, and
//! whether physics workers are pinned to cores.

use serde::Deserialize;

/// How log lines are written.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum LogFormat {
    /// Human-readable lines.
    #[default]
    Text,
    /// One JSON object per line (for log collectors).
    Json,
}

impl std::str::FromStr for LogFormat {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "text" => Ok(LogFormat::Text),
            "json" => Ok(LogFormat::Json),
            _ => Err(format!("expected `text` or `json`, got `{s}`")),
        }
    }
}

/// Whether the physics workers are pinned one to a core
/// ([`inertia_physics::ThreadPinning`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize, clap::ValueEnum)]
#[serde(rename_all = "lowercase")]
pub enum PhysicsPinning {
    /// Where the process may run on no more cores than it has physics
    /// threads (it owns them: dedicated cores, a pod under Kubernetes'
    /// static CPU manager policy).
    #[default]
    Auto,
    /// Never: the OS places the workers.
    Never,
    /// Always, worker `k` to the `k`-th core the process may run on.
    Always,
}

impl std::str::FromStr for PhysicsPinning {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s.to_ascii_lowercase().as_str() {
            "auto" => Ok(PhysicsPinning::Auto),
            "never" => Ok(PhysicsPinning::Never),
            "always" => Ok(PhysicsPinning::Always),
            _ => Err(format!("expected `auto`, `never` or `always`, got `{s}`")),
        }
    }
}

impl From<PhysicsPinning> for inertia_physics::ThreadPinning {
    fn from(p: PhysicsPinning) -> Self {
        match p {
            PhysicsPinning::Auto => Self::Auto,
            PhysicsPinning::Never => Self::Never,
            PhysicsPinning::Always => Self::Always,
        }
    }
}
