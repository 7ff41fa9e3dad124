//! Golden vectors of the control stream (`tests/vectors/control.json`):
//! frames the Rust encoder writes for one message of every kind, each with
//! the message as serde's JSON shows it (enums as `{"Variant": ...}`,
//! structs as objects, byte strings as arrays). The browser client's
//! control codec (`web/src/control.ts`) decodes every server frame to the
//! same JSON and encodes every client message to the same bytes, so the two
//! implementations cannot drift apart.
//!
//! Integers past 2^53 (which a JavaScript number cannot hold) are written
//! as decimal text in the JSON. A change to the format that means to
//! change the frames rewrites the file with
//! `INERTIA_WRITE_VECTORS=1 cargo test -p inertia-protocol --test integration control_vectors::`.

use inertia_protocol::control::{
    decode_payload, encode_frame, ClientControl, DisconnectReason, InputReport, Refusal,
    ServerControl, SnapshotParams, TokenRefusal, PROTOCOL_VERSION,
};
use inertia_protocol::property::{PropertyDecl, PropertyKind, PropertySchema};
use inertia_protocol::{EntityDesc, EntityKind, ShapeDesc};
use serde_json::{json, Value};

use crate::support;
use support::check_vectors;

const FILE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/vectors/control.json");

/// The largest integer a JavaScript number holds exactly.
const SAFE: u64 = (1 << 53) - 1;

fn entity(id: u32, kind: EntityKind, shape: ShapeDesc) -> EntityDesc {
    EntityDesc {
        id,
        kind,
        shape,
        color: [200, 120, 40, 255],
        owner: None,
        name: format!("body-{id}"),
        position: [1.5, -0.25, 1e4],
        rotation: [0.0, 0.38268343236508984, 0.0, 0.9238795325112867],
    }
}

/// One message of every kind the server sends.
fn server_messages() -> Vec<(&'static str, ServerControl)> {
    let welcome = |velocities: bool| ServerControl::Welcome {
        client_id: (1 << 63) + 12_345,
        tick: 123_456_789,
        tick_hz: 60,
        snapshot_hz: 30,
        position_resolution: 0.001,
        position_bound: 2_000_000.0,
        snapshot: SnapshotParams {
            rotation_bits: 10,
            velocity_resolution: velocities.then_some(0.01),
            velocity_bound: 512.0,
            max_datagram: 1200,
        },
        input_bytes: 5,
        server_version: "0.1.0".into(),
        game: "sandbox".into(),
        properties: PropertySchema {
            entity: vec![
                PropertyDecl::new("health", PropertyKind::UInt { bits: 7 }),
                PropertyDecl::new("team", PropertyKind::UInt { bits: 2 }),
                PropertyDecl::new("alive", PropertyKind::Bool),
                PropertyDecl::new("heading", PropertyKind::Int { bits: 10 }),
            ],
            match_state: vec![PropertyDecl::new("clock", PropertyKind::F32)],
        },
    };
    let mut avatar = entity(
        4,
        EntityKind::Avatar,
        ShapeDesc::Capsule {
            half_height: 0.5,
            radius: 0.3,
        },
    );
    avatar.owner = Some((1 << 63) + 12_345);
    avatar.name = "café ✓".into();
    let mut water = entity(
        11,
        EntityKind::Water,
        ShapeDesc::Cuboid {
            half_extents: [3.0, 1.0, 3.0],
        },
    );
    water.color = [40, 90, 200, 120];
    vec![
        ("welcome", welcome(true)),
        ("welcome without velocities", welcome(false)),
        (
            "refused: version",
            ServerControl::Refused(Refusal::VersionMismatch {
                server: PROTOCOL_VERSION,
                client: 9,
            }),
        ),
        (
            "refused: token malformed",
            ServerControl::Refused(Refusal::Token(TokenRefusal::Malformed)),
        ),
        (
            "refused: token forged",
            ServerControl::Refused(Refusal::Token(TokenRefusal::Forged)),
        ),
        (
            "refused: token expired",
            ServerControl::Refused(Refusal::Token(TokenRefusal::Expired {
                expires_at: 1_800_000_000,
                now: 1_800_000_301,
            })),
        ),
        (
            "refused: token for another server",
            ServerControl::Refused(Refusal::Token(TokenRefusal::WrongServer {
                token: "10.0.0.1:7777".into(),
                ours: "127.0.0.1:7777".into(),
            })),
        ),
        (
            "refused: token reused",
            ServerControl::Refused(Refusal::Token(TokenRefusal::Reused)),
        ),
        ("refused: full", ServerControl::Refused(Refusal::ServerFull)),
        (
            "refused: shutting down",
            ServerControl::Refused(Refusal::ShuttingDown),
        ),
        (
            "refused: malformed",
            ServerControl::Refused(Refusal::Malformed),
        ),
        (
            "refused: already connected",
            ServerControl::Refused(Refusal::AlreadyConnected),
        ),
        ("refused: busy", ServerControl::Refused(Refusal::Busy)),
        (
            "refused: simulation stopped",
            ServerControl::Refused(Refusal::SimulationStopped),
        ),
        (
            "refused by the rules",
            ServerControl::Refused(Refusal::Rejected {
                reason: "the match is full".into(),
            }),
        ),
        (
            "spawn: sphere",
            ServerControl::Spawn(entity(
                1,
                EntityKind::Dynamic,
                ShapeDesc::Sphere { radius: 0.25 },
            )),
        ),
        (
            "spawn: static box",
            ServerControl::Spawn(entity(
                2,
                EntityKind::Static,
                ShapeDesc::Cuboid {
                    half_extents: [25.0, 1.5, 40.0],
                },
            )),
        ),
        (
            "spawn: kinematic cylinder",
            ServerControl::Spawn(entity(
                3,
                EntityKind::Kinematic,
                ShapeDesc::Cylinder {
                    half_height: 1.0,
                    radius: 0.1,
                },
            )),
        ),
        ("spawn: avatar", ServerControl::Spawn(avatar)),
        (
            "spawn: hull",
            ServerControl::Spawn(entity(
                5,
                EntityKind::Dynamic,
                ShapeDesc::ConvexHull {
                    points: vec![
                        [0.0, 0.0, 0.0],
                        [1.0, 0.0, 0.0],
                        [0.0, 1.0, 0.0],
                        [0.0, 0.0, 1.0],
                    ],
                },
            )),
        ),
        (
            "spawn: mesh",
            ServerControl::Spawn(entity(
                6,
                EntityKind::Static,
                ShapeDesc::TriMesh {
                    vertices: vec![[0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [0.0, 0.0, 4.0]],
                    triangles: vec![[0, 2, 1]],
                },
            )),
        ),
        (
            "spawn: compound",
            ServerControl::Spawn(entity(
                7,
                EntityKind::Dynamic,
                ShapeDesc::Compound {
                    parts: vec![
                        (
                            [0.0, 0.5, 0.0],
                            [0.0, 0.0, 0.0, 1.0],
                            ShapeDesc::Sphere { radius: 0.2 },
                        ),
                        (
                            [0.0, -0.5, 0.0],
                            [
                                0.0,
                                0.0,
                                std::f32::consts::FRAC_1_SQRT_2,
                                std::f32::consts::FRAC_1_SQRT_2,
                            ],
                            ShapeDesc::Cuboid {
                                half_extents: [0.1, 0.5, 0.1],
                            },
                        ),
                    ],
                },
            )),
        ),
        (
            "spawn: particle",
            ServerControl::Spawn(entity(
                8,
                EntityKind::Dynamic,
                ShapeDesc::Particle { radius: 0.02 },
            )),
        ),
        (
            "spawn: ground",
            ServerControl::Spawn(entity(9, EntityKind::Static, ShapeDesc::Ground)),
        ),
        ("spawn: water", ServerControl::Spawn(water)),
        (
            "spawn: cloth",
            ServerControl::Spawn(entity(
                20,
                EntityKind::SoftBody,
                ShapeDesc::PointSet {
                    points: 4,
                    radius: 0.01,
                    triangles: vec![[0, 2, 1], [1, 2, 3]],
                    lines: vec![],
                },
            )),
        ),
        (
            "spawn: rope",
            ServerControl::Spawn(entity(
                30,
                EntityKind::SoftBody,
                ShapeDesc::PointSet {
                    points: 3,
                    radius: 0.02,
                    triangles: vec![],
                    lines: vec![[0, 1], [1, 2]],
                },
            )),
        ),
        (
            "spawn: fluid",
            ServerControl::Spawn(entity(
                40,
                EntityKind::Fluid,
                ShapeDesc::PointSet {
                    points: 300,
                    radius: 0.05,
                    triangles: vec![],
                    lines: vec![],
                },
            )),
        ),
        (
            "spawn: heightfield",
            ServerControl::Spawn(entity(
                12,
                EntityKind::Static,
                ShapeDesc::HeightField {
                    rows: 2,
                    cols: 3,
                    size: [40.0, 20.0],
                    heights: vec![0.0, 1.5, -0.25, 3.0, 0.125, 2.0],
                },
            )),
        ),
        ("despawn", ServerControl::Despawn { id: 4_000_000_000 }),
        ("message", ServerControl::Message(vec![0, 1, 2, 255])),
        ("message: empty", ServerControl::Message(vec![])),
        (
            "input timing",
            ServerControl::InputTiming(InputReport {
                on_time: 70_000,
                late: 3,
                refused: 0,
                min_lead: Some(-2),
            }),
        ),
        (
            "input timing: no input lately",
            ServerControl::InputTiming(InputReport {
                on_time: 1,
                late: 0,
                refused: 300,
                min_lead: None,
            }),
        ),
        (
            "goodbye: shutdown",
            ServerControl::Goodbye(DisconnectReason::ServerShutdown),
        ),
        (
            "goodbye: kicked",
            ServerControl::Goodbye(DisconnectReason::Kicked {
                reason: "afk".into(),
            }),
        ),
        (
            "goodbye: timeout",
            ServerControl::Goodbye(DisconnectReason::Timeout),
        ),
        (
            "goodbye: client left",
            ServerControl::Goodbye(DisconnectReason::ClientLeft),
        ),
        (
            "goodbye: protocol error",
            ServerControl::Goodbye(DisconnectReason::ProtocolError {
                what: "a second hello".into(),
            }),
        ),
        (
            "goodbye: simulation stopped",
            ServerControl::Goodbye(DisconnectReason::SimulationStopped {
                reason: "a panic".into(),
            }),
        ),
        (
            "goodbye: match over",
            ServerControl::Goodbye(DisconnectReason::MatchOver {
                reason: "time".into(),
            }),
        ),
    ]
}

/// Every message a client sends.
fn client_messages() -> Vec<(&'static str, ClientControl)> {
    vec![
        (
            "hello",
            ClientControl::Hello {
                version: PROTOCOL_VERSION,
                token: (0..=255).collect(),
            },
        ),
        ("goodbye", ClientControl::Goodbye),
        ("message", ClientControl::Message(b"ready".to_vec())),
    ]
}

/// `value` with every integer past [`SAFE`] written as decimal text.
fn js_safe(value: Value) -> Value {
    match value {
        Value::Number(n) if n.as_u64().is_some_and(|u| u > SAFE) => Value::String(n.to_string()),
        Value::Array(a) => Value::Array(a.into_iter().map(js_safe).collect()),
        Value::Object(o) => Value::Object(o.into_iter().map(|(k, v)| (k, js_safe(v))).collect()),
        other => other,
    }
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

fn vectors() -> Value {
    let server: Vec<Value> = server_messages()
        .into_iter()
        .map(|(name, msg)| {
            let frame = encode_frame(&msg).expect("a valid message");
            let back: ServerControl = decode_payload(&frame[4..]).expect("decodes");
            assert_eq!(back, msg, "{name}: read back");
            json!({
                "name": name,
                "frame": hex(&frame),
                "message": js_safe(serde_json::to_value(&msg).expect("JSON")),
            })
        })
        .collect();
    let client: Vec<Value> = client_messages()
        .into_iter()
        .map(|(name, msg)| {
            let frame = encode_frame(&msg).expect("a valid message");
            json!({
                "name": name,
                "frame": hex(&frame),
                "message": js_safe(serde_json::to_value(&msg).expect("JSON")),
            })
        })
        .collect();
    json!({ "protocol_version": PROTOCOL_VERSION, "server": server, "client": client })
}

#[test]
fn control_vectors_are_what_the_codec_writes() {
    check_vectors(FILE, &vectors(), "control");
}

#[test]
fn control_vectors_cover_every_message_and_every_shape() {
    let v = vectors();
    let variants = |list: &Value| -> Vec<String> {
        list.as_array()
            .unwrap()
            .iter()
            .map(|m| match &m["message"] {
                Value::Object(o) => o.keys().next().unwrap().clone(),
                Value::String(s) => s.clone(),
                other => panic!("{other}"),
            })
            .collect()
    };
    let server = variants(&v["server"]);
    for kind in [
        "Welcome",
        "Refused",
        "Spawn",
        "Despawn",
        "Message",
        "Goodbye",
        "InputTiming",
    ] {
        assert!(server.iter().any(|k| k == kind), "no {kind}");
    }
    let shapes: Vec<String> = v["server"]
        .as_array()
        .unwrap()
        .iter()
        .filter_map(|m| m["message"].get("Spawn"))
        .map(|e| match &e["shape"] {
            Value::Object(o) => o.keys().next().unwrap().clone(),
            Value::String(s) => s.clone(),
            other => panic!("{other}"),
        })
        .collect();
    for shape in [
        "Sphere",
        "Cuboid",
        "Capsule",
        "Cylinder",
        "ConvexHull",
        "TriMesh",
        "Compound",
        "Particle",
        "Ground",
        "HeightField",
    ] {
        assert!(shapes.iter().any(|s| s == shape), "no {shape}");
    }
    assert_eq!(variants(&v["client"]), ["Hello", "Goodbye", "Message"]);
}
