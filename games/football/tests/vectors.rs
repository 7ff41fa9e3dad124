//! Golden vectors of football's input and messages
//! (`tests/vectors/football.json`): for each play, the fields the page
//! gives (stick in [−1, 1], yaw in radians, pitch in degrees, buttons) and
//! the bytes `Play::new` encodes; every message the rules tell and every
//! one a player asks, with its fields and bytes. The browser page's codecs
//! (`web/src/football.ts`) must write and read the same bytes.
//!
//! A change that means to change the bytes rewrites the file with
//! `INERTIA_WRITE_VECTORS=1 cargo test -p inertia-football --test vectors`.

use inertia_football::input::buttons;
use inertia_football::properties::Team;
use inertia_football::{Ask, Play, Tell};
use inertia_protocol::input::GameInput;
use inertia_protocol::message::GameMessage;
use serde_json::{json, Value};

const FILE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/vectors/football.json");

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// A float as JSON can spell it (NaN as null, the infinities as strings).
fn number(x: f64) -> Value {
    if x.is_nan() {
        Value::Null
    } else if x == f64::INFINITY {
        json!("inf")
    } else if x == f64::NEG_INFINITY {
        json!("-inf")
    } else {
        json!(x)
    }
}

fn plays() -> Vec<Value> {
    let mut fields: Vec<([f64; 2], f64, f64, u8)> = (0..12u8)
        .map(|k| {
            let k = f64::from(k);
            (
                [k / 11.0 * 2.0 - 1.0, 0.5 - k * 0.125],
                -7.0 + k * 1.9,
                -20.0 + k * 9.5,
                [0, buttons::JUMP, buttons::KICK, buttons::ALL][k as usize % 4],
            )
        })
        .collect();
    fields.extend([
        ([-0.5 / 127.0, 0.5 / 127.0], 0.0, 0.5, 0xff),
        ([f64::NAN, 7.0], f64::INFINITY, f64::NAN, buttons::KICK),
        ([-3.0, f64::NEG_INFINITY], f64::NAN, 200.0, 0),
        (
            [1.0, 0.0],
            std::f64::consts::TAU - 1e-9,
            -95.0,
            buttons::JUMP,
        ),
    ]);
    fields
        .into_iter()
        .map(|(stick, yaw, pitch, pressed)| {
            let play = Play::new(stick, yaw, pitch, pressed);
            let payload = play.to_payload();
            assert_eq!(Play::from_payload(&payload), Ok(play), "canonical");
            json!({
                "stick": [number(stick[0]), number(stick[1])],
                "yaw": number(yaw),
                "pitch": number(pitch),
                "buttons": pressed,
                "bytes": hex(payload.as_bytes()),
            })
        })
        .collect()
}

fn tell_json(t: &Tell) -> Value {
    let (kind, fields) = match t {
        Tell::Joined { client, team } => {
            ("joined", json!({ "client": client, "team": team.code() }))
        }
        Tell::Kickoff { team } => ("kickoff", json!({ "team": team.code() })),
        Tell::Goal {
            tick,
            team,
            scorer,
            score,
        } => (
            "goal",
            json!({ "tick": tick, "team": team.code(), "scorer": scorer, "score": score }),
        ),
        Tell::Over { winner, score } => {
            ("over", json!({ "winner": winner.code(), "score": score }))
        }
        Tell::Said { client, text } => ("said", json!({ "client": client, "text": text })),
    };
    assert_eq!(Tell::decode(&t.to_bytes()).as_ref(), Ok(t));
    json!({ "kind": kind, "fields": fields, "bytes": hex(&t.to_bytes()) })
}

fn ask_json(a: &Ask) -> Value {
    let (kind, fields) = match a {
        Ask::Say(text) => ("say", json!({ "text": text })),
        Ask::SwitchTeam => ("switch_team", json!({})),
    };
    json!({ "kind": kind, "fields": fields, "bytes": hex(&a.to_bytes()) })
}

/// `v` with every object's keys in sorted order (serde_json keeps them in
/// insertion order when a crate in the build asks it to).
fn sorted(v: Value) -> Value {
    match v {
        Value::Object(map) => {
            let mut entries: Vec<(String, Value)> = map.into_iter().collect();
            entries.sort_by(|a, b| a.0.cmp(&b.0));
            Value::Object(entries.into_iter().map(|(k, v)| (k, sorted(v))).collect())
        }
        Value::Array(items) => Value::Array(items.into_iter().map(sorted).collect()),
        other => other,
    }
}

#[test]
fn football_vectors_are_what_the_encoders_write() {
    let tells = [
        Tell::Joined {
            client: 7,
            team: Team::Red,
        },
        Tell::Joined {
            client: 1 << 40,
            team: Team::Blue,
        },
        Tell::Kickoff { team: Team::Blue },
        Tell::Goal {
            tick: 12_345,
            team: Team::Red,
            scorer: Some(7),
            score: [1, 0],
        },
        Tell::Goal {
            tick: 1 << 33,
            team: Team::Blue,
            scorer: None,
            score: [1, 1],
        },
        Tell::Over {
            winner: Team::Blue,
            score: [1, 2],
        },
        Tell::Said {
            client: 3,
            text: "gg — ça marche".into(),
        },
        Tell::Said {
            client: 4,
            text: String::new(),
        },
    ];
    let asks = [
        Ask::Say("hello".into()),
        Ask::Say("é".repeat(50)),
        Ask::SwitchTeam,
    ];
    let want = json!({
        "input_bytes": Play::BYTES,
        "plays": plays(),
        "tells": tells.iter().map(tell_json).collect::<Vec<_>>(),
        "asks": asks.iter().map(ask_json).collect::<Vec<_>>(),
    });
    // Compared as text, its keys in order whatever serde_json's features
    // (a parser may miss an f64 by an ulp).
    let text = serde_json::to_string_pretty(&sorted(want)).unwrap() + "\n";
    if std::env::var("INERTIA_WRITE_VECTORS").as_deref() == Ok("1") {
        std::fs::write(FILE, &text).unwrap();
    }
    let have = std::fs::read_to_string(FILE).unwrap_or_default();
    assert!(
        have == text,
        "{FILE} is not what the encoders write: rewrite it with INERTIA_WRITE_VECTORS=1"
    );
}
