//! Golden vectors of the sandbox's messages (`tests/vectors/messages.json`:
//! every event its rules send, every request its players make, with their
//! fields and bytes), which the page's decoder and encoder must match, and
//! of its input (`tests/vectors/inputs.json`):
//! the bytes the Rust encoder writes for sticks on and off the grid,
//! turns past a whole circle and backwards, every button, undefined
//! buttons, NaN and infinities (written as `null`, `"inf"` and `"-inf"`).
//! The browser page's encoder (`web/src/sandbox.ts`) must write the same
//! bytes from the same fields.
//!
//! A change to the layout that means to change the bytes rewrites the file
//! with `INERTIA_WRITE_VECTORS=1 cargo test -p inertia-sandbox --test vectors`.

use inertia_protocol::input::GameInput;
use inertia_protocol::message::GameMessage;
use inertia_sandbox::{buttons, Removal, SandboxEvent, SandboxInput, SandboxRequest};
use serde_json::{json, Value};

const FILE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/vectors/inputs.json");

/// A float as JSON can spell it.
fn number(x: f32) -> Value {
    if x.is_nan() {
        Value::Null
    } else if x == f32::INFINITY {
        json!("inf")
    } else if x == f32::NEG_INFINITY {
        json!("-inf")
    } else {
        json!(x)
    }
}

fn inputs() -> Vec<SandboxInput> {
    let mut out: Vec<SandboxInput> = (0..12u8)
        .map(|k| SandboxInput {
            movement: [f32::from(k) / 11.0 * 2.0 - 1.0, 0.3 - f32::from(k) * 0.1],
            yaw: -7.0 + f32::from(k) * 1.9,
            buttons: [0, buttons::JUMP, buttons::PUSH, buttons::ALL][usize::from(k) % 4],
        })
        .collect();
    out.extend([
        SandboxInput {
            movement: [1.0, -1.0],
            yaw: 3.25,
            buttons: 0xff,
        },
        SandboxInput {
            movement: [f32::NAN, 7.0],
            yaw: f32::INFINITY,
            buttons: buttons::JUMP,
        },
        SandboxInput {
            movement: [-0.0, f32::NEG_INFINITY],
            yaw: f32::NAN,
            buttons: 0,
        },
    ]);
    out
}

/// Two vector files alike, each float read back as the f32 it was (JSON
/// parsers may miss an f64 by an ulp; never an f32).
fn same(a: &Value, b: &Value) -> bool {
    match (a, b) {
        (Value::Number(x), Value::Number(y)) => match (x.as_f64(), y.as_f64()) {
            (Some(x), Some(y)) => (x as f32).to_bits() == (y as f32).to_bits(),
            _ => x == y,
        },
        (Value::Array(x), Value::Array(y)) => {
            x.len() == y.len() && x.iter().zip(y).all(|(x, y)| same(x, y))
        }
        (Value::Object(x), Value::Object(y)) => {
            x.len() == y.len() && x.iter().all(|(k, v)| y.get(k).is_some_and(|w| same(v, w)))
        }
        _ => a == b,
    }
}

#[test]
fn sandbox_input_vectors_are_what_the_encoder_writes() {
    let list: Vec<Value> = inputs()
        .iter()
        .map(|i| {
            let payload = i.to_payload();
            assert_eq!(
                SandboxInput::from_payload(&payload).unwrap().to_payload(),
                payload,
                "canonical"
            );
            json!({
                "movement": [number(i.movement[0]), number(i.movement[1])],
                "yaw": number(i.yaw),
                "buttons": i.buttons,
                "bytes": payload.as_bytes().iter().map(|b| format!("{b:02x}")).collect::<String>(),
            })
        })
        .collect();
    let want = json!({ "inputs": list });
    if std::env::var("INERTIA_WRITE_VECTORS").as_deref() == Ok("1") {
        std::fs::write(FILE, serde_json::to_string_pretty(&want).unwrap() + "\n").unwrap();
    }
    let have: Value = serde_json::from_str(&std::fs::read_to_string(FILE).unwrap_or_default())
        .unwrap_or_default();
    assert!(
        same(&have, &want),
        "{FILE} is not what the encoder writes: rewrite it with INERTIA_WRITE_VECTORS=1"
    );
}

const MESSAGES: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/vectors/messages.json");

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// An event as the vectors spell it: its kind, its fields, its bytes.
fn event_json(e: &SandboxEvent) -> Value {
    let fields = match e {
        SandboxEvent::Joined { client, avatar } | SandboxEvent::Respawned { client, avatar } => {
            json!({ "client": client, "avatar": avatar })
        }
        SandboxEvent::Left { client } => json!({ "client": client }),
        SandboxEvent::Jumped { avatar } => json!({ "avatar": avatar }),
        SandboxEvent::Pushed {
            avatar,
            target,
            impulse,
        } => json!({ "avatar": avatar, "target": target, "impulse": impulse }),
        SandboxEvent::Removed { entity, reason } => json!({
            "entity": entity,
            "reason": match reason {
                Removal::OutOfBounds => "out_of_bounds",
                Removal::Quarantined => "quarantined",
                Removal::Despawned => "despawned",
            },
        }),
        SandboxEvent::Chat { client, text } => json!({ "client": client, "text": text }),
    };
    json!({ "kind": e.name(), "fields": fields, "bytes": hex(&e.to_bytes()) })
}

fn request_json(r: &SandboxRequest) -> Value {
    let (kind, fields) = match r {
        SandboxRequest::Chat { text } => ("chat", json!({ "text": text })),
        SandboxRequest::Respawn => ("respawn", json!({})),
    };
    json!({ "kind": kind, "fields": fields, "bytes": hex(&r.to_bytes()) })
}

#[test]
fn sandbox_message_vectors_are_what_the_encoder_writes() {
    let events = [
        SandboxEvent::Joined {
            client: 7,
            avatar: 301,
        },
        SandboxEvent::Left { client: 1 << 40 },
        SandboxEvent::Respawned {
            client: 2,
            avatar: 70_000,
        },
        SandboxEvent::Jumped { avatar: 5 },
        SandboxEvent::Pushed {
            avatar: 5,
            target: 12,
            impulse: [150.5, 38.25, -400.0],
        },
        SandboxEvent::Removed {
            entity: 99,
            reason: Removal::OutOfBounds,
        },
        SandboxEvent::Removed {
            entity: 100,
            reason: Removal::Quarantined,
        },
        SandboxEvent::Removed {
            entity: 101,
            reason: Removal::Despawned,
        },
        SandboxEvent::Chat {
            client: 3,
            text: "gg — ça marche".into(),
        },
        SandboxEvent::Chat {
            client: 4,
            text: String::new(),
        },
    ];
    let requests = [
        SandboxRequest::Chat {
            text: "hello".into(),
        },
        SandboxRequest::Chat {
            text: "é".repeat(100),
        },
        SandboxRequest::Respawn,
    ];
    for e in &events {
        assert_eq!(SandboxEvent::decode(&e.to_bytes()).as_ref(), Ok(e));
    }
    let want = json!({
        "events": events.iter().map(event_json).collect::<Vec<_>>(),
        "requests": requests.iter().map(request_json).collect::<Vec<_>>(),
    });
    if std::env::var("INERTIA_WRITE_VECTORS").as_deref() == Ok("1") {
        std::fs::write(
            MESSAGES,
            serde_json::to_string_pretty(&want).unwrap() + "\n",
        )
        .unwrap();
    }
    let have: Value = serde_json::from_str(&std::fs::read_to_string(MESSAGES).unwrap_or_default())
        .unwrap_or_default();
    assert!(
        same(&have, &want),
        "{MESSAGES} is not what the encoder writes: rewrite it with INERTIA_WRITE_VECTORS=1"
    );
}
