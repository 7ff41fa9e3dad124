//! The simulation's game events as the wire carries them.
//!
//! Events the protocol has a variant for travel as that variant; the
//! server's own (joins, jumps, pushes, removals) travel as
//! [`GameEvent::Custom`] with a short name and a JSON payload, so a client
//! can show them without a protocol change.

use inertia_protocol::control::GameEvent as WireEvent;
use serde_json::json;

use crate::rules::{GameEvent, RemovalReason};

/// The wire form of `event`.
pub fn to_wire(event: &GameEvent) -> WireEvent {
    let custom = |name: &str, data: serde_json::Value| WireEvent::Custom {
        name: name.to_string(),
        data: data.to_string().into_bytes(),
    };
    match event {
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
