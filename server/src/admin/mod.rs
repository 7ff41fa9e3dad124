//! The admin channel's server side: connections that negotiated
//! [`ADMIN_ALPN`](inertia_protocol::admin::ADMIN_ALPN) on the game port.
//!
//! The operator's tool opens one bidirectional stream and sends an
//! [`AdminHello`]. Nothing is answered before it passes [`judge_hello`]:
//! the protocol version, then the [`throttle`] on the tool's address, then
//! the hello's bounds, then its operator name and token against the
//! server's [`tokens`] (the operators of `--admin-token-file`, and the
//! dev token in dev mode). A hello that fails gets an
//! [`AdminHandshake::Refused`] and the connection is closed, and so does
//! anything that is not a hello (garbage, a stream that ends early, no
//! hello within [`HELLO_TIMEOUT`]). After the welcome each [`AdminCall`]
//! is carried out on the simulation and answered with an [`AdminReply`]
//! carrying its id; a call that does not decode or fails its checks is
//! answered with an [`AdminErrorKind::Invalid`] error under id 0 and
//! changes nothing.
//!
//! `save` and `load` name checkpoints in the server's checkpoint
//! directory and nowhere else ([`crate::replay::checkpoint`]); the file
//! is written or read and decoded on tokio's blocking pool, and only the
//! capture of the state, or the swap of the decoded one, runs on the tick
//! thread. A call in flight when the server shuts down is dropped with
//! its connection.
//!
//! Every hello and every action is logged (target `inertia::admin`) with
//! the operator (for an admitted hello, the name its token belongs to),
//! the remote address, the request and the outcome, and counted in
//! [`Metrics::admin_actions`](crate::metrics::Metrics) by action and
//! outcome. No token is ever logged.
//!
//! The tool's side is the `inertia-admin-client` crate's `AdminClient`.

mod kicks;
mod shared;
pub mod throttle;
pub mod tokens;

pub use kicks::Kicks;
pub use shared::AdminShared;

use std::net::{IpAddr, SocketAddr};
use std::sync::Arc;
use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

use inertia_protocol::admin::{
    AdminCall, AdminError, AdminErrorKind, AdminHandshake, AdminHello, AdminRefusal, AdminReply,
    AdminRequest, AdminResponse, AdminWelcome, StatusReport, ADMIN_PROTOCOL_VERSION,
};
use inertia_protocol::control::{encode_frame, ControlMessage, FrameDecoder};
use tracing::{debug, info, warn};

use crate::record::matches::MatchesError;
use crate::replay::checkpoint::CheckpointError;
use crate::replay::WorldEdit;
use crate::sim::edit::EditOutcome;
use crate::sim::time_travel::{SeekReport, TimeError};
use crate::sim::{ClockControl, CommandError, EditError, Simulation};

/// How long an admin tool has to say hello.
pub const HELLO_TIMEOUT: Duration = Duration::from_secs(5);

/// QUIC close codes of the admin channel.
pub mod close_code {
    /// The tool said goodbye (closed its stream).
    pub const DONE: u32 = 0;
    /// The hello was refused.
    pub const REFUSED: u32 = 1;
    /// The stream broke the framing after the hello.
    pub const PROTOCOL: u32 = 2;
    /// The server is shutting down.
    pub const SHUTDOWN: u32 = 3;
}

/// The audit log's target.
const AUDIT: &str = "inertia::admin";

/// The name an [`AdminRequest`] goes by in logs, metrics and the tool.
pub fn action_name(request: &AdminRequest) -> &'static str {
    match request {
        AdminRequest::Status => "status",
        AdminRequest::Pause => "pause",
        AdminRequest::Resume => "resume",
        AdminRequest::Step { .. } => "step",
        AdminRequest::Speed { .. } => "speed",
        AdminRequest::RunTo { .. } => "run_to",
        AdminRequest::Seek { .. } => "seek",
        AdminRequest::Reverse { .. } => "reverse",
        AdminRequest::Replay { .. } => "replay",
        AdminRequest::Save { .. } => "save",
        AdminRequest::Load { .. } => "load",
        AdminRequest::Record { .. } => "record",
        AdminRequest::Spawn { .. } => "spawn",
        AdminRequest::Despawn { .. } => "despawn",
        AdminRequest::Impulse { .. } => "impulse",
        AdminRequest::Kick { .. } => "kick",
        AdminRequest::Hash { .. } => "hash",
        AdminRequest::Matches => "matches",
        AdminRequest::FetchRecording { .. } => "fetch_recording",
    }
}

/// The outcome label of a response: `ok`, or the error kind.
pub fn outcome_name(response: &AdminResponse) -> &'static str {
    match response {
        AdminResponse::Error(e) => error_kind_name(e.kind),
        _ => "ok",
    }
}

/// The label of an error kind.
pub fn error_kind_name(kind: AdminErrorKind) -> &'static str {
    match kind {
        AdminErrorKind::Invalid => "invalid",
        AdminErrorKind::NotFound => "not_found",
        AdminErrorKind::OutOfRange => "out_of_range",
        AdminErrorKind::NotRecorded => "not_recorded",
        AdminErrorKind::Busy => "busy",
        AdminErrorKind::Io => "io",
        AdminErrorKind::Unsupported => "unsupported",
    }
}

/// The outcome label of a refused hello.
pub fn refusal_name(refusal: &AdminRefusal) -> &'static str {
    match refusal {
        AdminRefusal::VersionMismatch { .. } => "refused_version",
        AdminRefusal::BadCredential => "refused_credential",
        AdminRefusal::Malformed => "refused_malformed",
        AdminRefusal::Throttled { .. } => "refused_throttled",
    }
}

/// Answers a hello from `ip` at `now`, without I/O: the protocol version
/// first (so an old tool learns it is old), then the throttle (an address
/// blocked for failing too often is refused whatever it sends), then the
/// hello's bounds, then its operator and token against `shared`'s admin
/// tokens. A wrong credential counts against the address in the
/// throttle; an admitted hello clears it.
pub fn judge_hello(
    hello: &AdminHello,
    ip: IpAddr,
    now: Instant,
    shared: &AdminShared,
) -> Result<tokens::Admitted, AdminRefusal> {
    if hello.version != ADMIN_PROTOCOL_VERSION {
        return Err(AdminRefusal::VersionMismatch {
            server: ADMIN_PROTOCOL_VERSION,
            client: hello.version,
        });
    }
    let throttle = || shared.throttle.lock().unwrap_or_else(|e| e.into_inner());
    if let Err(wait) = throttle().check(ip, now) {
        let retry_after_ms = u32::try_from(wait.as_nanos().div_ceil(1_000_000)).unwrap_or(u32::MAX);
        return Err(AdminRefusal::Throttled { retry_after_ms });
    }
    if hello.check().is_err() {
        return Err(AdminRefusal::Malformed);
    }
    match shared.tokens.current().admit(&hello.operator, &hello.token) {
        Some(admitted) => {
            throttle().success(ip);
            Ok(admitted)
        }
        None => {
            if let Some(backoff) = throttle().failure(ip, now) {
                warn!(
                    target: AUDIT,
                    %ip,
                    backoff_ms = backoff.as_millis() as u64,
                    "too many wrong admin credentials from this address: its hellos are refused for a while"
                );
            }
            Err(AdminRefusal::BadCredential)
        }
    }
}

async fn write<T: ControlMessage>(send: &mut quinn::SendStream, msg: &T) -> Result<(), String> {
    let bytes = encode_frame(msg).map_err(|e| e.to_string())?;
    send.write_all(&bytes).await.map_err(|e| e.to_string())
}

/// What a read of the next message found.
enum Next<T> {
    Message(T),
    /// Bytes that are not a valid message; the stream is still in step
    /// when `in_step`.
    Bad {
        what: String,
        in_step: bool,
    },
    /// The stream ended (or the connection went away).
    End,
}

async fn read_next<T: ControlMessage>(
    recv: &mut quinn::RecvStream,
    frames: &mut FrameDecoder,
    buf: &mut [u8],
) -> Next<T> {
    loop {
        match frames.next::<T>() {
            Some(Ok(msg)) => return Next::Message(msg),
            Some(Err(e)) => {
                let in_step = !matches!(
                    e,
                    inertia_protocol::control::ControlError::FrameTooLarge { .. }
                );
                return Next::Bad {
                    what: e.to_string(),
                    in_step,
                };
            }
            None => {}
        }
        match recv.read(buf).await {
            Ok(Some(n)) => {
                if let Err(e) = frames.push(&buf[..n]) {
                    return Next::Bad {
                        what: e.to_string(),
                        in_step: false,
                    };
                }
            }
            Ok(None) if frames.buffered() > 0 => {
                return Next::Bad {
                    what: "the stream ended inside a frame".into(),
                    in_step: false,
                }
            }
            Ok(None) | Err(_) => return Next::End,
        }
    }
}

/// Serves one admin connection to its end.
pub async fn serve(connection: quinn::Connection, id: u64, shared: Arc<AdminShared>) {
    let remote = connection.remote_address();
    let (mut send, mut recv) = match tokio::time::timeout(HELLO_TIMEOUT, connection.accept_bi())
        .await
    {
        Ok(Ok(pair)) => pair,
        Ok(Err(e)) => {
            debug!(target: AUDIT, connection = id, %remote, error = %e, "admin connection gone before a stream");
            return;
        }
        Err(_) => {
            refuse_silently(&connection, id, remote, &shared, "no stream in time");
            return;
        }
    };
    let mut frames = FrameDecoder::new();
    let mut buf = vec![0u8; 4096];
    let hello = tokio::time::timeout(
        HELLO_TIMEOUT,
        read_next::<AdminHello>(&mut recv, &mut frames, &mut buf),
    )
    .await;
    let (operator, token, verdict) = match hello {
        Err(_) => (String::new(), String::new(), Err(AdminRefusal::Malformed)),
        Ok(Next::End) => {
            refuse_silently(&connection, id, remote, &shared, "closed before a hello");
            return;
        }
        Ok(Next::Bad { what, .. }) => {
            debug!(target: AUDIT, connection = id, %remote, error = %what, "admin hello does not decode");
            (String::new(), String::new(), Err(AdminRefusal::Malformed))
        }
        Ok(Next::Message(hello)) => {
            let verdict = judge_hello(&hello, remote.ip(), Instant::now(), &shared);
            (hello.operator, hello.token, verdict)
        }
    };
    let admitted = match verdict {
        Ok(admitted) => admitted,
        Err(refusal) => {
            let outcome = refusal_name(&refusal);
            warn!(target: AUDIT, connection = id, %remote, operator = %operator.escape_debug(), outcome, "admin hello refused");
            shared.metrics.admin_action("hello", outcome);
            shared.metrics.refused(&format!("admin_{outcome}"));
            let _ = write(&mut send, &AdminHandshake::Refused(refusal)).await;
            let _ = send.finish();
            let _ = tokio::time::timeout(Duration::from_millis(500), send.stopped()).await;
            connection.close(close_code::REFUSED.into(), b"refused");
            return;
        }
    };
    let welcome = AdminHandshake::Welcome(AdminWelcome {
        version: ADMIN_PROTOCOL_VERSION,
        server_version: env!("CARGO_PKG_VERSION").to_string(),
        tick_hz: shared.tick_hz,
    });
    if write(&mut send, &welcome).await.is_err() {
        return;
    }
    info!(
        target: AUDIT,
        connection = id,
        %remote,
        operator = %admitted.operator,
        credential = if admitted.shared { "shared" } else { "operator" },
        outcome = "ok",
        "admin hello accepted"
    );
    shared.metrics.admin_action("hello", "ok");
    let session = Session {
        operator: admitted.operator,
        remote,
        connection: id,
        shared: &shared,
    };
    let mut shutdown = shared.shutdown.clone();
    loop {
        let next = tokio::select! {
            next = read_next::<AdminCall>(&mut recv, &mut frames, &mut buf) => next,
            _ = shutdown.changed() => {
                connection.close(close_code::SHUTDOWN.into(), b"server shutting down");
                return;
            }
        };
        match next {
            Next::Message(call) => {
                // Every call is checked against the operators as they are
                // now: one removed from the token file by a reload is
                // refused here, and their session ends.
                if shared.tokens.current().admit(&operator, &token).is_none() {
                    warn!(target: AUDIT, connection = id, %remote, operator = %operator.escape_debug(), "admin credential revoked by a reload: session ended");
                    shared.metrics.admin_action("call", "revoked");
                    connection.close(close_code::REFUSED.into(), b"admin credential revoked");
                    return;
                }
                // A call in flight does not hold up shutdown: the
                // connection closes and the answer is dropped.
                let response = tokio::select! {
                    response = session.answer(&call.request) => response,
                    _ = shutdown.changed() => {
                        connection.close(close_code::SHUTDOWN.into(), b"server shutting down");
                        return;
                    }
                };
                let reply = AdminReply {
                    id: call.id,
                    response,
                };
                if write(&mut send, &reply).await.is_err() {
                    return;
                }
            }
            Next::Bad { what, in_step } => {
                warn!(target: AUDIT, connection = id, %remote, operator = %session.operator, error = %what, outcome = "invalid", "admin call malformed");
                shared.metrics.admin_action("malformed", "invalid");
                let reply = AdminReply {
                    id: 0,
                    response: AdminResponse::Error(AdminError::new(
                        AdminErrorKind::Invalid,
                        format!("malformed call: {what}"),
                    )),
                };
                let _ = write(&mut send, &reply).await;
                if !in_step {
                    let _ = send.finish();
                    let _ = tokio::time::timeout(Duration::from_millis(500), send.stopped()).await;
                    connection.close(close_code::PROTOCOL.into(), b"malformed call");
                    return;
                }
            }
            Next::End => {
                let _ = send.finish();
                let _ = tokio::time::timeout(Duration::from_millis(500), send.stopped()).await;
                connection.close(close_code::DONE.into(), b"done");
                debug!(target: AUDIT, connection = id, %remote, "admin connection done");
                return;
            }
        }
    }
}

/// Closes a connection that never sent a hello (nothing is answered),
/// logging and counting it as a malformed hello.
fn refuse_silently(
    connection: &quinn::Connection,
    id: u64,
    remote: SocketAddr,
    shared: &AdminShared,
    why: &str,
) {
    warn!(target: AUDIT, connection = id, %remote, why, outcome = "refused_malformed", "admin connection without a hello");
    shared.metrics.admin_action("hello", "refused_malformed");
    shared.metrics.refused("admin_refused_malformed");
    connection.close(close_code::REFUSED.into(), b"no hello");
}

/// One admitted operator's connection.
struct Session<'a> {
    operator: String,
    remote: SocketAddr,
    connection: u64,
    shared: &'a AdminShared,
}

fn unavailable(e: CommandError) -> AdminError {
    match e {
        CommandError::Busy => AdminError::new(AdminErrorKind::Busy, e.to_string()),
        CommandError::Stopped => AdminError::new(AdminErrorKind::Unsupported, e.to_string()),
    }
}

impl Session<'_> {
    /// Carries out one request, logs it and counts it.
    async fn answer(&self, request: &AdminRequest) -> AdminResponse {
        let response = match request.check() {
            Err(e) => AdminResponse::Error(e.into()),
            Ok(()) => self
                .carry_out(request)
                .await
                .unwrap_or_else(AdminResponse::Error),
        };
        let action = action_name(request);
        let outcome = outcome_name(&response);
        match &response {
            AdminResponse::Error(e) => info!(
                target: AUDIT,
                connection = self.connection,
                remote = %self.remote,
                operator = %self.operator,
                action,
                ?request,
                outcome,
                error = %e.message,
                "admin action"
            ),
            _ => info!(
                target: AUDIT,
                connection = self.connection,
                remote = %self.remote,
                operator = %self.operator,
                action,
                ?request,
                outcome,
                "admin action"
            ),
        }
        self.shared.metrics.admin_action(action, outcome);
        response
    }

    /// Runs `f` on the tick thread and waits for its answer.
    async fn on_sim<R: Send + 'static>(
        &self,
        f: impl FnOnce(&mut Simulation) -> R + Send + 'static,
    ) -> Result<R, AdminError> {
        let rx = self.shared.sim.call(f).map_err(unavailable)?;
        rx.await.map_err(|_| unavailable(CommandError::Stopped))
    }

    async fn carry_out(&self, request: &AdminRequest) -> Result<AdminResponse, AdminError> {
        match request {
            AdminRequest::Status => {
                let report = self.on_sim(status_report).await?;
                Ok(AdminResponse::Status(report))
            }
            AdminRequest::Pause => self.control_clock(ClockControl::Pause).await,
            AdminRequest::Resume => self.control_clock(ClockControl::Resume).await,
            AdminRequest::Step { ticks } => self.control_clock(ClockControl::Step(*ticks)).await,
            AdminRequest::Speed { scale } => self.control_clock(ClockControl::Speed(*scale)).await,
            AdminRequest::RunTo { tick } => self.control_clock(ClockControl::RunTo(*tick)).await,
            AdminRequest::Hash { tick } => {
                let tick = *tick;
                self.travel(move |s| {
                    let tick = tick.unwrap_or(s.world().tick());
                    s.hash_at(tick)
                })
                .await
            }
            AdminRequest::Seek { tick } => {
                let tick = *tick;
                self.travel(move |s| s.seek(tick)).await
            }
            AdminRequest::Reverse { speed } => {
                let speed = *speed;
                self.on_sim(move |s| s.reverse(speed))
                    .await?
                    .map_err(time_error)?;
                Ok(AdminResponse::Ok)
            }
            AdminRequest::Replay { from, to, speed } => {
                let (from, to, speed) = (*from, *to, *speed);
                self.travel(move |s| s.replay(from, to, speed)).await
            }
            AdminRequest::Matches => {
                let matches = self.shared.matches.clone();
                let list = blocking(move || matches.list())
                    .await?
                    .map_err(matches_error)?;
                Ok(AdminResponse::Matches(list))
            }
            AdminRequest::FetchRecording { name, file, offset } => {
                let (matches, name, file, offset) =
                    (self.shared.matches.clone(), name.clone(), *file, *offset);
                let part = blocking(move || matches.read(&name, file, offset))
                    .await?
                    .map_err(matches_error)?;
                Ok(AdminResponse::RecordingPart {
                    files: part.files,
                    file_name: part.file_name,
                    file_len: part.file_len,
                    offset: part.offset,
                    data: part.data,
                })
            }
            AdminRequest::Save { name, overwrite } => {
                // The state is captured on the tick thread; encoded,
                // packed and written off it.
                let state = self.on_sim(|s| s.checkpoint()).await?;
                let tick = state.tick;
                let (dir, name, overwrite) =
                    (self.shared.checkpoints.clone(), name.clone(), *overwrite);
                let written = name.clone();
                let bytes = blocking(move || dir.write(&written, &state.encode(), overwrite))
                    .await?
                    .map_err(checkpoint_error)?;
                info!(target: AUDIT, operator = %self.operator, tick, checkpoint = %name, bytes, overwrite, "checkpoint saved");
                Ok(AdminResponse::Ok)
            }
            AdminRequest::Load { name } => {
                // Read and decoded off the tick thread, which only swaps
                // the decoded state in.
                let (dir, name) = (self.shared.checkpoints.clone(), name.clone());
                let state = blocking(move || dir.read(&name))
                    .await?
                    .map_err(checkpoint_error)?;
                let operator = self.operator.clone();
                let tick = state.tick;
                let state_hash = self
                    .on_sim(move |s| s.load(&state, &operator))
                    .await?
                    .map_err(|e| AdminError::new(AdminErrorKind::Invalid, e.to_string()))?;
                Ok(AdminResponse::Hash {
                    tick,
                    state_hash,
                    recorded_hash: None,
                })
            }
            AdminRequest::Record { on: true } => {
                let io = |e: String| AdminError::new(AdminErrorKind::Io, e);
                let Some(opening) = self.on_sim(|s| s.prepare_recording()).await?.map_err(io)?
                else {
                    return Ok(AdminResponse::Ok);
                };
                // The directory is opened (a torn tail read and cut) off
                // the tick thread.
                let recorder = tokio::task::spawn_blocking(move || opening.open())
                    .await
                    .unwrap_or_else(|e| Err(e.to_string()));
                let operator = self.operator.clone();
                self.on_sim(move |s| {
                    s.adopt_recorder(recorder)?;
                    s.record_admin_edit(&operator, "record on");
                    Ok::<(), String>(())
                })
                .await?
                .map_err(io)?;
                Ok(AdminResponse::Ok)
            }
            AdminRequest::Record { on: false } => {
                let operator = self.operator.clone();
                self.on_sim(move |s| {
                    s.record_admin_edit(&operator, "record off");
                    s.stop_recording();
                })
                .await?;
                Ok(AdminResponse::Ok)
            }
            AdminRequest::Kick { client, reason } => {
                if self.shared.kicks.kick(*client, reason.clone()) {
                    Ok(AdminResponse::Ok)
                } else {
                    Err(AdminError::new(
                        AdminErrorKind::NotFound,
                        format!("no client {client} is connected"),
                    ))
                }
            }
            AdminRequest::Despawn { id } => {
                let edit = WorldEdit::Despawn { id: *id };
                self.edit(edit, format!("despawn {id}")).await?;
                Ok(AdminResponse::Ok)
            }
            AdminRequest::Impulse { id, impulse, point } => {
                let edit = WorldEdit::Impulse {
                    id: *id,
                    impulse: *impulse,
                    point: *point,
                };
                self.edit(edit, format!("impulse {id} {impulse:?} at {point:?}"))
                    .await?;
                Ok(AdminResponse::Ok)
            }
            AdminRequest::Spawn { desc } => {
                let what = format!(
                    "spawn {:?} {:?} at {:?}",
                    desc.kind, desc.name, desc.position
                );
                let edit = WorldEdit::Spawn { desc: desc.clone() };
                match self.edit(edit, what).await? {
                    EditOutcome::Spawned(id) => Ok(AdminResponse::Spawned { id }),
                    _ => Ok(AdminResponse::Ok),
                }
            }
        }
    }

    /// Carries out a clock request on the tick thread, by the same path
    /// as [`crate::sim::SimHandle`]'s clock methods.
    async fn control_clock(&self, request: ClockControl) -> Result<AdminResponse, AdminError> {
        self.on_sim(move |s| s.control_clock(request))
            .await?
            .map_err(|e| AdminError::new(AdminErrorKind::OutOfRange, e.to_string()))?;
        Ok(AdminResponse::Ok)
    }

    /// Runs a time-travel request on the tick thread; answers with the
    /// tick reached, its hash and the recorded one.
    async fn travel(
        &self,
        f: impl FnOnce(&mut Simulation) -> Result<SeekReport, TimeError> + Send + 'static,
    ) -> Result<AdminResponse, AdminError> {
        let report = self.on_sim(f).await?.map_err(time_error)?;
        Ok(AdminResponse::Hash {
            tick: report.tick,
            state_hash: report.state_hash,
            recorded_hash: report.recorded_hash,
        })
    }

    /// Applies a live edit on the tick thread, journaled and noted in the
    /// recording's audit trail.
    async fn edit(&self, edit: WorldEdit, what: String) -> Result<EditOutcome, AdminError> {
        let operator = self.operator.clone();
        self.on_sim(move |s| {
            let outcome = s.edit(edit);
            if outcome.is_ok() {
                s.record_admin_edit(&operator, &what);
            }
            outcome
        })
        .await?
        .map_err(|e| {
            let kind = match e {
                EditError::UnknownEntity(_) => AdminErrorKind::NotFound,
                EditError::NotLive { .. } => AdminErrorKind::Busy,
                _ => AdminErrorKind::Invalid,
            };
            AdminError::new(kind, e.to_string())
        })
    }
}

/// Runs file work on tokio's blocking pool, off the tick thread and the
/// I/O workers.
async fn blocking<R: Send + 'static>(
    f: impl FnOnce() -> R + Send + 'static,
) -> Result<R, AdminError> {
    tokio::task::spawn_blocking(f)
        .await
        .map_err(|e| AdminError::new(AdminErrorKind::Io, e.to_string()))
}

/// The admin error for a refused save or load.
fn checkpoint_error(e: CheckpointError) -> AdminError {
    AdminError::new(e.kind(), e.to_string())
}

/// The admin error for a kept match that could not be read.
fn matches_error(e: MatchesError) -> AdminError {
    let kind = match e {
        MatchesError::NotFound(_) => AdminErrorKind::NotFound,
        MatchesError::Io { .. } => AdminErrorKind::Io,
    };
    AdminError::new(kind, e.to_string())
}

/// The admin error for a refused time-travel request.
fn time_error(e: TimeError) -> AdminError {
    let kind = match e {
        TimeError::NoHistory | TimeError::NotRecorded { .. } => AdminErrorKind::NotRecorded,
        TimeError::InTheFuture { .. } | TimeError::BadRange { .. } => AdminErrorKind::OutOfRange,
        TimeError::State(_) | TimeError::World(_) => AdminErrorKind::Invalid,
    };
    AdminError::new(kind, e.to_string())
}

/// The status of the simulation now, read on the tick thread.
fn status_report(s: &mut Simulation) -> StatusReport {
    let wall_time_unix = SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0.0, |d| d.as_secs_f64());
    let clock = s.clock();
    StatusReport {
        tick: s.world().tick(),
        sim_time: s.world().time().max(0.0),
        wall_time_unix,
        time_scale: clock.time_scale(),
        achieved_rate: s.achieved_rate(),
        paused: clock.paused(),
        clients: s.client_count() as u32,
        bodies: s.world().bodies().count() as u32,
        tick_ms_p99: s.tick_p99().as_secs_f64() * 1000.0,
        state_hash: s.state_hash(),
        recording: s.recording(),
        live_tick: s.live_tick(),
        mode: s.mode(),
    }
}
