//! The connection to a server: QUIC with the certificate pinned by the
//! connect token, the hello on the control stream, then a background task
//! that decodes snapshots into the interpolation buffer, keeps the entity
//! table, and sends inputs with acknowledgements.

mod driver;

use std::net::SocketAddr;
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use inertia_protocol::connection::{
    ClientConnection, ClientConnectionConfig, ClientConnectionEnd, ClientConnectionEvent,
};
use inertia_protocol::control::{DisconnectReason, Refusal, PROTOCOL_VERSION};
use inertia_protocol::input::{GameInput, InputPayload, MAX_REDUNDANT_INPUTS};
use inertia_protocol::message::{
    check_len, Delivery, GameMessage, MessageDatagram, MessageRefusal,
};
use inertia_protocol::property::{PropertySchema, PropertyValue};
use inertia_protocol::token::ConnectToken;
use inertia_protocol::{ClientConfig, ClientSession, EntityId};
use inertia_sandbox::SandboxInput;
use tokio::sync::mpsc;

pub use driver::ClientEvent;
use driver::{ClientShared, DriverCommand};

/// What the server said about itself when it welcomed us (the
/// protocol's).
pub use inertia_protocol::connection::ServerInfo;
/// How long the handshake may take before [`ClientError::Timeout`] (the
/// protocol's).
pub use inertia_protocol::connection::HANDSHAKE_TIMEOUT;

/// Why a connection failed or ended.
#[derive(Debug, thiserror::Error)]
pub enum ClientError {
    /// A local socket could not be opened.
    #[error("local socket: {0}")]
    Io(#[from] std::io::Error),
    /// The TLS configuration could not be built.
    #[error("TLS set-up: {0}")]
    Tls(String),
    /// QUIC refused to start the connection.
    #[error("connect: {0}")]
    Connect(#[from] quinn::ConnectError),
    /// The connection failed or closed.
    #[error("connection: {0}")]
    Connection(#[from] quinn::ConnectionError),
    /// The server speaks another protocol version.
    #[error("protocol version mismatch: the server speaks {server}, this client {client}")]
    VersionMismatch {
        /// The server's version.
        server: u16,
        /// Ours.
        client: u16,
    },
    /// The server refused the hello.
    #[error("refused by the server: {0:?}")]
    Refused(Refusal),
    /// The server broke the protocol.
    #[error("protocol error: {0}")]
    Protocol(String),
    /// The prediction settings were refused (see
    /// [`ConnectOptions::predict`]).
    #[error("prediction: {0}")]
    Prediction(#[from] crate::predict::PredictionError),
    /// The server did not answer in time.
    #[error("the server did not answer within {0:?}")]
    Timeout(Duration),
    /// The game's input is not the size of the server's game's: this
    /// client plays another game.
    #[error("inputs of {ours} bytes, the server's game takes {server}")]
    InputSize {
        /// This client's, bytes.
        ours: usize,
        /// The server's, bytes.
        server: usize,
    },
    /// A message that cannot be sent: too long, or the connection has
    /// ended (nothing was sent).
    #[error("message not sent: {0}")]
    Message(#[from] MessageRefusal),
    /// A replay that cannot be asked for: its stretch is empty, its speed
    /// out of range, or the connection has ended (nothing was sent).
    #[error("replay not asked for: {0}")]
    Replay(#[from] inertia_protocol::replay::ReplayRefusal),
}

/// Options of [`Client::connect_with`].
#[derive(Debug, Clone)]
pub struct ConnectOptions {
    /// The protocol version announced in the hello (tests of version
    /// mismatch change it; games should not).
    pub protocol_version: u16,
    /// The local address to bind (default: any port on the unspecified
    /// address of the server's family).
    pub bind: Option<SocketAddr>,
    /// Inputs sent per second, Hz (default: the server's tick rate).
    pub input_hz: Option<u32>,
    /// How many of the latest inputs each input datagram carries, 1 to
    /// [`MAX_REDUNDANT_INPUTS`] (default: all 8): an input is lost only
    /// when that many datagrams in a row are.
    pub input_redundancy: Option<usize>,
    /// Predict the own avatar locally ([`crate::predict`]), with settings
    /// that must match the server's game (the defaults match its default
    /// sandbox); `None` (the default): the avatar is drawn from snapshots
    /// like every other entity.
    pub predict: Option<crate::predict::PredictionConfig>,
    /// With [`Self::predict`]: how the game's rules move the avatar, made
    /// for the connection (a game's own input and avatar); `None` (the
    /// default): the sandbox's walker.
    pub controller: Option<ControllerFactory>,
}

/// Makes the [`AvatarController`](crate::predict::AvatarController) a
/// connection predicts with.
#[derive(Clone)]
pub struct ControllerFactory(
    pub Arc<dyn Fn() -> Box<dyn crate::predict::AvatarController> + Send + Sync>,
);

impl std::fmt::Debug for ControllerFactory {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("ControllerFactory")
    }
}

impl Default for ConnectOptions {
    fn default() -> Self {
        Self {
            protocol_version: PROTOCOL_VERSION,
            bind: None,
            input_hz: None,
            input_redundancy: None,
            predict: None,
            controller: None,
        }
    }
}

/// A connected client. Cheap to share across threads; every method locks a
/// short-lived mutex. The connection runs on the tokio runtime that
/// [`Client::connect`] was called on.
#[derive(Debug)]
pub struct Client {
    state: Arc<Mutex<ClientShared>>,
    commands: mpsc::UnboundedSender<DriverCommand>,
    info: ServerInfo,
    epoch: Instant,
    connection: quinn::Connection,
    endpoint: quinn::Endpoint,
}

/// Says hello on the control stream and waits for the answer, as `conn`
/// directs: the server's welcome, or why not.
async fn handshake(
    conn: &mut ClientConnection,
    send: &mut quinn::SendStream,
    recv: &mut quinn::RecvStream,
) -> Result<ServerInfo, ClientError> {
    let mut buf = [0u8; 4096];
    loop {
        if let Some(ClientConnectionEvent::Welcomed(info)) = conn.poll_event() {
            return Ok(info);
        }
        match conn.end() {
            Some(ClientConnectionEnd::Refused(Refusal::VersionMismatch { server, client })) => {
                return Err(ClientError::VersionMismatch {
                    server: *server,
                    client: *client,
                })
            }
            Some(ClientConnectionEnd::Refused(r)) => return Err(ClientError::Refused(r.clone())),
            Some(ClientConnectionEnd::HandshakeTimeout) => {
                return Err(ClientError::Timeout(HANDSHAKE_TIMEOUT))
            }
            Some(ClientConnectionEnd::Protocol(what)) => {
                return Err(ClientError::Protocol(what.clone()))
            }
            Some(ClientConnectionEnd::Disconnected(reason)) => {
                return Err(ClientError::Protocol(format!("disconnected: {reason:?}")))
            }
            None => {}
        }
        let deadline = conn.poll_timeout().map(tokio::time::Instant::from_std);
        tokio::select! {
            written = send.write(conn.pending_control()), if !conn.pending_control().is_empty() => match written {
                Ok(n) => conn.control_written(n, Instant::now()),
                Err(e) => return Err(ClientError::Protocol(format!("control stream: {e}"))),
            },
            read = recv.read(&mut buf) => match read {
                Ok(Some(n)) => conn.on_control_data(&buf[..n], Instant::now()),
                Ok(None) => conn.on_control_finished(Instant::now()),
                Err(e) => return Err(ClientError::Protocol(format!("control stream: {e}"))),
            },
            () = driver::sleep_until(deadline) => conn.handle_timeout(Instant::now()),
        }
    }
}

impl Client {
    /// Connects to the server at `addr` with `token` (which names the
    /// server and pins its certificate).
    pub async fn connect(addr: SocketAddr, token: &ConnectToken) -> Result<Client, ClientError> {
        Self::connect_with(addr, token, ConnectOptions::default()).await
    }

    /// [`Client::connect`] with options.
    pub async fn connect_with(
        addr: SocketAddr,
        token: &ConnectToken,
        options: ConnectOptions,
    ) -> Result<Client, ClientError> {
        let bind = options.bind.unwrap_or_else(|| match addr {
            SocketAddr::V4(_) => "0.0.0.0:0".parse().expect("literal address"),
            SocketAddr::V6(_) => "[::]:0".parse().expect("literal address"),
        });
        let mut endpoint = quinn::Endpoint::client(bind)?;
        endpoint.set_default_client_config(
            inertia_tls::client_config(token.public.cert_fingerprint).map_err(ClientError::Tls)?,
        );
        let started = Instant::now();
        let mut conn = ClientConnection::new(
            options.protocol_version,
            token.to_bytes(),
            ClientConnectionConfig::default(),
            started,
        );
        let opened = async {
            let connection = endpoint.connect(addr, "localhost")?.await?;
            let (send, recv) = connection.open_bi().await?;
            Ok::<_, ClientError>((connection, send, recv))
        };
        let deadline = tokio::time::Instant::from_std(started + HANDSHAKE_TIMEOUT);
        let (connection, mut send, mut recv) = match tokio::time::timeout_at(deadline, opened).await
        {
            Ok(opened) => opened?,
            Err(_) => return Err(ClientError::Timeout(HANDSHAKE_TIMEOUT)),
        };
        let info = handshake(&mut conn, &mut send, &mut recv).await?;
        let session = ClientSession::new(
            ClientConfig {
                snapshot: info.snapshot,
                input_hz: options.input_hz.unwrap_or(info.tick_hz).clamp(1, 1000),
                input_redundancy: options
                    .input_redundancy
                    .unwrap_or(MAX_REDUNDANT_INPUTS)
                    .clamp(1, MAX_REDUNDANT_INPUTS),
                properties: info.properties.clone(),
            },
            info.tick,
        )
        .map_err(|e| ClientError::Protocol(format!("snapshot settings: {e}")))?;
        let predictor = options
            .predict
            .map(|config| match &options.controller {
                Some(make) => crate::predict::Predictor::with_controller(
                    config,
                    (make.0)(),
                    info.client_id,
                    info.tick_hz,
                ),
                None => crate::predict::Predictor::new(config, info.client_id, info.tick_hz),
            })
            .transpose()?;
        let epoch = Instant::now();
        let mut state = ClientShared::new(&info, session);
        state.predictor = predictor;
        let state = Arc::new(Mutex::new(state));
        let (commands, command_rx) = mpsc::unbounded_channel();
        tokio::spawn(driver::run(driver::Driver {
            connection: connection.clone(),
            conn,
            send,
            recv,
            state: state.clone(),
            commands: command_rx,
            epoch,
        }));
        Ok(Client {
            state,
            commands,
            info,
            epoch,
            connection,
            endpoint,
        })
    }

    /// Seconds since the connection was made, on the clock that
    /// [`Client::sample_at`] takes.
    pub fn local_time(&self) -> f64 {
        self.epoch.elapsed().as_secs_f64()
    }

    /// What the server said about itself.
    pub fn server_info(&self) -> &ServerInfo {
        &self.info
    }

    /// Our client id.
    pub fn client_id(&self) -> u64 {
        self.info.client_id
    }

    fn lock(&self) -> std::sync::MutexGuard<'_, ClientShared> {
        self.state.lock().unwrap_or_else(|e| e.into_inner())
    }

    /// Sets what the player wants from now on: the game's input, the
    /// type its rules read ([`GameInput`]). It is stamped for every tick
    /// from now on and sent every input interval, with the last few inputs
    /// repeated in every datagram against loss. Refused, changing nothing,
    /// when the server's game takes inputs of another size.
    pub fn set_game_input<I: GameInput>(&self, input: &I) -> Result<(), ClientError> {
        self.set_input_payload(input.to_payload())
    }

    /// [`Client::set_game_input`] with the input's bytes (for bindings to
    /// other languages, which encode the game's input themselves).
    pub fn set_input_payload(&self, payload: InputPayload) -> Result<(), ClientError> {
        if payload.len() != self.info.input_bytes {
            return Err(ClientError::InputSize {
                ours: payload.len(),
                server: self.info.input_bytes,
            });
        }
        self.lock().session.set_input(payload);
        Ok(())
    }

    /// The sandbox game's input ([`SandboxInput`]): movement in the
    /// horizontal plane (each in [−1, 1]), facing angle (rad) and held
    /// buttons ([`inertia_sandbox::buttons`]), for the stock server. A
    /// server running another game refuses it
    /// ([`ClientError::InputSize`]).
    pub fn set_input(&self, movement: [f32; 2], yaw: f32, buttons: u8) -> Result<(), ClientError> {
        self.set_game_input(&SandboxInput {
            movement,
            yaw,
            buttons,
        })
    }

    /// Sends a message of the game's to the server's rules: reliable (on
    /// the control stream, in order with every other reliable message) or
    /// unreliable (a datagram of its own, lost when it is). Refused,
    /// sending nothing, past
    /// [`MAX_MESSAGE_BYTES`](inertia_protocol::message::MAX_MESSAGE_BYTES)
    /// or once the connection has ended. The server takes at most its
    /// game's rate ([`MessageLimits`](inertia_protocol::message::MessageLimits),
    /// 30 a second by default) and refuses the rest.
    pub fn send_message<M: GameMessage>(
        &self,
        message: &M,
        delivery: Delivery,
    ) -> Result<(), ClientError> {
        self.send_message_bytes(message.to_bytes(), delivery)
    }

    /// [`Client::send_message`] with the message's bytes (for bindings to
    /// other languages, which encode the game's messages themselves).
    pub fn send_message_bytes(
        &self,
        bytes: Vec<u8>,
        delivery: Delivery,
    ) -> Result<(), ClientError> {
        check_len(&bytes)?;
        if self.lock().disconnected.is_some() {
            return Err(MessageRefusal::NotConnected.into());
        }
        match delivery {
            Delivery::Reliable => self
                .commands
                .send(DriverCommand::Send(bytes))
                .map_err(|_| MessageRefusal::NotConnected)?,
            Delivery::Unreliable => {
                let datagram = MessageDatagram::encode(&bytes)?;
                self.connection
                    .send_datagram(datagram.into())
                    .map_err(|_| MessageRefusal::NotConnected)?;
            }
        }
        Ok(())
    }

    /// Asks the server to show this stretch of the recent past (a
    /// kill-cam, an instant replay) beside the live match: ticks
    /// `request.from_tick..=request.to_tick`, at `request.speed` times
    /// real time, its interest centred on `request.focus` (the own avatar
    /// when `None`). The answer comes as [`ClientEvent::Replay`]; while it
    /// plays, [`Client::replay_sample`] draws it. The live stream, its
    /// interpolation and the prediction go on as before, and the player's
    /// inputs still reach the server: whether a player who watches may
    /// act is the game's rules' choice. A new request replaces the replay
    /// playing. Refused, sending nothing, when the stretch is empty, the
    /// speed out of range or the connection has ended; the server refuses
    /// (and says why) a stretch it no longer holds or has not reached,
    /// one longer than its window, and more than one request a second.
    pub fn replay(
        &self,
        request: inertia_protocol::replay::ReplayRequest,
    ) -> Result<(), ClientError> {
        use inertia_protocol::replay::ReplayRefusal;
        request.check()?;
        let mut s = self.lock();
        if s.disconnected.is_some() {
            return Err(ReplayRefusal::NotJoined.into());
        }
        self.commands
            .send(DriverCommand::Replay(request))
            .map_err(|_| ReplayRefusal::NotJoined)?;
        s.replay.asked();
        Ok(())
    }

    /// The kill-cam: the last `seconds` of the match up to the newest
    /// tick received, at `speed`, centred on `focus` (the one that hit
    /// the player; `None`: the own avatar). See [`Client::replay`].
    pub fn kill_cam(
        &self,
        seconds: f32,
        speed: f32,
        focus: Option<EntityId>,
    ) -> Result<(), ClientError> {
        let now = self.lock().latest.map_or(self.info.tick, |(tick, _)| tick);
        self.replay(inertia_protocol::replay::ReplayRequest::last_seconds(
            now,
            self.info.tick_hz,
            seconds,
            speed,
            focus,
        ))
    }

    /// Stops the replay playing, if any (answered by
    /// [`ClientEvent::Replay`] with [`ReplayEnd::Cancelled`](inertia_protocol::replay::ReplayEnd::Cancelled)).
    pub fn cancel_replay(&self) -> Result<(), ClientError> {
        self.commands
            .send(DriverCommand::CancelReplay)
            .map_err(|_| inertia_protocol::replay::ReplayRefusal::NotJoined)?;
        Ok(())
    }

    /// Where the player's replay stands.
    pub fn replay_status(&self) -> crate::replay::ReplayStatus {
        self.lock().replay.status()
    }

    /// The replayed world as it should be drawn now (see
    /// [`Client::replay`]): `None` before any replayed state came. Once
    /// the replay ended it shows its last frames to their end; draw
    /// [`Client::sample`] again when [`Client::replay_status`] is no
    /// longer playing.
    pub fn replay_sample(&self) -> Option<crate::interp::Sample> {
        let now = self.local_time();
        self.lock().replay.sample(now)
    }

    /// The newest replayed tick received.
    pub fn replay_tick(&self) -> Option<u64> {
        self.lock().replay.newest_tick()
    }

    /// An entity's properties as the replay shows them (as they were at
    /// the replayed tick).
    pub fn replay_properties(&self, entity: EntityId) -> Option<Vec<PropertyValue>> {
        self.lock().replay.properties(entity)
    }

    /// The match's properties as the replay shows them.
    pub fn replay_match_state(&self) -> Vec<PropertyValue> {
        self.lock().replay.match_state()
    }

    /// The world as it should be drawn now: interpolated behind the
    /// server by the buffer's delay.
    pub fn sample(&self) -> crate::interp::Sample {
        self.sample_at(self.local_time())
    }

    /// The world as it should be drawn at `local_time` (s, see
    /// [`Client::local_time`]). Its render tick becomes the view every
    /// input sent from now on carries
    /// ([`inertia_protocol::PlayerInput::view_behind`]), so the server can
    /// answer the player's actions against the world drawn (lag
    /// compensation): sample the frame you draw, then set the input. With
    /// prediction on, the own avatar is where prediction puts it (see
    /// [`Client::predicted_avatar`]), ahead of the interpolated rest.
    pub fn sample_at(&self, local_time: f64) -> crate::interp::Sample {
        let mut s = self.lock();
        let predicted = s.predictor.as_ref().and_then(|p| p.avatar());
        let mut frame = s.interp.sample(local_time).clone();
        if !frame.entities.is_empty() {
            s.session.set_view_tick(frame.render_tick);
        }
        if let Some(a) = predicted {
            let drawn = crate::interp::RenderedEntity {
                id: a.id,
                position: a.position,
                rotation: a.rotation,
                extrapolated: false,
            };
            match frame.entities.binary_search_by_key(&a.id, |e| e.id) {
                Ok(i) => frame.entities[i] = drawn,
                Err(i) => frame.entities.insert(i, drawn),
            }
        }
        frame
    }

    /// The game's properties, per entity and per match, as the server
    /// declared them (names and kinds, in the order values come in).
    pub fn property_schema(&self) -> Arc<PropertySchema> {
        self.info.properties.clone()
    }

    /// An entity's properties as of the tick last drawn (the render tick
    /// of the last [`Client::sample`]; the newest before any), in the
    /// schema's order, defaults where the rules set none; `None` for an
    /// entity not in view.
    pub fn properties(&self, entity: EntityId) -> Option<Vec<PropertyValue>> {
        let s = self.lock();
        let held = match s.session.view_tick() {
            Some(t) => s.properties.entity_at(entity, t.floor().max(0.0) as u64),
            None => s.properties.entity(entity),
        };
        // An entity described whose properties were never set holds the
        // defaults.
        held.or_else(|| {
            s.entities
                .get(entity)
                .map(|_| s.properties.entity_defaults())
        })
    }

    /// One property of an entity by name, as [`Client::properties`].
    pub fn property(&self, entity: EntityId, name: &str) -> Option<PropertyValue> {
        let i = self.info.properties.entity_index(name)?;
        self.properties(entity)?.get(i).copied()
    }

    /// The match's properties (the score, the clock, the phase) as of the
    /// tick last drawn, in the schema's order.
    pub fn match_state(&self) -> Vec<PropertyValue> {
        let s = self.lock();
        match s.session.view_tick() {
            Some(t) => s.properties.match_at(t.floor().max(0.0) as u64),
            None => s.properties.match_state(),
        }
    }

    /// One match property by name, as [`Client::match_state`].
    pub fn match_property(&self, name: &str) -> Option<PropertyValue> {
        let i = self.info.properties.match_index(name)?;
        self.match_state().get(i).copied()
    }

    /// Entities whose properties this client holds, ascending.
    pub fn entities_with_properties(&self) -> Vec<EntityId> {
        self.lock().properties.entities().collect()
    }

    /// The own avatar as predicted, when prediction is on
    /// ([`ConnectOptions::predict`]) and a snapshot has placed it: where to
    /// draw it (corrections smoothed), the raw prediction and its tick.
    pub fn predicted_avatar(&self) -> Option<crate::predict::PredictedAvatar> {
        self.lock().predictor.as_ref().and_then(|p| p.avatar())
    }

    /// The newest snapshot received, exactly as decoded (no interpolation):
    /// its tick and full view.
    pub fn latest_view(&self) -> Option<(u64, Vec<inertia_protocol::snapshot::ViewEntity>)> {
        let s = self.lock();
        let (tick, sequence) = s.latest?;
        Some((tick, s.session.decoder().entities(sequence)?))
    }

    /// How the server's clock ran at the newest snapshot: its tick, its
    /// time scale (negative while history plays backwards) and whether it
    /// was paused. `None` before the first snapshot.
    pub fn timeline(&self) -> Option<crate::clock::SnapshotMeta> {
        self.lock().latest_meta
    }

    /// Every entity the server has described to us, by id.
    pub fn entities(&self) -> Vec<inertia_protocol::EntityDesc> {
        self.lock()
            .entities
            .iter()
            .map(|(_, e)| e.desc.clone())
            .collect()
    }

    /// Runs `f` on the entity table: descriptions and the newest state each
    /// entity's snapshots carried.
    pub fn with_entities<R>(&self, f: impl FnOnce(&crate::entities::KnownEntities) -> R) -> R {
        f(&self.lock().entities)
    }

    /// Connection statistics.
    pub fn stats(&self) -> crate::stats::ClientStats {
        let mut s = self.lock();
        let rtt = self.connection.rtt().as_secs_f64();
        let now = self.epoch.elapsed().as_secs_f64();
        s.stats_at(now, rtt)
    }

    /// The next event (spawns, despawns, the game's messages, timeline
    /// breaks, the disconnect), oldest first.
    pub fn poll_event(&self) -> Option<ClientEvent> {
        self.lock().events.pop_front()
    }

    /// Why the connection ended, once it has.
    pub fn disconnected(&self) -> Option<DisconnectReason> {
        self.lock().disconnected.clone()
    }

    /// Sends `bytes` as one raw datagram, bypassing the input encoder: for
    /// tools and tests that check how a server treats bad datagrams.
    pub fn send_raw_datagram(&self, bytes: Vec<u8>) -> Result<(), quinn::SendDatagramError> {
        self.connection.send_datagram(bytes.into())
    }

    /// Says goodbye and closes the connection, waiting briefly for the
    /// server to hear it.
    pub async fn close(self) {
        let _ = self.commands.send(DriverCommand::Close);
        let _ = tokio::time::timeout(Duration::from_secs(1), self.connection.closed()).await;
        self.endpoint.close(0u32.into(), b"client left");
        let _ = tokio::time::timeout(Duration::from_secs(1), self.endpoint.wait_idle()).await;
    }
}
