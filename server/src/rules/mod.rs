//! Game rules: what players may do to the world.
//!
//! The tick thread calls a [`GameRules`] implementation at fixed points —
//! a client joins or leaves, an input arrives, before and after every tick
//! — and hands it a [`SimContext`]: controlled access to the world and the
//! entity table. Rules spawn and despawn entities and push bodies through
//! the context, which caps every force and impulse at its
//! [`ControlLimits`], so no rule (and no input it forwards) can launch a
//! body at absurd speed.
//!
//! Inputs come from the network and are untrusted: the simulation's input
//! schedule refuses inputs for ticks outside a window around now, the
//! simulation clamps the view every input carries ([`validate_input`])
//! before the rules see it, and the game's
//! own decoder ([`GameInput::from_payload`](inertia_protocol::input::GameInput::from_payload))
//! refuses payloads it does not define ([`InputRefusal::Undecodable`]).
//! [`SandboxRules`] is the default game: a
//! capsule avatar per client, moved by a capped control force towards the
//! desired velocity, a jump only when standing on something, and a push
//! for whatever is in front.
//!
//! Rules may answer an input against the world as its player saw it (lag
//! compensation): [`SimContext::cast_ray_at`] and
//! [`SimContext::overlap_sphere_at`] take the input's
//! [`PlayerInput::view_tick`] and test the moving bodies at their poses
//! of that tick, kept by the simulation's
//! [`PoseHistory`](crate::pose_history::PoseHistory) for as long as the rules ask
//! ([`GameRules::rewind_window_ms`]); static bodies are tested as they
//! are.
//!
//! Messages go both ways. A client's reach the rules on the tick thread
//! ([`GameRules::on_message`]) at the start of the tick after they
//! arrive, before that tick's inputs' forces are applied, ordered by
//! client id and then as the client sent them (whatever order they came
//! off the network in), and go into the recording's journal, so a replay
//! or a seek hands the rules the very same bytes at the same tick. The
//! rules send theirs with [`SimContext::send`] to everyone, one client or
//! a set ([`Recipients`]), reliably or not.
//!
//! One concept a file: the rules' trait and the refusals it speaks in,
//! here; `message.rs` the rules' messages on their way to clients;
//! `removal.rs` why an entity left the world unasked; `input.rs` an
//! input's validation; `context.rs` what the rules may do to the world
//! ([`SimContext`]); `sandbox.rs` the default game ([`SandboxRules`]).

mod context;
mod input;
mod message;
mod removal;
mod sandbox;

use inertia_protocol::message::{Delivery, MessageDecodeError, MessageLimits, MessageRefusal};
use inertia_protocol::property::PropertySchema;
use inertia_protocol::{EntityId, PlayerInput};

pub use context::{
    ContextError, ControlLimits, EntityLook, RewindCount, SimContext, TimelineParts,
};
pub use input::{validate_input, InputRefusal};
pub use message::{OutgoingMessage, Recipients};
pub use removal::RemovalReason;
pub use sandbox::{SandboxRules, SandboxSettings};

/// A connected client, as the network layer numbers it.
pub type ClientId = u64;

/// Why a client may not join.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum JoinRefusal {
    /// The server holds its maximum number of clients.
    #[error("server full ({max} clients)")]
    Full {
        /// The maximum.
        max: u32,
    },
    /// This client id is already in the game.
    #[error("client {0} has already joined")]
    AlreadyJoined(ClientId),
    /// No free place to put an avatar.
    #[error("no room to spawn an avatar")]
    NoRoom,
    /// The simulation is shutting down or not answering.
    #[error("the simulation is not running")]
    Unavailable,
    /// The rules refused, for their own reason.
    #[error("{0}")]
    Rules(String),
}

/// What a game does with players. Called on the tick thread only, in this
/// order each loop: joins and leaves, late inputs, then per tick the
/// clients' messages and the inputs due, `before_tick`, the physics step,
/// `on_removed` for what the step took out, and `after_tick`.
pub trait GameRules: Send {
    /// The game's name, which every welcome carries (at most
    /// [`MAX_GAME_NAME_BYTES`](inertia_protocol::control::MAX_GAME_NAME_BYTES)
    /// bytes; a longer one stops the server at start): clients pick their
    /// controls and HUD by it. Empty by default: a client then plays only
    /// with controls it was given for this game.
    fn name(&self) -> &str {
        ""
    }

    /// A client joins: make its avatar and return its entity id, or refuse.
    fn on_connect(
        &mut self,
        client: ClientId,
        ctx: &mut SimContext<'_>,
    ) -> Result<EntityId, JoinRefusal>;

    /// A client left (or was dropped): clean up after it.
    fn on_disconnect(&mut self, client: ClientId, ctx: &mut SimContext<'_>);

    /// Bytes of this game's input ([`GameInput::BYTES`](inertia_protocol::input::GameInput::BYTES)
    /// of the type its rules and clients share, at most
    /// [`MAX_INPUT_BYTES`](inertia_protocol::input::MAX_INPUT_BYTES)): the
    /// server tells every client in its welcome and refuses datagrams
    /// whose inputs have another size before they reach the rules. Rules
    /// whose players send no input say 0.
    fn input_bytes(&self) -> usize;

    /// An input arrived, its tick and view already checked (see
    /// [`validate_input`]). Decode its payload with the game's input type
    /// before acting on any field; a refused input changes nothing.
    fn on_input(
        &mut self,
        client: ClientId,
        input: &PlayerInput,
        ctx: &mut SimContext<'_>,
    ) -> Result<(), InputRefusal>;

    /// A client's message arrived (within the size and rate bounds,
    /// [`GameRules::message_limits`]): decode it with the game's message
    /// type ([`GameMessage::decode`](inertia_protocol::message::GameMessage::decode))
    /// before acting on it. A refused message changes nothing; it is
    /// counted per client and reason. Rules that take no messages keep
    /// the default, which refuses every one.
    fn on_message(
        &mut self,
        _client: ClientId,
        _delivery: Delivery,
        _bytes: &[u8],
        _ctx: &mut SimContext<'_>,
    ) -> Result<(), MessageRefusal> {
        Err(MessageRefusal::Undecodable(MessageDecodeError::Invalid(
            "these rules take no messages".into(),
        )))
    }

    /// How fast each client may send messages; more are refused and
    /// counted by its connection before they reach the tick thread.
    fn message_limits(&self) -> MessageLimits {
        MessageLimits::default()
    }

    /// An entity left the world without the rules asking: it fell out of
    /// the world's bounds, its state went non-finite, or an operator
    /// removed it. Its id is never reused. Rules that keep nothing about
    /// entities keep the default.
    fn on_removed(&mut self, _entity: EntityId, _reason: RemovalReason, _ctx: &mut SimContext<'_>) {
    }

    /// The game's properties, per entity and per match (health, team;
    /// score, clock), that the rules set through the context
    /// ([`SimContext::set_property`], [`SimContext::set_match_property`])
    /// and every client holds as of its snapshots. Asked once, at start.
    /// Rules without any keep the default: none, at no cost.
    fn properties(&self) -> PropertySchema {
        PropertySchema::default()
    }

    /// How far back these rules look when they answer an input against
    /// the world the player saw (`SimContext::cast_ray_at` and
    /// `overlap_sphere_at`), ms: the server keeps the moving bodies' poses
    /// that long (capped by `SimConfig::max_rewind_ms`), and carries them
    /// in every saved state. Rules that never look back keep the default,
    /// 0, and pay nothing; a shooter asks for about 500 (a view lags its
    /// input's tick by a round trip, the input's margin and the client's
    /// interpolation delay).
    fn rewind_window_ms(&self) -> u32 {
        0
    }

    /// Before each physics step: turn the latest inputs into forces.
    fn before_tick(&mut self, _ctx: &mut SimContext<'_>) {}

    /// After each physics step.
    fn after_tick(&mut self, _ctx: &mut SimContext<'_>) {}

    /// An orchestrator allocated this server for a match with `settings`
    /// (Agones: the allocation's labels and annotations, see
    /// [`crate::orchestrator::allocation`]): set the rules variant and seed
    /// the match's random choices. Called on the tick thread, after the
    /// allocation's scene (if any) is loaded and before the match's
    /// players join. An error is logged and changes nothing the rules did
    /// not. Rules with no variants and no randomness keep the default.
    fn configure_match(
        &mut self,
        _settings: &crate::orchestrator::MatchSettings,
        _ctx: &mut SimContext<'_>,
    ) -> Result<(), String> {
        Ok(())
    }

    /// Whether the game is over, and why (for the players, at most
    /// [`MAX_REASON_BYTES`](inertia_protocol::control::MAX_REASON_BYTES)):
    /// asked after each live tick; once it says so, the server drains,
    /// telling every client `MatchOver` with the reason, and stops. Rules
    /// that never end a match keep the default.
    fn match_over(&self) -> Option<String> {
        None
    }

    /// Everything the rules remember between ticks (players, their latest
    /// inputs, cooldowns, scores), as bytes. Keyframes and checkpoints
    /// carry it, and seeking, `--resume` and `load` re-simulate from it,
    /// so state left out here makes re-simulation differ from the
    /// recording. Rules that remember nothing keep the default (empty).
    fn save_state(&self) -> Vec<u8> {
        Vec::new()
    }

    /// A hash of the rules' state, folded into the state hash a recording
    /// keeps for every tick: a seek or a replay that reproduces the
    /// recorded hash reproduced the rules' state too. By default a hash of
    /// [`GameRules::save_state`]'s bytes (0 for rules that remember
    /// nothing); rules whose saved state is large may hash the same state
    /// more cheaply.
    fn state_hash(&self) -> u64 {
        let bytes = self.save_state();
        if bytes.is_empty() {
            return 0;
        }
        inertia_physics::saved_state::hash::hash_bytes(&bytes)
    }

    /// Replaces the rules' state with one from [`GameRules::save_state`].
    /// On error nothing changes.
    fn restore_state(&mut self, bytes: &[u8]) -> Result<(), String> {
        if bytes.is_empty() {
            Ok(())
        } else {
            Err(format!(
                "these rules keep no state, but {} bytes were given",
                bytes.len()
            ))
        }
    }
}
