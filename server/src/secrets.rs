//! Reloading the server's secrets while it serves: the connect-token key,
//! the TLS certificate and its key (outside dev mode), read again from
//! their files on SIGHUP or when the files change (Kubernetes updates a
//! mounted Secret by swapping a symbolic link; [`Secrets::watch`] polls).
//!
//! - A new token key becomes current at once; the one it replaces still
//!   opens tokens for [`TOKEN_KEY_GRACE_SECS`](crate::net::token_keys::TOKEN_KEY_GRACE_SECS),
//!   so players holding tokens minted just before the rotation get in.
//! - A new certificate serves every connection from then on (connections
//!   already open keep theirs). Clients pin the certificate named in their
//!   token, so a backend mints with the new fingerprint once it rotates.
//! - Bad files (unreadable, a key that is not 64 hex digits, a certificate
//!   that does not parse or match its key) are refused with the reason,
//!   logged, and nothing changes.
//!
//! The admin token file is reloaded beside them
//! ([`crate::admin::tokens::AdminTokenStore::reload`]).

use std::sync::Arc;
use std::time::Duration;

use inertia_protocol::token::TokenKey;
use tracing::{info, warn};

use crate::credentials::{self, CredentialFiles, CredentialsError};
use crate::net::NetShared;

/// How often [`Secrets::watch`] looks at the files.
pub const WATCH_PERIOD: Duration = Duration::from_secs(2);

/// Why a reload changed nothing.
#[derive(Debug, thiserror::Error)]
pub enum ReloadError {
    /// The files could not be read or did not parse.
    #[error(transparent)]
    Credentials(#[from] CredentialsError),
    /// The certificate and key were refused by TLS.
    #[error("TLS: {0}")]
    Tls(String),
}

/// What a reload changed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct Reloaded {
    /// A new token key is current (the old one in its grace period).
    pub token_key: bool,
    /// A new certificate serves new connections.
    pub certificate: bool,
}

/// The server's secret files and what they feed.
#[derive(Debug)]
pub struct Secrets {
    files: CredentialFiles,
    endpoint: quinn::Endpoint,
    shared: Arc<NetShared>,
    /// The certificate's SHA-256 now.
    fingerprint: std::sync::Mutex<[u8; 32]>,
}

impl Secrets {
    /// The secrets of a server outside dev mode, serving with the
    /// certificate whose SHA-256 is `fingerprint`.
    pub fn new(
        files: CredentialFiles,
        endpoint: quinn::Endpoint,
        shared: Arc<NetShared>,
        fingerprint: [u8; 32],
    ) -> Secrets {
        Secrets {
            files,
            endpoint,
            shared,
            fingerprint: std::sync::Mutex::new(fingerprint),
        }
    }

    /// Reads the files again and applies what changed. Blocking (it reads
    /// files).
    pub fn reload(&self) -> Result<Reloaded, ReloadError> {
        let creds = credentials::load(&self.files)?;
        let mut fingerprint = self.fingerprint.lock().unwrap_or_else(|e| e.into_inner());
        let certificate = creds.fingerprint != *fingerprint;
        if certificate {
            let config = crate::net::tls::server_config(&creds).map_err(ReloadError::Tls)?;
            self.endpoint.set_server_config(Some(config));
            *fingerprint = creds.fingerprint;
        }
        let now = crate::net::admission::unix_now();
        let token_key = self
            .shared
            .tokens
            .keys
            .write()
            .unwrap_or_else(|e| e.into_inner())
            .rotate(TokenKey::from_bytes(creds.token_key), now);
        Ok(Reloaded {
            token_key,
            certificate,
        })
    }

    /// [`Secrets::reload`], logged, with the admin token file beside it.
    pub fn reload_logged(&self) {
        match self.reload() {
            Ok(r) if r == Reloaded::default() => info!("secrets reloaded: unchanged"),
            Ok(r) => info!(
                token_key = r.token_key,
                certificate = r.certificate,
                "secrets reloaded"
            ),
            Err(e) => warn!(error = %e, "secrets not reloaded; the ones in use stay"),
        }
        // Logs and counts its own outcome.
        if self.shared.admin.tokens.file().is_some() {
            let _ = self.shared.admin.tokens.reload();
        }
    }

    /// Reloads whenever the files' contents change, looking every
    /// [`WATCH_PERIOD`]; runs until aborted.
    pub async fn watch(self: Arc<Self>) {
        let mut seen = self.digest().await;
        let mut ticker = tokio::time::interval(WATCH_PERIOD);
        ticker.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
        loop {
            ticker.tick().await;
            let now = self.digest().await;
            if now != seen {
                seen = now;
                let me = self.clone();
                let _ = tokio::task::spawn_blocking(move || me.reload_logged()).await;
            }
        }
    }

    /// A digest of the files' contents (an unreadable file counts as
    /// empty: when it comes back, that is a change).
    async fn digest(&self) -> Vec<u8> {
        let mut paths: Vec<std::path::PathBuf> = [
            &self.files.key_file,
            &self.files.cert_file,
            &self.files.cert_key_file,
        ]
        .into_iter()
        .flatten()
        .cloned()
        .collect();
        paths.extend(
            self.shared
                .admin
                .tokens
                .file()
                .map(std::path::Path::to_path_buf),
        );
        tokio::task::spawn_blocking(move || {
            let mut ctx = ring::digest::Context::new(&ring::digest::SHA256);
            for p in paths {
                let bytes = std::fs::read(&p).unwrap_or_default();
                ctx.update(&(bytes.len() as u64).to_le_bytes());
                ctx.update(&bytes);
            }
            ctx.finish().as_ref().to_vec()
        })
        .await
        .unwrap_or_default()
    }
}
