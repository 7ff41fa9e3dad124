//! A player joined by hand: the protocol's own client types
//! ([`ClientConnection`] for the connection's life, [`ClientSession`] for
//! snapshots and inputs) over quinn, pinned to the server's certificate,
//! on a thread of its own. The process tests need a player that the
//! server welcomes, serves and says goodbye to, without the client SDK
//! (the server depends on nothing above the protocol).

use std::net::SocketAddr;
use std::path::Path;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use inertia_protocol::connection::{
    ClientConnection, ClientConnectionConfig, ClientConnectionEvent,
};
use inertia_protocol::control::{DisconnectReason, PROTOCOL_VERSION};
use inertia_protocol::credentials::DevCredentials;
use inertia_protocol::token::ConnectToken;
use inertia_protocol::{ClientConfig, ClientSession};

/// What the player saw, shared with the test.
#[derive(Debug, Default)]
struct Seen {
    snapshots: u64,
    end: Option<DisconnectReason>,
}

/// A player in the game until the server lets it go, or it is dropped
/// (it then says goodbye and closes, as a game does).
#[derive(Debug)]
pub struct Player {
    seen: Arc<Mutex<Seen>>,
    leave: Arc<tokio::sync::Notify>,
}

impl Drop for Player {
    fn drop(&mut self) {
        self.leave.notify_one();
    }
}

impl Player {
    /// Joins the dev server whose credentials file is `credentials` as
    /// `client_id` (one from the clock when `None`).
    pub fn join_dev(credentials: &Path, client_id: Option<u64>) -> Result<Player, String> {
        let bytes = std::fs::read(credentials).map_err(|e| e.to_string())?;
        let creds: DevCredentials = serde_json::from_slice(&bytes).map_err(|e| e.to_string())?;
        let addr: SocketAddr = creds.server_addr.parse().map_err(|e| format!("{e}"))?;
        let now = SystemTime::now()
            .duration_since(UNIX_EPOCH)
            .map_or(0, |d| d.as_secs());
        let id = client_id.unwrap_or(u64::from(now as u32) << 8 | 1);
        let token = creds.mint_token(id, 60, now).map_err(|e| e.to_string())?;
        Player::join(addr, &token)
    }

    /// Joins the server at `addr` with `token`; why not, if it cannot.
    pub fn join(addr: SocketAddr, token: &ConnectToken) -> Result<Player, String> {
        let seen = Arc::new(Mutex::new(Seen::default()));
        let (joined_tx, joined_rx) = std::sync::mpsc::channel();
        let token = token.clone();
        let shared = seen.clone();
        let leave = Arc::new(tokio::sync::Notify::new());
        let told_to_leave = leave.clone();
        std::thread::spawn(move || {
            let runtime = tokio::runtime::Builder::new_current_thread()
                .enable_all()
                .build()
                .expect("a runtime");
            runtime.block_on(play(addr, token, shared, told_to_leave, joined_tx));
        });
        joined_rx
            .recv_timeout(Duration::from_secs(15))
            .map_err(|e| format!("no answer: {e}"))??;
        Ok(Player { seen, leave })
    }

    /// Snapshots received so far.
    pub fn snapshots(&self) -> u64 {
        self.seen.lock().expect("not poisoned").snapshots
    }

    /// Why the connection ended, once it has.
    pub fn disconnected(&self) -> Option<DisconnectReason> {
        self.seen.lock().expect("not poisoned").end.clone()
    }
}

/// Joins, then plays (acknowledging snapshots with idle inputs) until the
/// connection ends.
async fn play(
    addr: SocketAddr,
    token: ConnectToken,
    seen: Arc<Mutex<Seen>>,
    leave: Arc<tokio::sync::Notify>,
    joined: std::sync::mpsc::Sender<Result<(), String>>,
) {
    let fail = |why: String| {
        let _ = joined.send(Err(why));
    };
    let config = match inertia_tls::client_config(token.public.cert_fingerprint) {
        Ok(c) => c,
        Err(e) => return fail(e),
    };
    let mut endpoint = match quinn::Endpoint::client("127.0.0.1:0".parse().expect("literal")) {
        Ok(e) => e,
        Err(e) => return fail(e.to_string()),
    };
    endpoint.set_default_client_config(config);
    let started = Instant::now();
    let mut conn = ClientConnection::new(
        PROTOCOL_VERSION,
        token.to_bytes(),
        ClientConnectionConfig::default(),
        started,
    );
    let connection = match endpoint.connect(addr, "localhost") {
        Ok(connecting) => match connecting.await {
            Ok(c) => c,
            Err(e) => return fail(e.to_string()),
        },
        Err(e) => return fail(e.to_string()),
    };
    let (mut send, mut recv) = match connection.open_bi().await {
        Ok(s) => s,
        Err(e) => return fail(e.to_string()),
    };
    let mut buf = vec![0u8; 16 * 1024];
    let mut session: Option<(ClientSession, u64, u32)> = None;
    let mut told = false;
    loop {
        while let Some(event) = conn.poll_event() {
            if let ClientConnectionEvent::Welcomed(info) = event {
                let config = ClientConfig {
                    snapshot: info.snapshot,
                    input_hz: 30,
                    input_redundancy: 4,
                    properties: info.properties.clone(),
                };
                match ClientSession::new(config, info.tick) {
                    Ok(s) => session = Some((s, info.tick, info.tick_hz)),
                    Err(e) => return fail(e.to_string()),
                }
                told = true;
                let _ = joined.send(Ok(()));
            }
        }
        if conn.is_closed() {
            break;
        }
        if conn.wants_finish() {
            let _ = send.finish();
            // Taken or not, the finish wait closes it.
            conn.finish_sent();
        }
        let now = Instant::now();
        let deadline = conn
            .poll_timeout()
            .unwrap_or(now + Duration::from_secs(3600));
        // When the session's next input is due (its clock is seconds since
        // the start).
        let input_due = session.as_ref().map_or(now, |(s, _, _)| {
            started + Duration::from_secs_f64(s.next_input_at().max(0.0))
        });
        tokio::select! {
            datagram = connection.read_datagram() => match datagram {
                Ok(bytes) => {
                    if let Some((s, _, _)) = &mut session {
                        if s.on_datagram(&bytes).is_ok() {
                            seen.lock().expect("not poisoned").snapshots += 1;
                        }
                    }
                }
                Err(e) => conn.on_lost(closed_reason(&e)),
            },
            read = recv.read(&mut buf), if conn.reads_control() => match read {
                Ok(Some(n)) => conn.on_control_data(&buf[..n], Instant::now()),
                Ok(None) | Err(_) => conn.on_control_finished(Instant::now()),
            },
            written = send.write(conn.pending_control()), if !conn.pending_control().is_empty() => match written {
                Ok(n) => conn.control_written(n, Instant::now()),
                Err(e) => conn.on_lost(DisconnectReason::ProtocolError {
                    what: format!("control stream: {e}"),
                }),
            },
            () = tokio::time::sleep_until(deadline.into()) => conn.handle_timeout(Instant::now()),
            () = leave.notified() => conn.close(Instant::now()),
            () = tokio::time::sleep_until(input_due.into()), if conn.is_live() => {
                if let Some((s, tick, tick_hz)) = &mut session {
                    let elapsed = started.elapsed().as_secs_f64();
                    let target = *tick + (elapsed * f64::from(*tick_hz)) as u64 + 2;
                    if let Some(bytes) = s.poll_input(elapsed, Some(target)) {
                        let _ = connection.send_datagram(bytes.into());
                    }
                }
            }
        }
    }
    let end = conn.end().map(|e| e.reason());
    if !told {
        return fail(format!("not welcomed: {end:?}"));
    }
    if let Some(close) = conn.close_frame() {
        connection.close(close.code.into(), close.reason.as_bytes());
    }
    seen.lock().expect("not poisoned").end = end;
}

fn closed_reason(e: &quinn::ConnectionError) -> DisconnectReason {
    match e {
        quinn::ConnectionError::TimedOut => DisconnectReason::Timeout,
        quinn::ConnectionError::ApplicationClosed(close) => {
            DisconnectReason::from_close(close.error_code.into_inner(), &close.reason)
        }
        other => DisconnectReason::ProtocolError {
            what: other.to_string(),
        },
    }
}
