//! `replay-file export`: the records of a tick range as JSON lines, one
//! object per record, in recorded order. Every object has `kind` and
//! `tick`; the rest depends on the kind:
//!
//! - `session_start`: `tick_hz` (Hz), `scene`;
//! - `keyframe`: `bytes` (encoded length), `applied` (journal entries of
//!   its tick already in it), `bodies`, `entities`, `clients`,
//!   `spawn_points` (counts), `rules_bytes`;
//! - `journal`: `entries`, each `{"type": "join" | "leave", "client"}`,
//!   `{"type": "input", "client", "sequence", "tick", "movement": [x, z],
//!   "yaw" (rad), "buttons"}` or `{"type": "edit", "edit": <the edit>}`;
//! - `inputs`: `inputs`, each like a journal input;
//! - `tick_hash`: `hash`, 16 hex digits;
//! - `admin_edit`: `who`, `what` (UTF-8, invalid bytes replaced).
//!
//! A keyframe or journal that does not decode is exported with an `error`
//! field instead of its content, and the command exits 1 at the end.

use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::ops::ControlFlow;
use std::path::Path;
use std::process::ExitCode;

use inertia_physics::{World, WorldConfig};
use inertia_protocol::PlayerInput;
use inertia_server::record::{LegacyInput, Record};
use inertia_server::replay::journal::{self, JournalEntry};
use inertia_server::replay::SimState;
use serde_json::{json, Value};

use super::scan::{self, ScanDamage};
use super::{data_error, hex, misuse};
use crate::Failure;

/// Writes the records of ticks `from..=to` (default: all) of the
/// recording at `dir` to `out` (default: stdout).
pub fn run(
    dir: &Path,
    from: Option<u64>,
    to: Option<u64>,
    out: Option<&Path>,
    json: bool,
) -> Result<ExitCode, Failure> {
    let (from, to) = (from.unwrap_or(0), to.unwrap_or(u64::MAX));
    if from > to {
        return Err(misuse("usage", format!("--from {from} is after --to {to}")));
    }
    let files = scan::open(dir)?;
    let mut sink: Box<dyn Write> = match out {
        Some(path) => {
            Box::new(BufWriter::new(File::create(path).map_err(|e| {
                misuse("io", format!("cannot create {}: {e}", path.display()))
            })?))
        }
        None => Box::new(BufWriter::new(io::stdout().lock())),
    };
    // Records of `from` may end the segment before the one named for it.
    let start = files.iter().rposition(|s| s.first_tick < from).unwrap_or(0);
    let mut written = 0u64;
    let mut ticks: Option<(u64, u64)> = None;
    let mut undecodable = 0u64;
    let mut write_error: Option<io::Error> = None;
    let mut damage: Option<ScanDamage> = None;
    for (i, file) in files.iter().enumerate().skip(start) {
        let newest = i + 1 == files.len();
        let scan = scan::scan_segment(file, newest, |_, record| {
            let tick = record.tick();
            if tick > to {
                return ControlFlow::Break(());
            }
            if tick < from {
                return ControlFlow::Continue(());
            }
            let line = record_json(&record);
            if line.get("error").is_some() {
                undecodable += 1;
            }
            if let Err(e) = writeln!(sink, "{line}") {
                write_error = Some(e);
                return ControlFlow::Break(());
            }
            written += 1;
            ticks = Some(ticks.map_or((tick, tick), |(a, _)| (a, tick)));
            ControlFlow::Continue(())
        });
        if scan.stopped {
            break;
        }
        if let Some(d) = scan.damage {
            if d.not_a_segment() && i == 0 && scan.records == 0 {
                return Err(misuse(
                    "not_a_recording",
                    format!("{}: not a recording ({})", dir.display(), d.text()),
                ));
            }
            damage = Some(d);
            break;
        }
    }
    let flushed = sink.flush();
    drop(sink);
    match write_error.map_or(flushed, Err) {
        // A reader that stopped early (`| head`) is not an error.
        Err(e) if e.kind() == io::ErrorKind::BrokenPipe => return Ok(ExitCode::SUCCESS),
        Err(e) => {
            let to = out.map_or("stdout".into(), |p| p.display().to_string());
            return Err(data_error("io", format!("writing {to}: {e}")));
        }
        Ok(()) => {}
    }
    if let Some(path) = out {
        let range = ticks.map_or("no records in range".into(), |(a, b)| {
            format!("ticks {a}..={b}")
        });
        if json {
            println!(
                "{}",
                json!({
                    "records": written,
                    "first_tick": ticks.map(|t| t.0),
                    "last_tick": ticks.map(|t| t.1),
                    "out": path.display().to_string(),
                })
            );
        } else {
            println!("wrote {written} records ({range}) to {}", path.display());
        }
    }
    match damage {
        Some(d) if d.torn_tail => {
            eprintln!("inertia-admin: note: {}", d.text());
        }
        Some(d) => {
            eprintln!(
                "inertia-admin: the recording is damaged: {}. The records before it were exported",
                d.text()
            );
            return Ok(ExitCode::from(1));
        }
        None => {}
    }
    if undecodable > 0 {
        eprintln!(
            "inertia-admin: {undecodable} records did not decode (exported with an \"error\" field)"
        );
        return Ok(ExitCode::from(1));
    }
    Ok(ExitCode::SUCCESS)
}

/// One record as a JSON object (see the module docs).
fn record_json(record: &Record) -> Value {
    match record {
        Record::SessionStart {
            tick,
            tick_hz,
            scene,
        } => json!({
            "kind": "session_start",
            "tick": tick,
            "tick_hz": tick_hz,
            "scene": scene,
        }),
        Record::Keyframe { tick, state } => {
            let mut v = json!({ "kind": "keyframe", "tick": tick, "bytes": state.len() });
            match keyframe_fields(state) {
                Ok(fields) => merge(&mut v, fields),
                Err(e) => v["error"] = json!(e),
            }
            v
        }
        Record::Journal { tick, entries } => {
            let mut v = json!({ "kind": "journal", "tick": tick });
            match journal::decode(*tick, entries) {
                Ok(entries) => v["entries"] = entries.iter().map(entry_json).collect(),
                Err(e) => v["error"] = json!(e.to_string()),
            }
            v
        }
        Record::Inputs { tick, inputs } => json!({
            "kind": "inputs",
            "tick": tick,
            "inputs": inputs
                .iter()
                .map(|(client, input)| legacy_input_json(*client, input))
                .collect::<Vec<_>>(),
        }),
        Record::TickHash { tick, hash } => json!({
            "kind": "tick_hash",
            "tick": tick,
            "hash": hex(*hash),
        }),
        Record::AdminEdit { tick, who, what } => json!({
            "kind": "admin_edit",
            "tick": tick,
            "who": who,
            "what": String::from_utf8_lossy(what),
        }),
    }
}

/// What a keyframe holds, counted: decodes the saved state and restores
/// its world to count the bodies.
fn keyframe_fields(state: &[u8]) -> Result<Value, String> {
    let state = SimState::decode(state).map_err(|e| e.to_string())?;
    let mut world = World::new(WorldConfig::default()).map_err(|e| e.to_string())?;
    world
        .restore(&state.world)
        .map_err(|e| format!("saved world does not restore: {e}"))?;
    Ok(json!({
        "state_tick": state.tick,
        "applied": state.applied,
        "bodies": world.bodies().count(),
        "entities": state.entities.len(),
        "clients": state.clients.len(),
        "spawn_points": state.spawn_points.len(),
        "rules_bytes": state.rules.len(),
    }))
}

/// One journal entry as a JSON object.
fn entry_json(entry: &JournalEntry) -> Value {
    match entry {
        JournalEntry::Join(client) => json!({ "type": "join", "client": client }),
        JournalEntry::Leave(client) => json!({ "type": "leave", "client": client }),
        JournalEntry::Input(client, input) => input_json(*client, input),
        JournalEntry::Message(client, delivery, bytes) => json!({
            "type": "message",
            "client": client,
            "delivery": delivery.label(),
            "bytes": hex_bytes(bytes),
        }),
        JournalEntry::Edit(edit) => json!({
            "type": "edit",
            "edit": serde_json::to_value(edit).unwrap_or(Value::Null),
        }),
    }
}

/// A client's input as a JSON object: its payload, the game's bytes, in
/// hex (a view that is not finite comes out as null).
fn input_json(client: u64, input: &PlayerInput) -> Value {
    json!({
        "type": "input",
        "client": client,
        "sequence": input.sequence,
        "tick": input.tick,
        "view_behind": input.view_behind,
        "payload": hex_bytes(input.payload.as_bytes()),
    })
}

/// Bytes in lowercase hex.
fn hex_bytes(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// An input of the first builds' recordings (the sandbox's fields) as a
/// JSON object (a float that is not finite comes out as null).
fn legacy_input_json(client: u64, input: &LegacyInput) -> Value {
    json!({
        "type": "input",
        "client": client,
        "sequence": input.sequence,
        "tick": input.tick,
        "movement": input.movement,
        "yaw": input.yaw,
        "buttons": input.buttons,
    })
}

/// Copies `fields`' members into the object `v`.
fn merge(v: &mut Value, fields: Value) {
    if let (Some(v), Value::Object(fields)) = (v.as_object_mut(), fields) {
        v.extend(fields);
    }
}
