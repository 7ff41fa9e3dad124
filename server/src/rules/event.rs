//! What happens in a game that clients may want to show, and its wire form.
//!
//! Events the protocol has a variant for travel as that variant; the
//! server's own (joins, jumps, pushes, removals) travel as
//! [`WireEvent::Custom`] with a short name and a JSON payload, so a client
//! can show them without a protocol change.

use inertia_protocol::control::WireEvent;
use inertia_protocol::EntityId;
use serde_json::json;

use super::ClientId;

/// Why something happened to an entity without anyone asking.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RemovalReason {
    /// It left the world bounds.
    OutOfBounds,
    /// Its state went non-finite.
    Quarantined,
    /// The rules removed it.
    Despawned,
}

/// Something clients may want to show: sent reliably with the frame of the
/// tick it happened in.
#[derive(Debug, Clone, PartialEq)]
pub enum GameEvent {
    /// A client joined and got an avatar.
    Joined {
        /// The client.
        client: ClientId,
        /// Its avatar.
        avatar: EntityId,
    },
    /// A client left.
    Left {
        /// The client.
        client: ClientId,
    },
    /// A client's avatar was lost (fell off the world) and made anew.
    Respawned {
        /// The client.
        client: ClientId,
        /// The new avatar.
        avatar: EntityId,
    },
    /// An avatar jumped.
    Jumped {
        /// The avatar.
        avatar: EntityId,
    },
    /// An avatar pushed a body.
    Pushed {
        /// The avatar.
        avatar: EntityId,
        /// What it pushed.
        target: EntityId,
        /// The impulse given, N·s.
        impulse: [f64; 3],
    },
    /// An entity was removed by the simulation.
    Removed {
        /// The entity (its id is never reused).
        entity: EntityId,
        /// Why.
        reason: RemovalReason,
    },
    /// A game-specific event.
    Custom {
        /// What happened.
        name: String,
        /// The entity concerned, if any.
        entity: Option<EntityId>,
    },
}

impl GameEvent {
    /// The wire form of this event.
    pub fn to_wire(&self) -> WireEvent {
        let custom = |name: &str, data: serde_json::Value| WireEvent::Custom {
            name: name.to_string(),
            data: data.to_string().into_bytes(),
        };
        match self {
            GameEvent::Joined { client, avatar } => {
                custom("joined", json!({ "client": client, "avatar": avatar }))
            }
            GameEvent::Left { client } => custom("left", json!({ "client": client })),
            GameEvent::Respawned { client, avatar } => {
                custom("respawned", json!({ "client": client, "avatar": avatar }))
            }
            GameEvent::Jumped { avatar } => custom("jumped", json!({ "avatar": avatar })),
            GameEvent::Pushed {
                avatar,
                target,
                impulse,
            } => custom(
                "pushed",
                json!({ "avatar": avatar, "target": target, "impulse": impulse }),
            ),
            GameEvent::Removed { entity, reason } => {
                let reason = match reason {
                    RemovalReason::OutOfBounds => "out_of_bounds",
                    RemovalReason::Quarantined => "quarantined",
                    RemovalReason::Despawned => "despawned",
                };
                custom("removed", json!({ "entity": entity, "reason": reason }))
            }
            GameEvent::Custom { name, entity } => {
                let mut name = name.clone();
                inertia_protocol::control::truncate_utf8(
                    &mut name,
                    inertia_protocol::control::MAX_EVENT_NAME_BYTES,
                );
                custom(&name, json!({ "entity": entity }))
            }
        }
    }
}
