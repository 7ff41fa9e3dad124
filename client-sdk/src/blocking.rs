//! A blocking face on [`Client`], for games without an async runtime: it
//! owns a small tokio runtime (one I/O thread) on which the connection
//! runs, and every method returns at once except `connect` and `close`.

use std::net::SocketAddr;

use inertia_protocol::control::DisconnectReason;
use inertia_protocol::token::ConnectToken;
use inertia_protocol::EntityDesc;

use crate::interp::Sample;
use crate::net::{Client, ClientError, ClientEvent, ConnectOptions, ServerInfo};
use crate::stats::ClientStats;

/// A connected client driven by its own runtime thread.
#[derive(Debug)]
pub struct BlockingClient {
    runtime: tokio::runtime::Runtime,
    client: Option<Client>,
}

impl BlockingClient {
    /// Connects to the server at `addr` with `token`; blocks until the
    /// server welcomes or refuses us.
    pub fn connect(addr: SocketAddr, token: &ConnectToken) -> Result<Self, ClientError> {
        Self::connect_with(addr, token, ConnectOptions::default())
    }

    /// [`BlockingClient::connect`] with options.
    pub fn connect_with(
        addr: SocketAddr,
        token: &ConnectToken,
        options: ConnectOptions,
    ) -> Result<Self, ClientError> {
        let runtime = tokio::runtime::Builder::new_multi_thread()
            .worker_threads(1)
            .thread_name("inertia-client")
            .enable_all()
            .build()?;
        let client = runtime.block_on(Client::connect_with(addr, token, options))?;
        Ok(Self {
            runtime,
            client: Some(client),
        })
    }

    fn client(&self) -> &Client {
        self.client.as_ref().expect("present until close")
    }

    /// See [`Client::server_info`].
    pub fn server_info(&self) -> &ServerInfo {
        self.client().server_info()
    }

    /// See [`Client::local_time`].
    pub fn local_time(&self) -> f64 {
        self.client().local_time()
    }

    /// See [`Client::set_input`].
    pub fn set_input(&self, movement: [f32; 2], yaw: f32, buttons: u8) -> Result<(), ClientError> {
        self.client().set_input(movement, yaw, buttons)
    }

    /// See [`Client::set_game_input`].
    pub fn set_game_input<I: inertia_protocol::input::GameInput>(
        &self,
        input: &I,
    ) -> Result<(), ClientError> {
        self.client().set_game_input(input)
    }

    /// See [`Client::set_input_payload`].
    pub fn set_input_payload(
        &self,
        payload: inertia_protocol::input::InputPayload,
    ) -> Result<(), ClientError> {
        self.client().set_input_payload(payload)
    }

    /// See [`Client::send_message`].
    pub fn send_message<M: inertia_protocol::message::GameMessage>(
        &self,
        message: &M,
        delivery: inertia_protocol::message::Delivery,
    ) -> Result<(), ClientError> {
        self.client().send_message(message, delivery)
    }

    /// See [`Client::send_message_bytes`].
    pub fn send_message_bytes(
        &self,
        bytes: Vec<u8>,
        delivery: inertia_protocol::message::Delivery,
    ) -> Result<(), ClientError> {
        self.client().send_message_bytes(bytes, delivery)
    }

    /// See [`Client::property_schema`].
    pub fn property_schema(&self) -> std::sync::Arc<inertia_protocol::property::PropertySchema> {
        self.client().property_schema()
    }

    /// See [`Client::properties`].
    pub fn properties(
        &self,
        entity: inertia_protocol::EntityId,
    ) -> Option<Vec<inertia_protocol::property::PropertyValue>> {
        self.client().properties(entity)
    }

    /// See [`Client::property`].
    pub fn property(
        &self,
        entity: inertia_protocol::EntityId,
        name: &str,
    ) -> Option<inertia_protocol::property::PropertyValue> {
        self.client().property(entity, name)
    }

    /// See [`Client::match_state`].
    pub fn match_state(&self) -> Vec<inertia_protocol::property::PropertyValue> {
        self.client().match_state()
    }

    /// See [`Client::match_property`].
    pub fn match_property(&self, name: &str) -> Option<inertia_protocol::property::PropertyValue> {
        self.client().match_property(name)
    }

    /// See [`Client::entities_with_properties`].
    pub fn entities_with_properties(&self) -> Vec<inertia_protocol::EntityId> {
        self.client().entities_with_properties()
    }

    /// See [`Client::replay`].
    pub fn replay(
        &self,
        request: inertia_protocol::replay::ReplayRequest,
    ) -> Result<(), ClientError> {
        self.client().replay(request)
    }

    /// See [`Client::kill_cam`].
    pub fn kill_cam(
        &self,
        seconds: f32,
        speed: f32,
        focus: Option<inertia_protocol::EntityId>,
    ) -> Result<(), ClientError> {
        self.client().kill_cam(seconds, speed, focus)
    }

    /// See [`Client::cancel_replay`].
    pub fn cancel_replay(&self) -> Result<(), ClientError> {
        self.client().cancel_replay()
    }

    /// See [`Client::replay_status`].
    pub fn replay_status(&self) -> crate::replay::ReplayStatus {
        self.client().replay_status()
    }

    /// See [`Client::replay_sample`].
    pub fn replay_sample(&self) -> Option<Sample> {
        self.client().replay_sample()
    }

    /// See [`Client::sample`].
    pub fn sample(&self) -> Sample {
        self.client().sample()
    }

    /// See [`Client::sample_at`].
    pub fn sample_at(&self, local_time: f64) -> Sample {
        self.client().sample_at(local_time)
    }

    /// See [`Client::with_entities`].
    pub fn with_entities<R>(&self, f: impl FnOnce(&crate::entities::KnownEntities) -> R) -> R {
        self.client().with_entities(f)
    }

    /// See [`Client::timeline`].
    pub fn timeline(&self) -> Option<crate::clock::SnapshotMeta> {
        self.client().timeline()
    }

    /// See [`Client::entities`].
    pub fn entities(&self) -> Vec<EntityDesc> {
        self.client().entities()
    }

    /// See [`Client::stats`].
    pub fn stats(&self) -> ClientStats {
        self.client().stats()
    }

    /// See [`Client::poll_event`].
    pub fn poll_event(&self) -> Option<ClientEvent> {
        self.client().poll_event()
    }

    /// See [`Client::disconnected`].
    pub fn disconnected(&self) -> Option<DisconnectReason> {
        self.client().disconnected()
    }

    /// Says goodbye and closes; blocks up to about two seconds.
    pub fn close(mut self) {
        if let Some(client) = self.client.take() {
            self.runtime.block_on(client.close());
        }
    }
}
