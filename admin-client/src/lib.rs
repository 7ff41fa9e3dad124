//! The operator's side of the admin channel: connect with the admin
//! credential (the server's certificate pinned by its fingerprint), then
//! one call at a time. `inertia-admin`, the viewer and the tests use it;
//! the server's side is `inertia_server::admin`.
//!
//! Against a dev-mode server everything comes from its dev credentials
//! file ([`AdminClient::connect_dev`]). Against any other the operator
//! gives the address, the certificate (or its fingerprint) and their own
//! token, from a file in the server's token-file format
//! ([`read_token_file`]).

use std::net::SocketAddr;
use std::path::Path;
use std::time::Duration;

use inertia_protocol::admin::{
    AdminCall, AdminHandshake, AdminHello, AdminRefusal, AdminReply, AdminRequest, AdminResponse,
    AdminWelcome, ADMIN_ALPN, ADMIN_PROTOCOL_VERSION,
};
use inertia_protocol::control::{encode_frame, ControlMessage, FrameDecoder};
use inertia_protocol::credentials::DevCredentials;

/// How long connecting and the hello may take.
pub const CONNECT_TIMEOUT: Duration = Duration::from_secs(10);
/// How long one call may wait for its reply.
pub const CALL_TIMEOUT: Duration = Duration::from_secs(30);

/// Why the admin client failed.
#[derive(Debug, thiserror::Error)]
pub enum AdminClientError {
    /// The credentials file could not be read.
    #[error("credentials {path}: {why}")]
    Credentials {
        /// The file.
        path: String,
        /// What went wrong.
        why: String,
    },
    /// TLS or the local socket could not be set up.
    #[error("set-up: {0}")]
    Setup(String),
    /// The server could not be reached, or the connection failed.
    #[error("connection: {0}")]
    Connection(String),
    /// The server refused the hello.
    #[error("refused by the server: {}", describe_refusal(.0))]
    Refused(AdminRefusal),
    /// The server broke the protocol (or answered another call).
    #[error("protocol: {0}")]
    Protocol(String),
    /// The server took too long.
    #[error("no answer within {0:?}")]
    Timeout(Duration),
}

fn describe_refusal(r: &AdminRefusal) -> String {
    match r {
        AdminRefusal::VersionMismatch { server, client } => {
            format!("the server speaks admin protocol {server}, this tool {client}")
        }
        AdminRefusal::BadCredential => "the admin credential is wrong".into(),
        AdminRefusal::Malformed => "the hello was malformed".into(),
        AdminRefusal::Throttled { retry_after_ms } => format!(
            "too many wrong admin credentials from this address; try again in {:.1} s",
            f64::from(*retry_after_ms) / 1000.0
        ),
    }
}

/// An operator's credential as read from a token file: the token, and
/// the operator's name when the file gives one.
#[derive(Clone, PartialEq, Eq)]
pub struct OperatorToken {
    /// The operator's name, if the line was `NAME TOKEN`.
    pub operator: Option<String>,
    /// The admin token.
    pub token: String,
}

impl std::fmt::Debug for OperatorToken {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("OperatorToken")
            .field("operator", &self.operator)
            .finish_non_exhaustive()
    }
}

/// Parses an operator's token file: its first line that is neither blank
/// nor a `#` comment, either `NAME TOKEN` (a line of the server's admin
/// token file) or a token alone. Errors never show the token.
pub fn parse_token_file(text: &str) -> Result<OperatorToken, String> {
    let line = text
        .lines()
        .map(str::trim)
        .find(|l| !l.is_empty() && !l.starts_with('#'))
        .ok_or_else(|| "no token in the file".to_string())?;
    let mut fields = line.split_whitespace();
    match (fields.next(), fields.next(), fields.next()) {
        (Some(token), None, _) => Ok(OperatorToken {
            operator: None,
            token: token.to_string(),
        }),
        (Some(name), Some(token), None) => Ok(OperatorToken {
            operator: Some(name.to_string()),
            token: token.to_string(),
        }),
        _ => Err("expected `OPERATOR TOKEN` or a token alone on the first line".into()),
    }
}

/// Reads an operator's token file (see [`parse_token_file`]).
pub fn read_token_file(path: &Path) -> Result<OperatorToken, AdminClientError> {
    let err = |why: String| AdminClientError::Credentials {
        path: path.display().to_string(),
        why,
    };
    let bytes = std::fs::read(path).map_err(|e| err(e.to_string()))?;
    let text = String::from_utf8(bytes).map_err(|_| err("not UTF-8 text".into()))?;
    parse_token_file(&text).map_err(err)
}

/// The SHA-256 fingerprint of the certificate in `path` (PEM or DER): what
/// the admin client pins.
pub fn cert_file_fingerprint(path: &Path) -> Result<[u8; 32], AdminClientError> {
    use rustls::pki_types::pem::PemObject;
    use rustls::pki_types::CertificateDer;
    let err = |why: String| AdminClientError::Credentials {
        path: path.display().to_string(),
        why,
    };
    let bytes = std::fs::read(path).map_err(|e| err(e.to_string()))?;
    let der = if bytes.starts_with(b"-----") {
        CertificateDer::from_pem_slice(&bytes)
            .map_err(|e| err(format!("no PEM certificate: {e}")))?
    } else {
        CertificateDer::from(bytes)
    };
    Ok(inertia_protocol::token::cert_fingerprint(&der))
}

/// The quinn client configuration for the admin channel, pinning the
/// server certificate whose SHA-256 is `fingerprint`.
pub fn client_config(fingerprint: [u8; 32]) -> Result<quinn::ClientConfig, String> {
    inertia_tls::client_config_for(fingerprint, ADMIN_ALPN)
}

/// The dev credentials file at `path`.
pub fn read_credentials(path: &Path) -> Result<DevCredentials, AdminClientError> {
    let err = |why: String| AdminClientError::Credentials {
        path: path.display().to_string(),
        why,
    };
    let bytes = std::fs::read(path).map_err(|e| err(e.to_string()))?;
    serde_json::from_slice(&bytes).map_err(|e| err(e.to_string()))
}

/// A QUIC connection to `addr` for the admin channel, the certificate
/// pinned to `fingerprint`, and the endpoint that carries it.
pub async fn connect_quic(
    addr: SocketAddr,
    fingerprint: [u8; 32],
) -> Result<(quinn::Endpoint, quinn::Connection), AdminClientError> {
    let local: SocketAddr = if addr.is_ipv4() {
        "0.0.0.0:0".parse().expect("literal")
    } else {
        "[::]:0".parse().expect("literal")
    };
    connect_quic_from(local, addr, fingerprint).await
}

/// [`connect_quic`] from the local address `local` (a port of 0 is any
/// free port).
pub async fn connect_quic_from(
    local: SocketAddr,
    addr: SocketAddr,
    fingerprint: [u8; 32],
) -> Result<(quinn::Endpoint, quinn::Connection), AdminClientError> {
    let mut endpoint =
        quinn::Endpoint::client(local).map_err(|e| AdminClientError::Setup(e.to_string()))?;
    endpoint
        .set_default_client_config(client_config(fingerprint).map_err(AdminClientError::Setup)?);
    let connecting = endpoint
        .connect(addr, "localhost")
        .map_err(|e| AdminClientError::Connection(e.to_string()))?;
    let connection = tokio::time::timeout(CONNECT_TIMEOUT, connecting)
        .await
        .map_err(|_| AdminClientError::Timeout(CONNECT_TIMEOUT))?
        .map_err(|e| AdminClientError::Connection(e.to_string()))?;
    Ok((endpoint, connection))
}

/// An admitted admin connection.
#[derive(Debug)]
pub struct AdminClient {
    endpoint: quinn::Endpoint,
    connection: quinn::Connection,
    send: quinn::SendStream,
    recv: quinn::RecvStream,
    frames: FrameDecoder,
    next_id: u32,
    welcome: AdminWelcome,
}

impl AdminClient {
    /// Connects to `addr`, pins `fingerprint`, and says hello with
    /// `credential` as `operator`.
    pub async fn connect(
        addr: SocketAddr,
        fingerprint: [u8; 32],
        credential: &str,
        operator: &str,
    ) -> Result<AdminClient, AdminClientError> {
        let (endpoint, connection) = connect_quic(addr, fingerprint).await?;
        Self::hello(endpoint, connection, credential, operator).await
    }

    /// [`AdminClient::connect`] from the local address `local`.
    pub async fn connect_from(
        local: SocketAddr,
        addr: SocketAddr,
        fingerprint: [u8; 32],
        credential: &str,
        operator: &str,
    ) -> Result<AdminClient, AdminClientError> {
        let (endpoint, connection) = connect_quic_from(local, addr, fingerprint).await?;
        Self::hello(endpoint, connection, credential, operator).await
    }

    async fn hello(
        endpoint: quinn::Endpoint,
        connection: quinn::Connection,
        credential: &str,
        operator: &str,
    ) -> Result<AdminClient, AdminClientError> {
        let (mut send, recv) = connection
            .open_bi()
            .await
            .map_err(|e| AdminClientError::Connection(e.to_string()))?;
        let hello = AdminHello {
            version: ADMIN_PROTOCOL_VERSION,
            token: credential.to_string(),
            operator: operator.to_string(),
        };
        let bytes = encode_frame(&hello).map_err(|e| AdminClientError::Protocol(e.to_string()))?;
        send.write_all(&bytes)
            .await
            .map_err(|e| AdminClientError::Connection(e.to_string()))?;
        let mut client = AdminClient {
            endpoint,
            connection,
            send,
            recv,
            frames: FrameDecoder::new(),
            next_id: 1,
            welcome: AdminWelcome {
                version: 0,
                server_version: String::new(),
                tick_hz: 1,
            },
        };
        let answer: AdminHandshake = client.read(CONNECT_TIMEOUT).await?;
        match answer {
            AdminHandshake::Welcome(w) => {
                client.welcome = w;
                Ok(client)
            }
            AdminHandshake::Refused(r) => {
                client.connection.close(0u32.into(), b"refused");
                Err(AdminClientError::Refused(r))
            }
        }
    }

    /// Connects with the server address, fingerprint and admin
    /// credential of a dev credentials file (`addr` overrides its
    /// address).
    pub async fn connect_dev(
        credentials: &Path,
        addr: Option<SocketAddr>,
        operator: &str,
    ) -> Result<AdminClient, AdminClientError> {
        let creds = read_credentials(credentials)?;
        let bad = |why: String| AdminClientError::Credentials {
            path: credentials.display().to_string(),
            why,
        };
        let addr = match addr {
            Some(a) => a,
            None => creds
                .server_addr
                .parse()
                .map_err(|e| bad(format!("server_addr: {e}")))?,
        };
        let fingerprint = creds.fingerprint().map_err(|e| bad(e.to_string()))?;
        Self::connect(addr, fingerprint, &creds.admin_token, operator).await
    }

    /// What the server said about itself.
    pub fn welcome(&self) -> &AdminWelcome {
        &self.welcome
    }

    async fn read<T: ControlMessage>(&mut self, wait: Duration) -> Result<T, AdminClientError> {
        let mut buf = [0u8; 4096];
        let read = async {
            loop {
                if let Some(msg) = self.frames.next::<T>() {
                    return msg.map_err(|e| AdminClientError::Protocol(e.to_string()));
                }
                match self.recv.read(&mut buf).await {
                    Ok(Some(n)) => self
                        .frames
                        .push(&buf[..n])
                        .map_err(|e| AdminClientError::Protocol(e.to_string()))?,
                    Ok(None) => {
                        return Err(AdminClientError::Connection(
                            "the server closed the admin stream".into(),
                        ))
                    }
                    Err(e) => return Err(AdminClientError::Connection(e.to_string())),
                }
            }
        };
        tokio::time::timeout(wait, read)
            .await
            .map_err(|_| AdminClientError::Timeout(wait))?
    }

    /// Sends `request` and waits for its answer (an
    /// [`AdminResponse::Error`] is an answer, not a failure).
    pub async fn call(&mut self, request: AdminRequest) -> Result<AdminResponse, AdminClientError> {
        let id = self.next_id;
        self.next_id = self.next_id.wrapping_add(1).max(1);
        let bytes = encode_frame(&AdminCall { id, request })
            .map_err(|e| AdminClientError::Protocol(e.to_string()))?;
        self.send
            .write_all(&bytes)
            .await
            .map_err(|e| AdminClientError::Connection(e.to_string()))?;
        let reply: AdminReply = self.read(CALL_TIMEOUT).await?;
        if reply.id != id {
            if let AdminResponse::Error(e) = reply.response {
                return Ok(AdminResponse::Error(e));
            }
            return Err(AdminClientError::Protocol(format!(
                "answer to call {} while waiting for {id}",
                reply.id
            )));
        }
        Ok(reply.response)
    }

    /// Sends raw bytes on the admin stream (for tests of what the server
    /// does with malformed calls) and reads the next reply, if any.
    pub async fn send_raw(&mut self, bytes: &[u8]) -> Result<AdminReply, AdminClientError> {
        self.send
            .write_all(bytes)
            .await
            .map_err(|e| AdminClientError::Connection(e.to_string()))?;
        self.read(CALL_TIMEOUT).await
    }

    /// Says goodbye: finishes the stream and closes the connection.
    pub async fn close(mut self) {
        let _ = self.send.finish();
        let _ = tokio::time::timeout(Duration::from_millis(500), self.connection.closed()).await;
        self.connection.close(0u32.into(), b"done");
        let _ = tokio::time::timeout(Duration::from_millis(500), self.endpoint.wait_idle()).await;
    }
}
