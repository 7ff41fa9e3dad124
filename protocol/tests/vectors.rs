//! Golden vectors of the snapshot wire format (`tests/vectors/snapshots.json`):
//! datagrams the Rust encoder writes for fixed streams of worlds, with what
//! the Rust decoder reads from each, both as the quantized indices that
//! travel and as the values they stand for. A decoder written elsewhere
//! (the browser client's) decodes the same bytes and must read the same,
//! so the implementations cannot drift apart.
//!
//! The file is what these streams give today: a change to the encoder or
//! the decoder that changes a datagram or its reading fails here. A change
//! to the format that means to change them rewrites the file with
//! `INERTIA_WRITE_VECTORS=1 cargo test -p inertia-protocol --test integration vectors::
//! -- --skip control_vectors:: --skip input_vectors::` (the filter matches
//! their names too), in review, with the reason. The vectors also cover every code of the
//! format: both header forms, every size class of every field.
//!
//! Each stream lists its config and its snapshots in the order they were
//! sent (ticks, 64-bit, as decimal text). Before a snapshot, `acked` names the snapshot the client
//! acknowledged (the encoder's baseline from then on); a decoder that has
//! read every earlier snapshot of the stream holds the baseline each one
//! names.

use std::sync::Arc;

use glam::{DQuat, DVec3};
use inertia_protocol::property::{
    FrameProperties, PropertyDecl, PropertyKind, PropertyRow, PropertySchema,
};
use inertia_protocol::quantize::PositionGrid;
use inertia_protocol::snapshot::{QuantizedEntity, QuantizedFrame};
use inertia_protocol::{
    EntityState, Interest, PriorityAccumulator, SnapshotConfig, SnapshotDecoder, SnapshotEncoder,
};
use serde_json::{json, Value};

use crate::support;
use support::check_vectors;

const FILE: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/vectors/snapshots.json");

/// One world sent: the snapshot acknowledged before it, and the clock.
struct Step {
    acked: Option<u16>,
    tick: u64,
    time_scale: f32,
    paused: bool,
    world: Vec<EntityState>,
    /// The game's properties at this step (streams with a schema).
    properties: Option<FrameProperties>,
}

fn body(id: u32, at: [f64; 3], rotation: DQuat, velocity: [f64; 3], asleep: bool) -> EntityState {
    EntityState {
        id,
        position: DVec3::from_array(at),
        rotation,
        linear_velocity: DVec3::from_array(velocity),
        angular_velocity: DVec3::ZERO,
        asleep,
    }
}

/// A rotation whose largest component is `largest` (0 = x … 3 = w).
fn turned(largest: usize, by: f64) -> DQuat {
    let mut c = [0.2 * by, -0.15, 0.1 + by, 0.3];
    c[largest] = 0.9;
    DQuat::from_array(c).normalize()
}

/// Stream `velocities`: the server's config with velocities, a small world
/// that moves by every size class, rests, leaves and arrives, under every
/// kind of clock.
fn moving_stream() -> (SnapshotConfig, Vec<Step>) {
    let config = SnapshotConfig {
        velocities: true,
        ..SnapshotConfig::default()
    };
    let first = vec![
        body(1, [0.0, 0.5, 0.0], DQuat::IDENTITY, [0.0; 3], true),
        body(
            2,
            [1.25, 0.5, -3.5],
            turned(0, 0.0),
            [1.0, 0.0, -2.0],
            false,
        ),
        body(3, [-7.0, 2.0, 4.0], turned(1, 0.0), [0.0, -3.0, 0.5], false),
        body(
            10,
            [20.0, 0.25, -20.0],
            turned(2, 0.0),
            [0.5, 0.0, 0.0],
            false,
        ),
        body(
            200,
            [-511.0, 0.0, 511.0],
            turned(3, 0.0),
            [-99.0, 50.0, 0.01],
            false,
        ),
        body(70_000, [3.0, 3.0, 3.0], DQuat::IDENTITY, [0.0; 3], true),
    ];
    let mut second = first.clone();
    // Moved by each size class of the position code, an axis at a time:
    // 3 mm (4 bits), 50 mm (7 bits), 400 mm (10 bits), 5 m (absolute).
    second[1].position += DVec3::new(0.003, 0.0, 0.05);
    second[1].linear_velocity = DVec3::new(1.05, 0.0, -2.0);
    second[2].position += DVec3::new(0.4, 5.0, -0.002);
    second[2].linear_velocity = DVec3::new(0.0, -3.5, 6.0);
    second[2].rotation = turned(1, 0.001);
    second[3].rotation = turned(2, 0.02);
    second[3].asleep = true;
    second[4].rotation = turned(3, 0.1);
    second[4].linear_velocity = DVec3::new(-98.0, 50.0, 30.0);
    second[0].asleep = false;
    second[0].linear_velocity = DVec3::new(0.0, 4.0, 0.0);
    second.pop();
    second.push(body(
        70_003,
        [4.0, 3.0, 3.0],
        turned(0, 0.5),
        [0.0; 3],
        true,
    ));
    let mut third = second.clone();
    third[2].rotation = turned(0, 0.0);
    third[3].rotation = turned(2, 2.0);
    third[4].position += DVec3::new(-0.001, 0.0, 0.0);
    third.retain(|e| e.id != 2);
    (
        config,
        vec![
            Step {
                acked: None,
                tick: 100,
                time_scale: 1.0,
                paused: false,
                world: first,
                properties: None,
            },
            Step {
                acked: Some(0),
                tick: 102,
                time_scale: 0.5,
                paused: false,
                world: second,
                properties: None,
            },
            // Played backwards from the timeline: the tick goes down.
            Step {
                acked: Some(1),
                tick: 60,
                time_scale: -2.0,
                paused: false,
                world: third.clone(),
                properties: None,
            },
            // Snapshot 2 not acknowledged: still against 1, far ahead.
            Step {
                acked: None,
                tick: 4_000,
                time_scale: 0.0,
                paused: true,
                world: third,
                properties: None,
            },
        ],
    )
}

/// Stream `coarse`: no velocities, a 1 cm grid within ±2 km and 9-bit
/// rotations, and a world of 80 bodies in rows (every gap class of the
/// ids, and the widest count class).
fn coarse_stream() -> (SnapshotConfig, Vec<Step>) {
    let config = SnapshotConfig {
        grid: PositionGrid {
            resolution: 0.01,
            bound: 2_000.0,
        },
        rotation_bits: 9,
        max_datagram: 4_000,
        ..SnapshotConfig::default()
    };
    let mut id = 0;
    let world: Vec<EntityState> = (0..80)
        .map(|i| {
            // Gaps of 0, 7, 60 and 700 in turn.
            id += 1 + [0, 7, 60, 700][i % 4];
            let at = [i as f64 * 3.0 - 200.0, (i % 5) as f64, -(i as f64) * 7.5];
            body(id, at, turned(i % 4, i as f64 * 0.01), [0.0; 3], i % 3 == 0)
        })
        .collect();
    let mut moved = world.clone();
    for (i, e) in moved.iter_mut().enumerate().step_by(10) {
        e.position.x += 0.05 * i as f64;
        e.asleep = false;
    }
    (
        config,
        vec![
            Step {
                acked: None,
                tick: u64::MAX / 3,
                time_scale: 8.0,
                paused: false,
                world,
                properties: None,
            },
            Step {
                acked: Some(0),
                tick: u64::MAX / 3 + 100,
                time_scale: 1.0,
                paused: false,
                world: moved,
                properties: None,
            },
        ],
    )
}

/// Stream `properties`: a few entities with a property of every kind
/// (a flag, unsigned and signed integers up to 64 bits, a float) and the
/// match's, changing, an entity leaving with its row, and one arriving
/// with its own.
fn property_stream() -> (SnapshotConfig, PropertySchema, Vec<Step>) {
    let schema = PropertySchema {
        entity: vec![
            PropertyDecl::new("health", PropertyKind::UInt { bits: 7 }),
            PropertyDecl::new("team", PropertyKind::UInt { bits: 2 }),
            PropertyDecl::new("alive", PropertyKind::Bool),
            PropertyDecl::new("heading", PropertyKind::Int { bits: 10 }),
            PropertyDecl::new("owner", PropertyKind::UInt { bits: 64 }),
        ],
        match_state: vec![
            PropertyDecl::new("score", PropertyKind::UInt { bits: 8 }),
            PropertyDecl::new("clock", PropertyKind::F32),
            PropertyDecl::new("bonus", PropertyKind::Int { bits: 64 }),
        ],
    };
    let at = |id: u32| {
        body(
            id,
            [f64::from(id), 0.5, 0.0],
            DQuat::IDENTITY,
            [0.0; 3],
            true,
        )
    };
    let row = |v: [u64; 5]| -> PropertyRow { v.to_vec().into() };
    let props = |rows: Vec<(u32, PropertyRow)>, m: [u64; 3]| {
        Some(FrameProperties {
            entities: rows,
            match_state: Some(m.to_vec().into()),
        })
    };
    let heading = |h: i64| (h as u64) & 0x3ff;
    let clock = |c: f32| u64::from(c.to_bits());
    let steps = vec![
        Step {
            acked: None,
            tick: 10,
            time_scale: 1.0,
            paused: false,
            world: vec![at(1), at(2), at(40)],
            properties: props(
                vec![
                    (1, row([100, 1, 1, heading(-3), u64::MAX])),
                    (40, row([55, 3, 1, heading(511), 7])),
                ],
                [0, clock(90.0), 0],
            ),
        },
        Step {
            acked: Some(0),
            tick: 12,
            time_scale: 1.0,
            paused: false,
            world: vec![at(1), at(2), at(40)],
            properties: props(
                vec![
                    (1, row([80, 1, 1, heading(-3), u64::MAX])),
                    (2, row([0, 2, 0, heading(-512), 0])),
                    (40, row([55, 3, 1, heading(511), 7])),
                ],
                [1, clock(89.5), -5i64 as u64],
            ),
        },
        Step {
            acked: Some(1),
            tick: 14,
            time_scale: 1.0,
            paused: false,
            world: vec![at(1), at(2), at(700)],
            properties: props(
                vec![
                    (1, row([0, 1, 0, heading(-3), u64::MAX])),
                    (2, row([0, 2, 0, heading(-512), 0])),
                    (700, row([127, 0, 1, 0, 1 << 40])),
                ],
                [1, clock(89.0), -5i64 as u64],
            ),
        },
        Step {
            acked: Some(2),
            tick: 16,
            time_scale: 1.0,
            paused: false,
            world: vec![at(1), at(2), at(700)],
            properties: props(
                vec![
                    (1, row([0, 1, 0, heading(-3), u64::MAX])),
                    (2, row([0, 2, 0, heading(-512), 0])),
                    (700, row([127, 0, 1, 0, 1 << 40])),
                ],
                [1, clock(89.0), -5i64 as u64],
            ),
        },
    ];
    (SnapshotConfig::default(), schema, steps)
}

fn quantized(q: &QuantizedEntity) -> Value {
    json!({
        "position": q.position,
        "rotation": { "largest": q.rotation.largest, "small": q.rotation.small },
        "velocity": q.velocity,
        "at_rest": q.at_rest,
    })
}

/// Raw property values as decimal text (64-bit values stay exact in
/// every JSON reader).
fn raws(row: &PropertyRow) -> Value {
    json!(row.iter().map(|v| v.to_string()).collect::<Vec<_>>())
}

/// Encodes and decodes a stream, as the vectors file holds it.
fn run(name: &str, config: SnapshotConfig, schema: PropertySchema, steps: Vec<Step>) -> Value {
    let schema = Arc::new(schema);
    let mut encoder = SnapshotEncoder::new(config)
        .unwrap()
        .with_properties(schema.clone());
    let mut decoder = SnapshotDecoder::new(config)
        .unwrap()
        .with_properties(schema.clone());
    let mut priorities = PriorityAccumulator::new(Interest::everything());
    let mut snapshots = Vec::new();
    for step in steps {
        if let Some(a) = step.acked {
            encoder.on_ack(a);
        }
        let mut frame = QuantizedFrame::new(
            step.tick,
            step.time_scale,
            step.paused,
            &step.world,
            &config,
        );
        if let Some(p) = step.properties {
            frame = frame.with_properties(Arc::new(p));
        }
        let bytes = encoder.encode_frame(&frame, &mut priorities, usize::MAX);
        let report = encoder.last_report();
        assert_eq!(report.deferred, 0, "{name}: every entity fits");
        let d = decoder.decode(&bytes).unwrap();
        let view = decoder.view(d.sequence).unwrap();
        let updated: Vec<Value> = d
            .updated
            .iter()
            .map(|e| {
                json!({
                    "id": e.id,
                    "quantized": quantized(view.get(e.id).unwrap()),
                    "position": e.position.to_array(),
                    "rotation": e.rotation.to_array(),
                    "velocity": e.linear_velocity.map(|v| v.to_array()),
                })
            })
            .collect();
        let hex: String = bytes.iter().map(|b| format!("{b:02x}")).collect();
        snapshots.push(json!({
            "acked": step.acked,
            "bytes": hex,
            "sequence": d.sequence,
            "baseline": d.baseline,
            // A u64: as decimal text, which every JSON reader keeps exact.
            "tick": d.tick.to_string(),
            "time_scale": d.time_scale,
            "paused": d.paused,
            "removed": d.removed,
            "updated": updated,
            "properties": d.properties.iter().map(|(id, row)| json!([id, raws(row)])).collect::<Vec<_>>(),
            "match_state": d.match_state.as_ref().map(raws),
        }));
    }
    json!({
        "name": name,
        "config": {
            "grid": { "resolution": config.grid.resolution, "bound": config.grid.bound,
                      "bits": config.grid.bits() },
            "rotation_bits": config.rotation_bits,
            "velocities": config.velocities,
            "velocity_grid": { "resolution": config.velocity_grid.resolution,
                               "bound": config.velocity_grid.bound,
                               "bits": config.velocity_grid.bits() },
            "max_datagram": config.max_datagram,
        },
        "properties": *schema,
        "snapshots": snapshots,
    })
}

fn vectors() -> Value {
    let (c, s) = moving_stream();
    let moving = run("velocities", c, PropertySchema::default(), s);
    let (c, s) = coarse_stream();
    let coarse = run("coarse", c, PropertySchema::default(), s);
    let (c, schema, s) = property_stream();
    let properties = run("properties", c, schema, s);
    json!({
        "format": "inertia snapshot datagram (protocol/src/snapshot/mod.rs)",
        "streams": [moving, coarse, properties],
    })
}

#[test]
fn golden_vectors_are_what_the_codec_writes_and_reads() {
    check_vectors(FILE, &vectors(), "vectors");
}

/// The widths of each size class (as `protocol/src/snapshot/code.rs`
/// documents them).
const ID_CLASSES: [u32; 4] = [2, 5, 9, 32];
const COUNT_CLASSES: [u32; 3] = [3, 6, 14];
const TICK_CLASSES: [u32; 3] = [4, 8, 16];
const POSITION_CLASSES: [u32; 4] = [0, 4, 7, 10];
const ROTATION_CLASSES: [u32; 3] = [3, 6, 9];

/// Which class of an unsigned varint `value` takes.
fn varuint_class(value: u64, classes: &[u32]) -> usize {
    let mut start = 0u64;
    for (i, &bits) in classes.iter().enumerate() {
        if value - start < 1u64 << bits || i + 1 == classes.len() {
            return i;
        }
        start += 1 << bits;
    }
    unreachable!()
}

/// Which class a signed per-axis delta takes (`classes.len()`: absolute).
fn delta_class(d: i64, classes: &[u32]) -> usize {
    classes
        .iter()
        .position(|&bits| match bits {
            0 => d == 0,
            b => -(1i64 << (b - 1)) <= d && d < 1i64 << (b - 1),
        })
        .unwrap_or(classes.len())
}

fn ints(v: &Value) -> Vec<i64> {
    v.as_array()
        .unwrap()
        .iter()
        .map(|x| x.as_i64().unwrap())
        .collect()
}

#[test]
fn golden_vectors_cover_every_code_of_the_format() {
    use std::collections::{BTreeMap, BTreeSet};
    let all = vectors();
    let mut seen: BTreeSet<String> = BTreeSet::new();
    let mut see = |s: String| {
        seen.insert(s);
    };
    for stream in all["streams"].as_array().unwrap() {
        // Each snapshot's view, by sequence: id → quantized state.
        let mut views: BTreeMap<u64, BTreeMap<u64, Value>> = BTreeMap::new();
        for snap in stream["snapshots"].as_array().unwrap() {
            let base_seq = snap["baseline"].as_u64();
            let mut view = base_seq.map_or_else(BTreeMap::new, |b| views[&b].clone());
            let base = view.clone();
            see(format!("baseline {}", base_seq.is_some()));
            see(format!("paused {}", snap["paused"]));
            see(format!("time scale one {}", snap["time_scale"] == 1.0));
            let tick_of = |s: &Value| s["tick"].as_str().unwrap().parse::<u64>().unwrap();
            let tick = tick_of(snap);
            let base_tick = base_seq.map(|b| tick_of(&stream["snapshots"][b as usize]));
            match base_tick.and_then(|t| tick.checked_sub(t)) {
                Some(d) if d < (1 << 16) + (1 << 8) + (1 << 4) => {
                    see(format!("tick class {}", varuint_class(d, &TICK_CLASSES)))
                }
                _ => see("tick absolute".into()),
            }
            for list in ["removed", "updated"] {
                let items = snap[list].as_array().unwrap();
                see(format!(
                    "count class {}",
                    varuint_class(items.len() as u64, &COUNT_CLASSES)
                ));
                let mut prev: Option<u64> = None;
                for item in items {
                    let id = item.as_u64().or(item["id"].as_u64()).unwrap();
                    let gap = prev.map_or(id, |p| id - p - 1);
                    see(format!("id class {}", varuint_class(gap, &ID_CLASSES)));
                    prev = Some(id);
                }
            }
            for id in snap["removed"].as_array().unwrap() {
                view.remove(&id.as_u64().unwrap());
            }
            for e in snap["updated"].as_array().unwrap() {
                let q = &e["quantized"];
                let id = e["id"].as_u64().unwrap();
                see(format!("at rest {}", q["at_rest"]));
                match base.get(&id) {
                    None => see("entity new to the baseline".into()),
                    Some(b) => {
                        let (p, bp) = (ints(&q["position"]), ints(&b["position"]));
                        for k in 0..3 {
                            let c = delta_class(p[k] - bp[k], &POSITION_CLASSES);
                            see(format!("position class {c}"));
                        }
                        let (r, br) = (&q["rotation"], &b["rotation"]);
                        if r == br {
                            see("rotation unchanged".into());
                        } else if r["largest"] == br["largest"] {
                            let (s, bs) = (ints(&r["small"]), ints(&br["small"]));
                            let worst = (0..3)
                                .map(|k| s[k] - bs[k])
                                .map(|d| if d < 0 { -d - 1 } else { d })
                                .max()
                                .unwrap();
                            let c = ROTATION_CLASSES
                                .iter()
                                .position(|&bits| worst < 1 << (bits - 1))
                                .unwrap_or(3);
                            see(format!("rotation class {c}"));
                        } else {
                            see("rotation other largest".into());
                        }
                        match (q["velocity"].is_null(), b["velocity"].is_null()) {
                            (false, false) => {
                                let (v, bv) = (ints(&q["velocity"]), ints(&b["velocity"]));
                                for k in 0..3 {
                                    let c = delta_class(v[k] - bv[k], &POSITION_CLASSES);
                                    see(format!("velocity class {c}"));
                                }
                            }
                            (false, true) => see("velocity against none".into()),
                            (true, _) => {}
                        }
                    }
                }
                see(format!("velocity sent {}", !q["velocity"].is_null()));
                see(format!(
                    "largest {}",
                    q["rotation"]["largest"].as_u64().unwrap()
                ));
                view.insert(id, q.clone());
            }
            views.insert(snap["sequence"].as_u64().unwrap(), view);
        }
    }
    let mut wanted: Vec<String> = [
        "baseline false",
        "baseline true",
        "paused false",
        "paused true",
        "time scale one false",
        "time scale one true",
        "tick absolute",
        "entity new to the baseline",
        "at rest false",
        "at rest true",
        "velocity sent false",
        "velocity sent true",
        "velocity against none",
        "rotation unchanged",
        "rotation other largest",
    ]
    .map(String::from)
    .to_vec();
    wanted.extend((0..3).map(|c| format!("tick class {c}")));
    wanted.extend((0..3).map(|c| format!("count class {c}")));
    wanted.extend((0..4).map(|c| format!("id class {c}")));
    wanted.extend((0..5).map(|c| format!("position class {c}")));
    wanted.extend((0..4).map(|c| format!("rotation class {c}")));
    wanted.extend((0..5).map(|c| format!("velocity class {c}")));
    wanted.extend((0..4).map(|c| format!("largest {c}")));
    let missing: Vec<&String> = wanted.iter().filter(|w| !seen.contains(*w)).collect();
    assert!(missing.is_empty(), "not covered: {missing:?}");
}
