//! `inertia-admin`: an operator's commands to a running server over the
//! admin channel, and offline tools for recording directories
//! (`replay-file`, see [`replay_file`]). Against a dev-mode server it
//! reads the dev credentials file; against any other it takes the
//! server's address (`--server`), its certificate (`--cert-file` or
//! `--fingerprint`) and the operator's token (`--token-file`, or
//! `INERTIA_ADMIN_TOKEN`), reading the credentials file only for what
//! these do not give. Prints for people, or one JSON object per command
//! with `--json`. Exits 0 when the server did what was asked, 1 when it
//! answered with an error (or a recording is damaged or does not
//! re-simulate), 2 when it could not be reached, refused the credential or
//! the command was misused.

mod replay_file;

use std::net::SocketAddr;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use clap::{Parser, Subcommand};
use inertia_admin_client::{
    cert_file_fingerprint, read_credentials, read_token_file, AdminClient, AdminClientError,
};
use inertia_protocol::admin::{
    AdminRequest, AdminResponse, CheckpointName, MatchName, SpawnDesc, StatusReport,
};
use inertia_protocol::credentials::{hex32, DevCredentials, DEV_CREDENTIALS_PATH};
use inertia_server::admin::error_kind_name;
use serde_json::json;

/// Administer a running Inertia server.
#[derive(Debug, Parser)]
#[command(name = "inertia-admin", version)]
struct Args {
    /// The server's game port (default: the address in the credentials
    /// file).
    #[arg(long, value_name = "ADDR")]
    server: Option<SocketAddr>,
    /// The dev credentials file (server address, certificate fingerprint,
    /// admin credential), read for whatever --server, --cert-file or
    /// --fingerprint, and --token-file do not give.
    #[arg(long, value_name = "FILE", default_value = DEV_CREDENTIALS_PATH)]
    credentials: PathBuf,
    /// The server's TLS certificate (PEM or DER), pinned by its SHA-256
    /// (default: the fingerprint in the credentials file).
    #[arg(long, value_name = "FILE", conflicts_with = "fingerprint")]
    cert_file: Option<PathBuf>,
    /// The SHA-256 of the server certificate's DER, 64 hex digits.
    #[arg(long, value_name = "HEX")]
    fingerprint: Option<String>,
    /// This operator's admin token: a file whose first line is
    /// `OPERATOR TOKEN` (the operator's line of the server's
    /// --admin-token-file; it also gives the name) or the token alone.
    /// Without it, the token in INERTIA_ADMIN_TOKEN, else the credentials
    /// file's.
    #[arg(long, value_name = "FILE")]
    token_file: Option<PathBuf>,
    /// Who is acting: the operator name the token belongs to, and what the
    /// server's audit log records (default: the token file's name, else
    /// $USER).
    #[arg(long)]
    operator: Option<String>,
    /// Print one JSON object instead of text.
    #[arg(long, global = true)]
    json: bool,
    #[command(subcommand)]
    command: Cmd,
}

#[derive(Debug, Subcommand)]
enum Cmd {
    /// The server's tick, clocks, clients, bodies and state hash.
    Status,
    /// Stop running ticks.
    Pause,
    /// Run ticks again at the time scale before the pause.
    Resume,
    /// Run exactly N ticks (at most an hour of simulation), then stay
    /// paused.
    Step {
        /// How many ticks.
        n: u64,
    },
    /// Run at X simulated seconds per wall second (0 < X ≤ 64); reports
    /// the rate reached over the next second.
    Speed {
        /// The time scale.
        x: f64,
    },
    /// Run until TICK (at most an hour of simulation ahead), then pause.
    RunTo {
        /// The tick to stop at.
        tick: u64,
    },
    /// Jump to a recorded tick and pause there.
    Seek {
        /// The tick.
        tick: u64,
    },
    /// Play the recording backwards.
    Reverse {
        /// Time scale (1 is real time).
        #[arg(long, default_value_t = 1.0)]
        speed: f64,
    },
    /// Play recorded ticks FROM..=TO to the clients.
    Replay {
        /// The first tick.
        from: u64,
        /// The last tick.
        to: u64,
        /// Time scale (1 is real time).
        #[arg(long, default_value_t = 1.0)]
        speed: f64,
    },
    /// Save the world as a checkpoint in the server's checkpoint
    /// directory (its --checkpoint-dir).
    Save {
        /// The checkpoint's name: letters, digits, `.`, `_` and `-`, not
        /// starting with `.` (a name in that directory, not a path).
        name: String,
        /// Replace a checkpoint already saved under that name.
        #[arg(long)]
        overwrite: bool,
    },
    /// Load the world from a checkpoint in the server's checkpoint
    /// directory.
    Load {
        /// The checkpoint's name.
        name: String,
    },
    /// Start or stop recording.
    Record {
        /// `on` or `off`.
        #[arg(value_parser = ["on", "off"])]
        state: String,
    },
    /// Add a body, described as JSON (the admin protocol's `SpawnDesc`).
    Spawn {
        /// The body, as JSON.
        desc: String,
    },
    /// Remove an entity.
    Despawn {
        /// The entity id.
        id: u32,
    },
    /// Apply an impulse (N·s, world frame) to a body.
    Impulse {
        /// The entity id.
        id: u32,
        /// x component.
        #[arg(allow_negative_numbers = true)]
        x: f64,
        /// y component.
        #[arg(allow_negative_numbers = true)]
        y: f64,
        /// z component.
        #[arg(allow_negative_numbers = true)]
        z: f64,
        /// Where it acts (m, world; default the centre of mass).
        #[arg(long, num_args = 3, value_names = ["X", "Y", "Z"], allow_negative_numbers = true)]
        at: Option<Vec<f64>>,
    },
    /// Disconnect a client.
    Kick {
        /// The client id.
        client: u64,
        /// Why, shown to the player.
        #[arg(long, default_value = "kicked by an operator")]
        reason: String,
    },
    /// The state hash at TICK (default: now).
    Hash {
        /// The tick.
        tick: Option<u64>,
    },
    /// The finished matches whose recordings the server keeps
    Matches,
    /// Copy a kept match's recording here, to replay or verify offline
    /// (`replay-file verify DIR`)
    FetchRecording {
        /// The match (as `matches` lists it).
        name: String,
        /// Where to put it (default: ./NAME); must not exist yet.
        #[arg(long)]
        out: Option<PathBuf>,
    },
    /// Offline tools for a recording directory (no server needed).
    #[command(subcommand)]
    ReplayFile(replay_file::ReplayFileCmd),
}

/// A failure, with the exit code it gives.
struct Failure {
    /// The exit status: 1 for a server or data error, 2 for misuse or an
    /// unreachable server.
    code: u8,
    /// A short machine-readable name (`--json`'s `error.kind`).
    kind: &'static str,
    /// What happened, for people.
    message: String,
}

impl Failure {
    /// Reports the failure (a JSON error object on stdout with `--json`,
    /// the message on stderr always) and gives its exit status.
    fn report(&self, json: bool) -> ExitCode {
        if json {
            println!(
                "{}",
                json!({ "error": { "kind": self.kind, "message": self.message } })
            );
        }
        eprintln!("inertia-admin: {}", self.message);
        ExitCode::from(self.code)
    }
}

impl From<AdminClientError> for Failure {
    fn from(e: AdminClientError) -> Self {
        let kind = match e {
            AdminClientError::Refused(_) => "refused",
            AdminClientError::Credentials { .. } => "credentials",
            _ => "connection",
        };
        Failure {
            code: 2,
            kind,
            message: e.to_string(),
        }
    }
}

fn request(cmd: &Cmd) -> Result<AdminRequest, Failure> {
    let usage = |message: String| Failure {
        code: 2,
        kind: "usage",
        message,
    };
    Ok(match cmd {
        Cmd::Status => AdminRequest::Status,
        Cmd::Pause => AdminRequest::Pause,
        Cmd::Resume => AdminRequest::Resume,
        Cmd::Step { n } => AdminRequest::Step { ticks: *n },
        Cmd::Speed { x } => AdminRequest::Speed { scale: *x },
        Cmd::RunTo { tick } => AdminRequest::RunTo { tick: *tick },
        Cmd::Seek { tick } => AdminRequest::Seek { tick: *tick },
        Cmd::Reverse { speed } => AdminRequest::Reverse { speed: *speed },
        Cmd::Replay { from, to, speed } => AdminRequest::Replay {
            from: *from,
            to: *to,
            speed: *speed,
        },
        Cmd::Save { name, overwrite } => AdminRequest::Save {
            name: checkpoint_name(name).map_err(usage)?,
            overwrite: *overwrite,
        },
        Cmd::Load { name } => AdminRequest::Load {
            name: checkpoint_name(name).map_err(usage)?,
        },
        Cmd::Record { state } => AdminRequest::Record { on: state == "on" },
        Cmd::Spawn { desc } => {
            let desc: SpawnDesc =
                serde_json::from_str(desc).map_err(|e| usage(format!("spawn description: {e}")))?;
            AdminRequest::Spawn { desc }
        }
        Cmd::Despawn { id } => AdminRequest::Despawn { id: *id },
        Cmd::Impulse { id, x, y, z, at } => AdminRequest::Impulse {
            id: *id,
            impulse: [*x, *y, *z],
            point: at.as_ref().map(|p| [p[0], p[1], p[2]]),
        },
        Cmd::Kick { client, reason } => AdminRequest::Kick {
            client: *client,
            reason: reason.clone(),
        },
        Cmd::Hash { tick } => AdminRequest::Hash { tick: *tick },
        Cmd::Matches => AdminRequest::Matches,
        Cmd::FetchRecording { name, .. } => AdminRequest::FetchRecording {
            name: MatchName::new(name.as_str())
                .map_err(|e| usage(format!("match {name:?}: {e}")))?,
            file: 0,
            offset: 0,
        },
        Cmd::ReplayFile(_) => {
            return Err(usage("replay-file works offline, not on a server".into()))
        }
    })
}

/// A checkpoint name, or why `name` is not one.
fn checkpoint_name(name: &str) -> Result<CheckpointName, String> {
    CheckpointName::new(name).map_err(|e| format!("checkpoint {name:?}: {e}"))
}

fn status_json(s: &StatusReport) -> serde_json::Value {
    json!({
        "tick": s.tick,
        "sim_time": s.sim_time,
        "wall_time_unix": s.wall_time_unix,
        "time_scale": s.time_scale,
        "achieved_rate": s.achieved_rate,
        "paused": s.paused,
        "clients": s.clients,
        "bodies": s.bodies,
        "tick_ms_p99": s.tick_ms_p99,
        "state_hash": s.state_hash,
        "recording": s.recording,
        "live_tick": s.live_tick,
        "mode": s.mode.name(),
    })
}

fn status_text(s: &StatusReport, tick_hz: u32) -> String {
    format!(
        "tick {} (sim time {:.3} s)\n\
         mode {}, live tick {}\n\
         time scale {} ({}), achieved {:.1} ticks/s ({:.2}×)\n\
         clients {}, bodies {}\n\
         tick p99 {:.3} ms\n\
         state hash {:016x}\n\
         recording {}",
        s.tick,
        s.sim_time,
        s.mode.name(),
        s.live_tick,
        s.time_scale,
        if s.paused { "paused" } else { "running" },
        s.achieved_rate,
        s.achieved_rate / f64::from(tick_hz.max(1)),
        s.clients,
        s.bodies,
        s.tick_ms_p99,
        s.state_hash,
        if s.recording { "on" } else { "off" },
    )
}

/// Runs one command; the JSON object and the text to print.
async fn run(args: &Args) -> Result<(serde_json::Value, String), Failure> {
    let request = request(&args.command)?;
    request.check().map_err(|e| Failure {
        code: 2,
        kind: "usage",
        message: e.to_string(),
    })?;
    let mut client = connect(args).await?;
    let tick_hz = client.welcome().tick_hz;
    if let (Cmd::FetchRecording { name, out }, AdminRequest::FetchRecording { name: m, .. }) =
        (&args.command, &request)
    {
        let out = out.clone().unwrap_or_else(|| PathBuf::from(name));
        let fetched = fetch_recording(&mut client, m, &out).await;
        client.close().await;
        return fetched;
    }
    let response = client.call(request.clone()).await?;
    let out = match response {
        AdminResponse::Error(e) => {
            client.close().await;
            return Err(Failure {
                code: 1,
                kind: error_kind_name(e.kind),
                message: e.message,
            });
        }
        AdminResponse::Status(s) => (status_json(&s), status_text(&s, tick_hz)),
        AdminResponse::Hash {
            tick,
            state_hash,
            recorded_hash,
        } => hash_output(&args.command, tick, state_hash, recorded_hash),
        AdminResponse::Spawned { id } => (
            json!({ "ok": true, "spawned": id }),
            format!("spawned entity {id}"),
        ),
        AdminResponse::Matches(list) => (
            json!({ "matches": list.iter().map(|m| json!({
                "name": m.name.as_str(), "files": m.files, "bytes": m.bytes,
            })).collect::<Vec<_>>() }),
            if list.is_empty() {
                "no finished match kept".to_string()
            } else {
                list.iter()
                    .map(|m| format!("{}  {} files, {} bytes", m.name, m.files, m.bytes))
                    .collect::<Vec<_>>()
                    .join("\n")
            },
        ),
        AdminResponse::RecordingPart { .. } => {
            (json!({ "ok": true }), "a part of a recording".to_string())
        }
        AdminResponse::Ok => match &args.command {
            Cmd::Speed { x } => {
                // The rate is a second's average: give the new speed a
                // second to show.
                tokio::time::sleep(Duration::from_millis(1100)).await;
                match client.call(AdminRequest::Status).await? {
                    AdminResponse::Status(s) => {
                        let achieved_scale = s.achieved_rate / f64::from(tick_hz.max(1));
                        (
                            json!({
                                "ok": true,
                                "time_scale": s.time_scale,
                                "requested": x,
                                "achieved_rate": s.achieved_rate,
                                "achieved_scale": achieved_scale,
                            }),
                            format!(
                                "time scale {}; achieved {:.1} ticks/s ({achieved_scale:.2}×)",
                                s.time_scale, s.achieved_rate
                            ),
                        )
                    }
                    _ => (json!({ "ok": true }), format!("time scale {x}")),
                }
            }
            cmd => (json!({ "ok": true }), done_text(cmd)),
        },
    };
    client.close().await;
    Ok(out)
}

/// The environment variable that may hold the operator's admin token.
const TOKEN_ENV: &str = "INERTIA_ADMIN_TOKEN";

/// Connects as the options say: each of the address, the fingerprint and
/// the token from its option, else from the dev credentials file (read
/// only when one is missing).
async fn connect(args: &Args) -> Result<AdminClient, Failure> {
    let mut dev: Option<DevCredentials> = None;
    let mut dev_file = || -> Result<DevCredentials, AdminClientError> {
        if dev.is_none() {
            dev = Some(read_credentials(&args.credentials)?);
        }
        Ok(dev.clone().expect("just read"))
    };
    let bad = |path: &std::path::Path, why: String| AdminClientError::Credentials {
        path: path.display().to_string(),
        why,
    };
    let mut operator = args.operator.clone();
    let token = match (&args.token_file, std::env::var(TOKEN_ENV)) {
        (Some(path), _) => {
            let file = read_token_file(path)?;
            operator = operator.or(file.operator);
            file.token
        }
        (None, Ok(token)) if !token.trim().is_empty() => token.trim().to_string(),
        _ => dev_file()?.admin_token,
    };
    let fingerprint = match (&args.cert_file, &args.fingerprint) {
        (Some(path), _) => cert_file_fingerprint(path)?,
        (None, Some(hex)) => hex32("fingerprint", hex).map_err(|e| Failure {
            code: 2,
            kind: "usage",
            message: format!("--fingerprint: {e}"),
        })?,
        (None, None) => {
            let creds = dev_file()?;
            creds
                .fingerprint()
                .map_err(|e| bad(&args.credentials, e.to_string()))?
        }
    };
    let addr = match args.server {
        Some(a) => a,
        None => {
            let creds = dev_file()?;
            creds
                .server_addr
                .parse()
                .map_err(|e| bad(&args.credentials, format!("server_addr: {e}")))?
        }
    };
    let operator = operator
        .or_else(|| std::env::var("USER").ok())
        .unwrap_or_else(|| "operator".into());
    Ok(AdminClient::connect(addr, fingerprint, &token, &operator).await?)
}

/// What a [`AdminResponse::Hash`] prints: for `hash`, the tick and its
/// hashes; for `seek`, `replay` and `load` (which answer with the tick
/// they reached), the same object plus `matches` (whether the state hash
/// equals the recorded one; null when nothing was recorded for the tick).
fn hash_output(
    cmd: &Cmd,
    tick: u64,
    state_hash: u64,
    recorded_hash: Option<u64>,
) -> (serde_json::Value, String) {
    let mut value =
        json!({ "tick": tick, "state_hash": state_hash, "recorded_hash": recorded_hash });
    let reached = match cmd {
        Cmd::Seek { .. } => "at",
        Cmd::Replay { .. } => "replaying from",
        Cmd::Load { .. } => "loaded",
        _ => {
            let text = match recorded_hash {
                Some(r) => format!(
                    "tick {tick}: state hash {state_hash:016x}, recorded {r:016x}{}",
                    if r == state_hash { "" } else { " (differs)" }
                ),
                None => format!("tick {tick}: state hash {state_hash:016x}"),
            };
            return (value, text);
        }
    };
    let matches = recorded_hash.map(|r| r == state_hash);
    value["matches"] = json!(matches);
    let verdict = match (recorded_hash, matches) {
        (Some(r), Some(true)) => format!("recorded {r:016x}: matches"),
        (Some(r), _) => format!("recorded {r:016x}: DIFFERS"),
        (None, _) => "no recorded hash to compare".to_string(),
    };
    (
        value,
        format!("{reached} tick {tick}: state hash {state_hash:016x}, {verdict}"),
    )
}

/// Copies match `name`'s recording into the new directory `out`, file by
/// file, part by part; the JSON object and the text to print.
async fn fetch_recording(
    client: &mut AdminClient,
    name: &MatchName,
    out: &std::path::Path,
) -> Result<(serde_json::Value, String), Failure> {
    let failed = |code, kind, message: String| Failure {
        code,
        kind,
        message,
    };
    std::fs::create_dir(out).map_err(|e| {
        failed(
            1,
            "io",
            format!("{}: {e} (it must not exist yet)", out.display()),
        )
    })?;
    let (mut file, mut offset, mut bytes, mut files) = (0u32, 0u64, 0u64, 1u32);
    let mut writer: Option<std::fs::File> = None;
    while file < files {
        let request = AdminRequest::FetchRecording {
            name: name.clone(),
            file,
            offset,
        };
        match client.call(request).await? {
            AdminResponse::RecordingPart {
                files: total,
                file_name,
                file_len,
                offset: at,
                data,
            } => {
                files = total;
                if at != offset {
                    return Err(failed(
                        1,
                        "protocol",
                        format!("asked for byte {offset}, got {at}"),
                    ));
                }
                // The name is checked by the protocol: a plain file name.
                let w = match writer.as_mut() {
                    Some(w) => w,
                    None => writer.insert(
                        std::fs::File::create_new(out.join(&file_name))
                            .map_err(|e| failed(1, "io", format!("{file_name}: {e}")))?,
                    ),
                };
                use std::io::Write;
                w.write_all(&data)
                    .map_err(|e| failed(1, "io", format!("{file_name}: {e}")))?;
                offset += data.len() as u64;
                bytes += data.len() as u64;
                if offset >= file_len || data.is_empty() {
                    writer = None;
                    file += 1;
                    offset = 0;
                }
            }
            AdminResponse::Error(e) => {
                return Err(failed(1, error_kind_name(e.kind), e.message));
            }
            other => {
                return Err(failed(
                    1,
                    "protocol",
                    format!("unexpected answer {other:?}"),
                ));
            }
        }
    }
    Ok((
        json!({ "ok": true, "match": name.as_str(), "files": files, "bytes": bytes, "out": out.display().to_string() }),
        format!(
            "fetched {name}: {files} files, {bytes} bytes into {}",
            out.display()
        ),
    ))
}

fn done_text(cmd: &Cmd) -> String {
    match cmd {
        Cmd::Pause => "paused".into(),
        Cmd::Resume => "resumed".into(),
        Cmd::Step { n } => format!("stepping {n} ticks"),
        Cmd::RunTo { tick } => format!("running to tick {tick}"),
        Cmd::Despawn { id } => format!("despawned entity {id}"),
        Cmd::Impulse { id, .. } => format!("impulse applied to entity {id}"),
        Cmd::Kick { client, .. } => format!("kicked client {client}"),
        Cmd::Save { name, .. } => format!("saved checkpoint {name}"),
        _ => "done".into(),
    }
}

fn main() -> ExitCode {
    let args = Args::parse();
    if let Cmd::ReplayFile(cmd) = &args.command {
        return replay_file::run(cmd, args.json);
    }
    let runtime = match tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
    {
        Ok(r) => r,
        Err(e) => {
            eprintln!("inertia-admin: cannot start the runtime: {e}");
            return ExitCode::from(2);
        }
    };
    match runtime.block_on(run(&args)) {
        Ok((json, text)) => {
            if args.json {
                println!("{json}");
            } else {
                println!("{text}");
            }
            ExitCode::SUCCESS
        }
        Err(f) => f.report(args.json),
    }
}
