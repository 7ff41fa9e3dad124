//! Golden vectors of the sandbox's input (`tests/vectors/inputs.json`):
//! the bytes the Rust encoder writes for sticks on and off the grid,
//! turns past a whole circle and backwards, every button, undefined
//! buttons, NaN and infinities (written as `null`, `"inf"` and `"-inf"`).
//! The browser page's encoder (`web/src/sandbox.ts`) must write the same
//! bytes from the same fields.
//!
//! A change to the layout that means to change the bytes rewrites the file
//! with `INERTIA_WRITE_VECTORS=1 cargo test -p inertia-sandbox --test vectors`.

use inertia_protocol::input::GameInput;
use inertia_sandbox::{buttons, SandboxInput};
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
