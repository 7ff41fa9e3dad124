//! Joining a dev-mode server: read `<data-dir>/dev-credentials.json`,
//! which the server writes when it runs without a configured key, and mint
//! a connect token from it. A real game gets its tokens from its own
//! backend, which holds the server key; only dev tools may read the file.

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::time::{SystemTime, UNIX_EPOCH};

use inertia_protocol::credentials::DevCredentials;
use inertia_protocol::token::ConnectToken;

pub use inertia_protocol::credentials::DEV_CREDENTIALS_PATH;

/// The options a dev tool joins with (`watch`, the viewer): flatten them
/// into its own clap arguments.
#[derive(Debug, Clone, clap::Args)]
pub struct DevArgs {
    /// Where to connect (default: the address in the credentials file).
    #[arg(long)]
    pub server: Option<SocketAddr>,
    /// The dev credentials file a dev-mode server writes.
    #[arg(long, default_value = DEV_CREDENTIALS_PATH)]
    pub credentials: PathBuf,
}

/// How long a dev token stays valid, s.
pub const DEV_TOKEN_TTL: u64 = 3600;

/// Why dev credentials could not be used.
#[derive(Debug, thiserror::Error)]
pub enum DevError {
    /// The file could not be read.
    #[error("{path}: {source} (is a dev-mode server running from this directory?)")]
    Read {
        /// The file.
        path: PathBuf,
        /// The cause.
        source: std::io::Error,
    },
    /// The file is not valid.
    #[error("{path}: {why}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        why: String,
    },
}

/// The server's address and a fresh token for `client_id` (random when
/// `None`), from the dev credentials file at `path`.
pub fn dev_token(
    path: &Path,
    client_id: Option<u64>,
) -> Result<(SocketAddr, ConnectToken, DevCredentials), DevError> {
    let invalid = |why: String| DevError::Invalid {
        path: path.to_path_buf(),
        why,
    };
    let bytes = std::fs::read(path).map_err(|source| DevError::Read {
        path: path.to_path_buf(),
        source,
    })?;
    let creds: DevCredentials =
        serde_json::from_slice(&bytes).map_err(|e| invalid(e.to_string()))?;
    let addr: SocketAddr = creds
        .server_addr
        .parse()
        .map_err(|e| invalid(format!("server_addr: {e}")))?;
    let now = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    let client_id = client_id.unwrap_or_else(random_client_id);
    let token = creds
        .mint_token(client_id, DEV_TOKEN_TTL, now)
        .map_err(|e| invalid(e.to_string()))?;
    Ok((addr, token, creds))
}

/// A client id from the clock and the process id: distinct enough for dev
/// tools run side by side.
fn random_client_id() -> u64 {
    let nanos = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| d.as_nanos() as u64);
    let mut z = nanos ^ (u64::from(std::process::id()) << 32);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    (z ^ (z >> 31)) >> 1
}
