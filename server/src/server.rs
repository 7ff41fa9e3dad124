//! Starting and stopping a whole server: credentials, scene, simulation
//! thread, metrics endpoint and game port, in that order; and a clean stop
//! that tells every client why.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Duration;

use inertia_protocol::admin::MatchName;
use inertia_protocol::connection::ServerConnectionConfig;
use inertia_protocol::control::{truncate_utf8, DisconnectReason, MAX_REASON_BYTES};
use inertia_protocol::token::TokenKey;
use tokio::sync::watch;
use tokio::task::JoinHandle;
use tracing::{error, info, warn};

use crate::admin::tokens::{AdminTokenStore, TokenFileError};
use crate::admin::AdminShared;
use crate::config::ServerConfig;
use crate::credentials::{self, CredentialFiles, CredentialsError};
use crate::health::Health;
use crate::metrics::Metrics;
use crate::net::{self, ConnectTokens, NetShared, Streaming};
use crate::orchestrator::{Allocation, Orchestrator, Probe};
use crate::record::matches::MatchesDir;
use crate::replay::checkpoint::CheckpointDir;
use crate::rules::{GameRules, SandboxRules, SandboxSettings};
use crate::scene::{demo::DEMO_RON, Scene, SceneError, SceneFormat};
use crate::secrets::Secrets;
use crate::sim::resume::read_for_resume;
use crate::sim::{Frame, SimConfig, SimExit, SimHandle, Simulation};

/// Why the server could not start.
#[derive(Debug, thiserror::Error)]
pub enum StartError {
    /// The game's input is larger than the protocol carries.
    #[error("the game's input is {0} bytes, the most an input carries is {max}", max = inertia_protocol::input::MAX_INPUT_BYTES)]
    InputTooLarge(usize),
    /// The game's name is longer than a welcome carries.
    #[error("the game's name {0:?} is longer than {max} bytes", max = inertia_protocol::control::MAX_GAME_NAME_BYTES)]
    GameNameTooLong(String),
    /// The game's property schema breaks a bound of the protocol's.
    #[error(transparent)]
    Properties(#[from] inertia_protocol::property::PropertyError),
    /// The configuration is invalid.
    #[error("configuration: {0}")]
    Config(#[from] crate::config::ConfigError),
    /// Key or certificate missing or unreadable.
    #[error("credentials: {0}")]
    Credentials(#[from] CredentialsError),
    /// The admin token file is missing or wrong.
    #[error("{0}")]
    AdminTokens(#[from] TokenFileError),
    /// Dev mode was asked to listen beyond loopback.
    #[error(
        "dev mode (no --key-file / --cert-file) listens on loopback only, but --listen is {0}; \
         give a key and certificate to listen there"
    )]
    DevModeNotLoopback(SocketAddr),
    /// The scene file is bad.
    #[error("scene: {0}")]
    Scene(#[from] SceneError),
    /// The scene makes more rigid bodies than `--max-bodies`.
    #[error(
        "the scene makes {bodies} rigid bodies or more, past --max-bodies {max}: raise the \
         limit if the machine can step that many each tick"
    )]
    TooManyBodies {
        /// Rigid bodies the scene had made when it was refused: the one
        /// past the limit (the build stops there).
        bodies: usize,
        /// The limit.
        max: usize,
    },
    /// A socket could not be bound.
    #[error("{what} {addr}: {source}")]
    Bind {
        /// Which socket.
        what: &'static str,
        /// Its address.
        addr: SocketAddr,
        /// The cause.
        source: std::io::Error,
    },
    /// TLS could not be set up with the certificate.
    #[error("TLS: {0}")]
    Tls(String),
    /// The simulation thread could not start.
    #[error("simulation thread: {0}")]
    Thread(std::io::Error),
    /// The snapshot stage's thread could not start.
    #[error("snapshot thread: {0}")]
    SnapshotThread(std::io::Error),
    /// `--resume` found nothing usable to resume from.
    #[error("resume: {0}")]
    Resume(#[from] crate::sim::resume::ResumeError),
}

/// A running server.
pub struct RunningServer {
    addr: SocketAddr,
    metrics_addr: SocketAddr,
    credentials_path: Option<PathBuf>,
    admin_token: String,
    shared: Arc<NetShared>,
    shutdown: Arc<watch::Sender<Option<DisconnectReason>>>,
    health: Arc<Health>,
    endpoint: quinn::Endpoint,
    tasks: Vec<JoinHandle<()>>,
    orchestrator: Orchestrator,
    /// The secret files, outside dev mode.
    secrets: Option<Arc<Secrets>>,
    /// `--match-seconds`.
    match_length: Option<Duration>,
    /// The live recording, kept under the match's name when it ends.
    recording_dir: PathBuf,
}

impl std::fmt::Debug for RunningServer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("RunningServer")
            .field("addr", &self.addr)
            .field("metrics_addr", &self.metrics_addr)
            .finish_non_exhaustive()
    }
}

/// Starts a server with the sandbox rules.
pub async fn start(config: ServerConfig) -> Result<RunningServer, StartError> {
    start_with_rules(
        config,
        Box::new(SandboxRules::new(SandboxSettings::default())),
    )
    .await
}

/// Starts a server with the game's own `rules` on the built-in demo
/// scene unless the configuration names one.
pub async fn start_with_rules(
    config: ServerConfig,
    rules: Box<dyn GameRules>,
) -> Result<RunningServer, StartError> {
    start_game(config, rules, DEMO_RON).await
}

/// Starts a server with the game's own `rules`, on the scene the
/// configuration names or else on `default_scene` (a scene in RON, the
/// game's own: see [`crate::scene`]).
pub async fn start_game(
    config: ServerConfig,
    rules: Box<dyn GameRules>,
    default_scene: &str,
) -> Result<RunningServer, StartError> {
    config.validate()?;
    let listen = config.listen_addr();
    let dev = config.dev_mode();
    if dev && !listen.ip().is_loopback() {
        return Err(StartError::DevModeNotLoopback(listen));
    }
    // The scene first: a bad file is refused before anything is bound or
    // written.
    // Built once, under the body limit: a file that would make millions of
    // bodies is refused at the one past the limit.
    let world_config = config.world_config();
    let built = match &config.scene {
        Some(path) => Scene::read_file(path)?
            .build_with(world_config)
            .map_err(|e| e.in_file(path)),
        None => Scene::read(default_scene, SceneFormat::Ron)?.build_with(world_config),
    };
    let built = built.map_err(|e| match e.body_limit() {
        Some(max) => StartError::TooManyBodies {
            bodies: max + 1,
            max,
        },
        None => StartError::Scene(e),
    })?;
    let bodies = built.world.bodies().count();
    info!(scene = %built.name, entities = built.entities.len(), bodies, max_bodies = config.max_bodies, "scene built");
    info!(
        threads = built.world.config().threads,
        pinned_to = ?built.world.pinned_cores(),
        "physics threads"
    );

    let socket = std::net::UdpSocket::bind(listen).map_err(|source| StartError::Bind {
        what: "game port",
        addr: listen,
        source,
    })?;
    let addr = socket.local_addr().map_err(|source| StartError::Bind {
        what: "game port",
        addr: listen,
        source,
    })?;
    let files = CredentialFiles {
        key_file: config.key_file.clone(),
        cert_file: config.cert_file.clone(),
        cert_key_file: config.cert_key_file.clone(),
    };
    let (creds, credentials_path) = if dev {
        let (creds, path) = credentials::make_dev(&config.data_dir, addr)?;
        (creds, Some(path))
    } else {
        (credentials::load(&files)?, None)
    };

    let metrics = Metrics::new();
    let admin_tokens = Arc::new(AdminTokenStore::open(
        config.admin_token_file.clone(),
        creds.admin_token.clone(),
        metrics.clone(),
    )?);
    if admin_tokens.current().is_empty() {
        warn!(
            target: "inertia::admin",
            "the admin channel admits no one: give --admin-token-file to name its operators"
        );
    }
    let sim_config = SimConfig {
        metrics: Some(metrics.clone()),
        recording: Some(config.recorder_config()),
        record_at_start: config.record && !config.resume,
        ..SimConfig::from(&config)
    };
    let history_budget = sim_config.history_budget;
    let input_bytes = rules.input_bytes();
    let game = rules.name().to_string();
    if game.len() > inertia_protocol::control::MAX_GAME_NAME_BYTES {
        return Err(StartError::GameNameTooLong(game));
    }
    let message_limits = rules.message_limits();
    let properties = Arc::new(rules.properties());
    properties.validate().map_err(StartError::Properties)?;
    if input_bytes > inertia_protocol::input::MAX_INPUT_BYTES {
        return Err(StartError::InputTooLarge(input_bytes));
    }
    let mut simulation = Simulation::new(built, rules, sim_config);
    if config.resume {
        let plan = read_for_resume(&config.recording_dir(), history_budget)?;
        let report = simulation.resume(plan)?;
        for damage in &report.damage {
            warn!(
                file = %damage.path.display(),
                offset = damage.offset,
                why = %damage.why,
                "the recording is damaged here; left as it is"
            );
        }
        info!(
            keyframe = report.keyframe_tick,
            tick = report.tick,
            resimulated = report.resimulated,
            hashes_checked = report.hashes_checked,
            mismatches = report.mismatches,
            bytes_cut = report.bytes_cut(),
            damage = report.damage.len(),
            seconds = report.seconds,
            "resumed from the recording"
        );
        if config.record {
            if let Err(e) = simulation.start_recording() {
                error!(error = %e, "cannot record; running without a recording");
            }
        }
        // Nobody is connected after a restart.
        for client in report.clients {
            simulation.leave(client);
        }
    }
    let sim = Arc::new(SimHandle::run(simulation).map_err(StartError::Thread)?);

    let health = Arc::new(Health::new());
    let metrics_listener = tokio::net::TcpListener::bind(config.metrics)
        .await
        .map_err(|source| StartError::Bind {
            what: "metrics",
            addr: config.metrics,
            source,
        })?;
    let metrics_addr = metrics_listener
        .local_addr()
        .map_err(|source| StartError::Bind {
            what: "metrics",
            addr: config.metrics,
            source,
        })?;
    let mut tasks = Vec::new();
    {
        let (metrics, health) = (metrics.clone(), health.clone());
        let play = crate::play::PlayConfig {
            web_dir: crate::play::PlayConfig::find_web_dir(config.web_dir.as_deref()),
            dev_credentials: credentials_path.clone(),
            port: Some(metrics_addr.port()),
        };
        tasks.push(tokio::spawn(async move {
            if let Err(e) = crate::http::serve_on(metrics_listener, metrics, health, play).await {
                warn!(error = %e, "HTTP endpoint (metrics, health, page) stopped");
            }
        }));
    }

    let server_config = net::tls::server_config(&creds).map_err(StartError::Tls)?;
    let endpoint = quinn::Endpoint::new(
        quinn::EndpointConfig::default(),
        Some(server_config),
        socket,
        Arc::new(quinn::TokioRuntime),
    )
    .map_err(|source| StartError::Bind {
        what: "game port",
        addr,
        source,
    })?;
    let (shutdown, shutdown_rx) = watch::channel(None);
    let shutdown = Arc::new(shutdown);
    let snapshot = config.snapshot_config();
    let admin = AdminShared::new(
        sim.clone(),
        metrics.clone(),
        config.tick_hz,
        shutdown_rx.clone(),
        CheckpointDir::new(config.checkpoint_dir()),
        MatchesDir::new(config.matches_dir()),
    )
    .with_tokens(admin_tokens);
    let shared = Arc::new(
        NetShared::new(
            sim,
            metrics,
            ConnectTokens::new(TokenKey::from_bytes(creds.token_key), addr.to_string()),
            Streaming {
                snapshot,
                snapshot_hz: config.snapshot_hz,
                tick_hz: config.tick_hz,
                budget_bytes_per_sec: config.client_budget_bytes_per_sec(),
                properties,
                replays: config.replays(),
            },
            shutdown_rx,
            Arc::new(admin),
        )
        .with_frame_history(config.frame_history)
        .with_game(&game)
        .with_connection_config(ServerConnectionConfig {
            input_bytes: Some(input_bytes),
            messages: message_limits,
            ..config.connection
        }),
    );
    if config.frame_history > 0 {
        tasks.push(tokio::spawn(shared.clone().record_history()));
    }
    // Its own thread, below the tick thread's priority; it ends with the
    // shutdown.
    net::snapshots::spawn(shared.clone(), config.tick_realtime)
        .map_err(StartError::SnapshotThread)?;
    let gate = net::gate::GateConfig {
        retry_above_per_sec: config.retry_above_per_sec as usize,
        ..net::gate::GateConfig::default()
    };
    tasks.push(tokio::spawn(net::accept(
        endpoint.clone(),
        shared.clone(),
        gate,
    )));
    tasks.push(tokio::spawn(supervise(
        shared.sim.watch_exit(),
        health.clone(),
        shutdown.clone(),
    )));
    // Outside dev mode the secrets are read again when their files change
    // (and on SIGHUP, by the process).
    let secrets = (!dev).then(|| {
        Arc::new(Secrets::new(
            files,
            endpoint.clone(),
            shared.clone(),
            creds.fingerprint,
        ))
    });
    if let Some(secrets) = &secrets {
        tasks.push(tokio::spawn(secrets.clone().watch()));
    }
    health.set_ready(true);
    // Ready for the orchestrator too: the scene is built, the port bound.
    let orchestrator =
        Orchestrator::start(config.orchestrating(), probe(&shared, config.max_clients));
    tasks.push(tokio::spawn(apply_allocation(
        orchestrator.watch_allocation(),
        shared.clone(),
        config.scenes_dir.clone(),
        config.world_config(),
    )));
    info!(
        %addr,
        %metrics_addr,
        dev_mode = dev,
        credentials = ?credentials_path,
        tick_hz = config.tick_hz,
        snapshot_hz = config.snapshot_hz,
        "server ready"
    );
    let admin_token = creds.admin_token.clone().unwrap_or_default();
    if dev {
        tasks.push(tokio::spawn(renew_dev_certificate(
            creds,
            config.data_dir.clone(),
            addr,
            endpoint.clone(),
        )));
    }
    Ok(RunningServer {
        addr,
        metrics_addr,
        credentials_path,
        admin_token,
        shared,
        shutdown,
        health,
        endpoint,
        tasks,
        orchestrator,
        secrets,
        match_length: config.match_seconds.map(Duration::from_secs),
        recording_dir: config.recording_dir(),
    })
}

/// Renews a dev server's certificate a day before it expires, for as long
/// as the server runs: browsers pin it by hash only while it is valid for
/// at most 14 days. New connections get the new certificate; those
/// connected keep theirs.
async fn renew_dev_certificate(
    mut creds: credentials::Credentials,
    data_dir: PathBuf,
    addr: SocketAddr,
    endpoint: quinn::Endpoint,
) {
    let days = credentials::DEV_CERTIFICATE_DAYS - credentials::DEV_CERTIFICATE_RENEW_DAYS_BEFORE;
    let every = Duration::from_secs(days.unsigned_abs() * 86_400);
    loop {
        tokio::time::sleep(every).await;
        let renewed = credentials::renew_dev(&creds, &data_dir, addr).and_then(|renewed| {
            net::tls::server_config(&renewed)
                .map(|config| (renewed, config))
                .map_err(credentials::CredentialsError::Generate)
        });
        match renewed {
            Ok((renewed, config)) => {
                endpoint.set_server_config(Some(config));
                info!(
                    fingerprint = %inertia_protocol::credentials::to_hex(&renewed.fingerprint),
                    "dev certificate renewed"
                );
                creds = renewed;
            }
            Err(e) => warn!(error = %e, "the dev certificate could not be renewed"),
        }
    }
}

/// Under Agones, applies what an allocation asks for, before the match's
/// players join:
/// - the scene (`inertia.dev/scene`, a file in `--scenes-dir`) replaces the
///   one the server started with, as the admin's `load` replaces a world:
///   the recording starts a new session, and anyone already connected is
///   placed in the new world. Refused (logged, nothing changed) without a
///   scenes directory, or when the file does not build within the body
///   limit;
/// - then the whole settings go to the game rules
///   ([`GameRules::configure_match`]: the rules variant, the seed).
async fn apply_allocation(
    mut allocation: watch::Receiver<Option<Allocation>>,
    shared: Arc<NetShared>,
    scenes: Option<PathBuf>,
    world: inertia_physics::WorldConfig,
) {
    let settings = match allocation.wait_for(Option::is_some).await {
        Ok(a) => a.as_ref().map(|a| a.settings.clone()),
        Err(_) => None,
    };
    let Some(settings) = settings else { return };
    if let Some(scene) = &settings.scene {
        load_scene(&shared, scene, scenes, world).await;
    }
    let configured = shared.sim.call(move |sim| sim.configure_match(&settings));
    match configured {
        Ok(done) => match done.await {
            Ok(Ok(())) => info!("the match is configured"),
            Ok(Err(e)) => warn!(error = %e, "the game rules refused the match's settings"),
            Err(_) => {}
        },
        Err(e) => warn!(error = %e, "the match's settings could not be handed to the tick thread"),
    }
}

/// Loads `scene` from the `scenes` directory in place of the world (see
/// [`apply_allocation`]).
async fn load_scene(
    shared: &Arc<NetShared>,
    scene: &str,
    scenes: Option<PathBuf>,
    world: inertia_physics::WorldConfig,
) {
    let Some(dir) = scenes else {
        warn!(%scene, "the allocation asks for a scene, but no --scenes-dir is set; the scene the server started with plays");
        return;
    };
    let path = dir.join(scene);
    let built = tokio::task::spawn_blocking(move || {
        Scene::read_file(&path).and_then(|s| s.build_with(world).map_err(|e| e.in_file(&path)))
    })
    .await;
    let built = match built {
        Ok(Ok(built)) => built,
        Ok(Err(e)) => {
            warn!(%scene, error = %e, "the allocation's scene is refused; the scene the server started with plays");
            return;
        }
        Err(_) => return,
    };
    let (name, entities) = (built.name.clone(), built.entities.len());
    let loaded = shared
        .sim
        .call(move |sim| sim.load_scene(built, "allocation"));
    match loaded {
        Ok(done) => match done.await {
            Ok(Ok(_)) => info!(%scene, name = %name, entities, "the allocation's scene is loaded"),
            Ok(Err(e)) => {
                warn!(%scene, error = %e, "the allocation's scene did not load; the scene the server started with plays")
            }
            Err(_) => {}
        },
        Err(e) => {
            warn!(%scene, error = %e, "the allocation's scene could not be handed to the tick thread")
        }
    }
}

/// What the orchestrator reads of the server: the tick loop's turns and
/// the clients connected.
fn probe(shared: &Arc<NetShared>, capacity: u32) -> Probe {
    let (a, b) = (shared.clone(), shared.clone());
    Probe {
        loops: Arc::new(move || {
            a.sim
                .stats()
                .loops
                .load(std::sync::atomic::Ordering::Relaxed)
        }),
        players: Arc::new(move || {
            b.connected
                .lock()
                .map(|c| c.keys().copied().collect())
                .unwrap_or_default()
        }),
        capacity,
    }
}

/// Watches the tick thread. If it ever stops other than by a shutdown
/// (a panic in a tick, a command or an admin call), the server fails at
/// once: `/healthz` and `/readyz` answer 503 with the reason, every client
/// gets a goodbye saying the simulation stopped, and
/// [`RunningServer::failed`] returns the reason (the process then exits
/// non-zero so an orchestrator restarts it; `--resume` carries on from the
/// recording).
async fn supervise(
    mut exit: watch::Receiver<Option<SimExit>>,
    health: Arc<Health>,
    shutdown: Arc<watch::Sender<Option<DisconnectReason>>>,
) {
    let outcome = match exit.wait_for(Option::is_some).await {
        Ok(e) => e.clone(),
        // The handle is gone: the server itself is being dropped.
        Err(_) => return,
    };
    let Some(SimExit::Failed {
        reason,
        tick,
        keyframe,
    }) = outcome
    else {
        return;
    };
    let what = format!("the simulation stopped at tick {tick}: {reason}");
    error!(%reason, tick, keyframe, "the simulation failed; failing health checks and stopping");
    // Clients are told first: a failure makes the process shut down, and
    // the shutdown tells them whatever reason is set by then.
    let mut told = what.clone();
    truncate_utf8(&mut told, MAX_REASON_BYTES);
    stop_clients(
        &shutdown,
        DisconnectReason::SimulationStopped { reason: told },
    );
    health.fail(what);
}

/// Tells every connection to end with `reason`, unless one was given
/// already (the first reason is what clients hear).
fn stop_clients(shutdown: &watch::Sender<Option<DisconnectReason>>, reason: DisconnectReason) {
    shutdown.send_if_modified(|r| {
        if r.is_some() {
            return false;
        }
        *r = Some(reason);
        true
    });
}

impl RunningServer {
    /// The game port's address.
    pub fn addr(&self) -> SocketAddr {
        self.addr
    }

    /// The metrics and health endpoint's address.
    pub fn metrics_addr(&self) -> SocketAddr {
        self.metrics_addr
    }

    /// The dev credentials file, in dev mode.
    pub fn credentials_path(&self) -> Option<&PathBuf> {
        self.credentials_path.as_ref()
    }

    /// The dev admin credential, which admits any operator name (empty
    /// outside dev mode, where operators' tokens come from the admin token
    /// file).
    pub fn admin_token(&self) -> &str {
        &self.admin_token
    }

    /// The admin credentials in use (a handle the process's SIGHUP
    /// handler keeps to reload them).
    pub fn admin_tokens(&self) -> Arc<AdminTokenStore> {
        self.shared.admin.tokens.clone()
    }

    /// Reads the admin token file again: a good file replaces the
    /// operators for every hello from now on (admitted sessions stay); a
    /// bad one is logged and the operators in use stay. What SIGHUP does.
    /// Blocking (it reads a file).
    pub fn reload_admin_tokens(&self) -> Result<usize, TokenFileError> {
        self.shared.admin.tokens.reload()
    }

    /// The server's secret files and their reload (outside dev mode):
    /// what SIGHUP does, and what a change to the files does by itself.
    pub fn secrets(&self) -> Option<Arc<Secrets>> {
        self.secrets.clone()
    }

    /// Where `save` and `load` keep checkpoints.
    pub fn checkpoints(&self) -> &CheckpointDir {
        &self.shared.admin.checkpoints
    }

    /// The simulation.
    pub fn sim(&self) -> &SimHandle {
        &self.shared.sim
    }

    /// The latest frame.
    pub fn frame(&self) -> Arc<Frame> {
        self.shared.sim.frame()
    }

    /// The frame of `tick`, if it is among the last
    /// [`ServerConfig::frame_history`] (none are kept by default).
    pub fn frame_at(&self, tick: u64) -> Option<Arc<Frame>> {
        self.shared.frame_at(tick)
    }

    /// Metrics handles.
    pub fn metrics(&self) -> &Metrics {
        &self.shared.metrics
    }

    /// Whether the server has failed (the tick thread stopped), and why.
    pub fn failure(&self) -> Option<String> {
        self.health.failure()
    }

    /// Waits until the server fails (the tick thread stopped other than by
    /// a shutdown) and returns why; never returns while it works.
    pub async fn failed(&self) -> String {
        self.health.failed().await
    }

    /// The match the orchestrator allocated this server for, once it has
    /// (Agones; never standalone).
    pub fn allocation(&self) -> Option<Allocation> {
        self.orchestrator.allocation()
    }

    /// Waits until the match is over and says why: the game rules ended
    /// it ([`crate::rules::GameRules::match_over`]), or its length passed
    /// (`--match-seconds`, or the allocation's). Never returns for a
    /// match with neither. The process then ends it with
    /// [`RunningServer::end_match`].
    pub async fn match_over(&self) -> String {
        let mut rules = self.shared.sim.match_over();
        let ended_by_rules = async {
            match rules.wait_for(Option::is_some).await {
                Ok(why) => why.clone().unwrap_or_default(),
                Err(_) => std::future::pending().await,
            }
        };
        tokio::select! {
            why = ended_by_rules => why,
            () = self.orchestrator.match_over(self.match_length) => {
                "the match's time is up".to_string()
            }
        }
    }

    /// Ends the match: every client is told `MatchOver` with `reason`,
    /// then the server shuts down as [`RunningServer::shutdown`] does, and
    /// the match's recording, ended, is kept under its own name in the
    /// matches directory ([`crate::record::matches`]). Returns that name
    /// (`None` without a recording).
    pub async fn end_match(self, reason: String) -> Option<MatchName> {
        let mut told = reason;
        truncate_utf8(&mut told, MAX_REASON_BYTES);
        info!(reason = %told, "the match is over; draining");
        stop_clients(&self.shutdown, DisconnectReason::MatchOver { reason: told });
        self.drain().await;
        // Kept before the orchestrator hears of the end: under Agones,
        // Shutdown deletes the pod, and a copy to a shared volume must be
        // done by then.
        let (matches, recording) = (
            self.shared.admin.matches.clone(),
            self.recording_dir.clone(),
        );
        let now = crate::net::admission::unix_now();
        let kept = match tokio::task::spawn_blocking(move || matches.keep(&recording, now)).await {
            Ok(Ok(Some(name))) => {
                info!(%name, "the match's recording is kept");
                Some(name)
            }
            Ok(Ok(None)) => None,
            Ok(Err(e)) => {
                warn!(error = %e, "the match's recording could not be kept under its name; it stays where it was");
                None
            }
            Err(_) => None,
        };
        self.orchestrator.shutdown().await;
        info!("stopped");
        kept
    }

    /// Clients connected now.
    pub fn clients(&self) -> usize {
        self.shared.connected.lock().map_or(0, |c| c.len())
    }

    /// Stops accepting, tells every client the server is shutting down,
    /// closes their connections (the admin channel's too, dropping any
    /// call in flight), stops the simulation, which ends the recording
    /// with a keyframe, and returns within [`SHUTDOWN_DEADLINE`] whatever
    /// an admin call or the tick thread is doing: a tick thread that has
    /// not stopped by then is left behind (logged) to end with the
    /// process.
    pub async fn shutdown(self) {
        self.drain().await;
        // Last: under Agones, Shutdown deletes the pod.
        self.orchestrator.shutdown().await;
        info!("stopped");
    }

    /// [`RunningServer::shutdown`] but for telling the orchestrator.
    async fn drain(&self) {
        info!("shutting down");
        let deadline = tokio::time::Instant::now() + SHUTDOWN_DEADLINE;
        self.health.set_ready(false);
        // A failure's reason, if one came first, is what clients are told.
        stop_clients(&self.shutdown, DisconnectReason::ServerShutdown);
        let drained = tokio::time::Instant::now() + CLIENT_DRAIN;
        while self.clients() > 0 && tokio::time::Instant::now() < drained {
            tokio::time::sleep(Duration::from_millis(20)).await;
        }
        self.endpoint.close(
            net::connection::close_code::SHUTDOWN.into(),
            b"server shutting down",
        );
        let _ = tokio::time::timeout(ENDPOINT_IDLE, self.endpoint.wait_idle()).await;
        for task in &self.tasks {
            task.abort();
        }
        // The tick thread ends the recording with a keyframe of the last
        // tick, on disk before the process exits; it has what is left of
        // the deadline (at least SHUTDOWN_DEADLINE - CLIENT_DRAIN -
        // ENDPOINT_IDLE).
        let left = deadline.saturating_duration_since(tokio::time::Instant::now());
        if !self.shared.sim.stop_within(left).await {
            error!(
                deadline_s = SHUTDOWN_DEADLINE.as_secs(),
                "the tick thread did not stop within the shutdown deadline and is abandoned; \
                 the recording may lack its last keyframe (a resume starts from the last one \
                 on disk)"
            );
        }
    }
}

/// The longest [`RunningServer::shutdown`] takes.
pub const SHUTDOWN_DEADLINE: Duration = Duration::from_secs(10);
/// How long clients told of the shutdown have to leave.
const CLIENT_DRAIN: Duration = Duration::from_secs(3);
/// How long closed connections have to say goodbye.
const ENDPOINT_IDLE: Duration = Duration::from_secs(2);
