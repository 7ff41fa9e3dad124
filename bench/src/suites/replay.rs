//! `replay`: what recording a session costs, and how fast an operator can
//! travel in it.
//!
//! A game scene of `--bodies` dynamic bodies (default 1000; see
//! [`scene_ron`]: crate pyramids and a row of crates, a ball pit stirred by
//! a turning kinematic paddle, and hinged pendulums, so not everything
//! sleeps) runs under [`SandboxRules`] with `--bots` clients (default 8)
//! joined through [`Simulation::join`]. Each bot sends one input a tick, as
//! it would arrive over the wire ([`quantize_input`]): a random walk of its
//! stick, facing roughly where it walks, jumping and pushing now and then,
//! and walking home when it strays more than [`HOME_RADIUS`] from the
//! middle. Every random choice comes from [`SplitMix`] with fixed seeds, so
//! every run plays the same game.
//!
//! For each keyframe interval K (`--keyframe-ticks`, a list; default 900,
//! the server's default) the suite:
//!
//! 1. records `--minutes` minutes (default 10) at 60 Hz into a fresh
//!    temporary directory, ticking by hand (`run_ticks(1)` per tick, not
//!    the wall clock), then ends the recording with
//!    [`Simulation::finish_recording`] (a last keyframe, synced);
//! 2. measures the segment files on disk and what they hold, by record
//!    kind (keyframes, journal, tick hashes, framing);
//! 3. seeks `--seeks` times (default 100) to random recorded ticks, in
//!    random order, as an operator would, timing each
//!    [`Simulation::seek`] and checking its state hash against the recorded
//!    one;
//! 4. re-simulates the whole directory with [`verify`].
//!
//! One record per K. See `bench/README.md` for every field.

use std::path::{Path, PathBuf};
use std::time::Instant;

use inertia_protocol::input::quantize_input;
use inertia_protocol::input::GameInput;
use inertia_protocol::rng::SplitMix;
use inertia_protocol::{EntityId, PlayerInput};
use inertia_sandbox::buttons;
use inertia_server::record::{Record, RecordReader, RecorderConfig};
use inertia_server::replay::SimState;
use inertia_server::rules::SandboxRules;
use inertia_server::scene::{Scene, SceneFormat};
use inertia_server::sim::verify::verify;
use inertia_server::sim::{SimConfig, Simulation};

use crate::report::{logical_cores, median, note, progress, Measurement as Out, Sink};
use crate::{BenchError, Opts};

/// Minutes recorded by default (`--minutes`).
pub const DEFAULT_MINUTES: f64 = 10.0;
/// Seeks timed by default (`--seeks`).
pub const DEFAULT_SEEKS: u32 = 100;
/// Dynamic bodies by default (`--bodies`).
pub const DEFAULT_BODIES: u32 = 1000;
/// Clients by default (`--bots`).
pub const DEFAULT_BOTS: u32 = 8;
/// Keyframe intervals by default (`--keyframe-ticks`): the server's.
pub const DEFAULT_KEYFRAME_TICKS: [u64; 1] =
    [inertia_server::record::recorder::DEFAULT_KEYFRAME_TICKS];
/// Ticks per second.
pub const TICK_HZ: u32 = 60;
/// Hinged pendulums in the scene (counted in `--bodies`).
pub const PENDULUMS: u32 = 4;
/// A bot further than this from the middle walks home, m.
pub const HOME_RADIUS: f64 = 30.0;
/// Product targets: a seek's 99th percentile, ms.
pub const TARGET_SEEK_P99_MS: f64 = 100.0;
/// Product targets: bytes recorded per hour of play.
pub const TARGET_BYTES_PER_HOUR: f64 = 100e6;
/// Bytes a frame adds around its payload (kind, length, CRC; see the
/// layout in `inertia_server::record`).
const FRAME_OVERHEAD: u64 = 9;
/// Bytes of a segment file's header (magic, version).
const SEGMENT_HEADER: u64 = 8;
/// Records the recorder's channel holds. The server sizes it for real
/// time; this suite ticks as fast as the CPU allows, so it gives the
/// recorder thread more slack (a dropped record would end the recording).
const RECORDER_CAPACITY: usize = 1 << 16;
/// Keyframes decoded and restored alone, to time a seek's fixed part.
const RESTORES: usize = 10;
/// Balls per row and rows per layer in the ball pit.
const PIT_ROW: u32 = 25;
/// Bodies in a ten-row pyramid.
const PYRAMID_BODIES: u32 = 55;

/// The scene as RON (see `docs/scene-format.md`): `bodies` dynamic bodies
/// (at least [`PENDULUMS`] + 2) on a 120 m ground.
///
/// * Half the rest are wooden crates (0.8 m): ten-row pyramids standing
///   in rows east of the middle, three abreast, and what is left over in
///   one row to the north.
/// * The other half are balls (0.25 m) in layers of 25 × 25 on the floor
///   of a walled pit (20 m × 20 m, walls 1.5 m) west of the middle, where
///   an 18 m kinematic paddle turns at 0.4 rad/s and keeps stirring them.
/// * [`PENDULUMS`] heavy balls hang on hinges from static pivots 6 m up,
///   released 45° out, swinging over the open ground to the north.
///
/// Avatars spawn in the open middle, between the pit and the pyramids.
pub fn scene_ron(bodies: u32) -> Result<String, BenchError> {
    if bodies < PENDULUMS + 2 {
        return Err(format!("--bodies must be at least {}", PENDULUMS + 2).into());
    }
    let rest = bodies - PENDULUMS;
    let crates = rest / 2;
    let balls = rest - crates;
    let mut s = String::new();
    s.push_str(
        "(\n    name: \"replay\",\n    world: (gravity: (0.0, -9.81, 0.0), solver_substeps: 4, sleep: true,\n            bounds: (min: (-80.0, -20.0, -80.0), max: (80.0, 80.0, 80.0))),\n",
    );
    s.push_str("    spawn_points: [\n");
    for i in 0..8 {
        let (x, z) = (-1.5 + 3.0 * f64::from(i % 2), -6.0 + 4.0 * f64::from(i / 2));
        s.push_str(&format!("        ({x:.1}, 1.5, {z:.1}),\n"));
    }
    s.push_str("    ],\n    bodies: [\n");
    s.push_str(
        "        (name: \"ground\", kind: Static, shape: Cuboid(half_extents: (60.0, 0.5, 60.0)),\n         position: (0.0, -0.5, 0.0), friction: 0.8, color: (90, 95, 90, 255)),\n",
    );
    // The pit, inner x -24..-4, z -10..10.
    for (name, pos, half) in [
        ("pit_north", (-14.0, 0.75, -10.25), (10.5, 0.75, 0.25)),
        ("pit_south", (-14.0, 0.75, 10.25), (10.5, 0.75, 0.25)),
        ("pit_west", (-24.25, 0.75, 0.0), (0.25, 0.75, 10.0)),
        ("pit_east", (-3.75, 0.75, 0.0), (0.25, 0.75, 10.0)),
    ] {
        s.push_str(&format!(
            "        (name: \"{name}\", kind: Static, shape: Cuboid(half_extents: ({:.2}, {:.2}, {:.2})),\n         position: ({:.2}, {:.2}, {:.2})),\n",
            half.0, half.1, half.2, pos.0, pos.1, pos.2
        ));
    }
    s.push_str(
        "        (name: \"paddle\", kind: Kinematic, shape: Cuboid(half_extents: (9.0, 0.3, 0.15)),\n         position: (-14.0, 0.35, 0.0), angular_velocity: (0.0, 0.4, 0.0), color: (120, 140, 170, 255)),\n",
    );
    for i in 0..PENDULUMS {
        let x = -6.0 + 6.0 * f64::from(i);
        s.push_str(&format!(
            "        (name: \"pivot_{i}\", kind: Static, shape: Cuboid(half_extents: (0.2, 0.2, 0.2)),\n         position: ({x:.1}, 6.0, 16.0)),\n        (name: \"bob_{i}\", shape: Sphere(radius: 0.4), position: ({:.1}, 3.0, 16.0), density: 2000.0,\n         color: (200, 60, 60, 255)),\n",
            x + 3.0
        ));
    }
    s.push_str("    ],\n    generators: [\n");
    let crate_body = "body: (shape: Cuboid(half_extents: (0.4, 0.4, 0.4)), density: 450.0, friction: 0.7, color: (160, 110, 60, 255))";
    for i in 0..crates / PYRAMID_BODIES {
        let x = 10.0 + 10.0 * f64::from(i % 3);
        let z = -14.0 + 3.0 * f64::from(i / 3);
        s.push_str(&format!(
            "        Pyramid(name: \"pyramid_{i}\", rows: 10, origin: ({x:.1}, 0.0, {z:.1}), gap: 0.02,\n                {crate_body}),\n"
        ));
    }
    let left = crates % PYRAMID_BODIES;
    if left > 0 {
        s.push_str(&format!(
            "        Grid(name: \"crate\", counts: ({left}, 1, 1), spacing: (0.9, 0.0, 0.0),\n             origin: ({:.2}, 0.4, 22.0), {crate_body}),\n",
            -0.45 * f64::from(left - 1)
        ));
    }
    let ball_body = "body: (shape: Sphere(radius: 0.25), density: 300.0, friction: 0.5, restitution: 0.3, color: (200, 200, 210, 255))";
    let per_layer = PIT_ROW * PIT_ROW;
    let (layers, in_layer) = (balls / per_layer, balls % per_layer);
    let (x0, z0, y0, step) = (-22.4, -8.4, 0.3, 0.7);
    if layers > 0 {
        s.push_str(&format!(
            "        Grid(name: \"ball\", counts: ({PIT_ROW}, {layers}, {PIT_ROW}), spacing: ({step}, {step}, {step}),\n             origin: ({x0}, {y0}, {z0}), {ball_body}),\n"
        ));
    }
    let y = y0 + step * f64::from(layers);
    let (rows, last) = (in_layer / PIT_ROW, in_layer % PIT_ROW);
    if rows > 0 {
        s.push_str(&format!(
            "        Grid(name: \"ball_rows\", counts: ({PIT_ROW}, 1, {rows}), spacing: ({step}, 0.0, {step}),\n             origin: ({x0}, {y:.2}, {z0}), {ball_body}),\n"
        ));
    }
    if last > 0 {
        s.push_str(&format!(
            "        Grid(name: \"ball_last\", counts: ({last}, 1, 1), spacing: ({step}, 0.0, 0.0),\n             origin: ({x0}, {y:.2}, {:.2}), {ball_body}),\n",
            z0 + step * f64::from(rows)
        ));
    }
    s.push_str("    ],\n    joints: [\n");
    for i in 0..PENDULUMS {
        let x = -6.0 + 6.0 * f64::from(i);
        s.push_str(&format!(
            "        (a: \"pivot_{i}\", b: \"bob_{i}\", anchor: ({x:.1}, 6.0, 16.0), kind: Hinge(axis: (0.0, 0.0, 1.0))),\n"
        ));
    }
    s.push_str("    ],\n)\n");
    Ok(s)
}

/// One bot's stick, buttons and sequence.
struct Bot {
    client: u64,
    avatar: EntityId,
    rng: SplitMix,
    movement: [f64; 2],
    yaw: f64,
    push_ticks: u32,
    sequence: u32,
    /// Ticks left walking home.
    homing: u32,
}

impl Bot {
    fn new(client: u64, avatar: EntityId) -> Self {
        Bot {
            client,
            avatar,
            rng: SplitMix(0x5EED_0000 + client),
            movement: [0.0, 0.0],
            yaw: 0.0,
            push_ticks: 0,
            sequence: 0,
            homing: 0,
        }
    }

    /// Steers home when the avatar at `at` (x, z) has strayed.
    fn look(&mut self, at: Option<(f64, f64)>) {
        if let Some((x, z)) = at {
            let d = (x * x + z * z).sqrt();
            if d > HOME_RADIUS {
                self.movement = [-x / d, -z / d];
                self.homing = 120;
            }
        }
    }

    /// This tick's input, as quantized on the wire.
    fn input(&mut self, tick: u64) -> PlayerInput {
        let r = &mut self.rng;
        if self.homing > 0 {
            self.homing -= 1;
        } else {
            for m in &mut self.movement {
                *m = (0.995 * *m + r.range(-0.08, 0.08)).clamp(-1.0, 1.0);
            }
        }
        let [mx, mz] = self.movement;
        if mx.hypot(mz) > 0.2 {
            // Face roughly where it walks (yaw 0 faces +z).
            let want = mx.atan2(mz);
            let d = (want - self.yaw + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                - std::f64::consts::PI;
            self.yaw += 0.1 * d;
        }
        self.yaw += r.range(-0.03, 0.03);
        let mut b = 0;
        if r.uniform() < 1.0 / 180.0 {
            b |= buttons::JUMP;
        }
        if self.push_ticks == 0 && r.uniform() < 1.0 / 90.0 {
            self.push_ticks = 3;
        }
        if self.push_ticks > 0 {
            self.push_ticks -= 1;
            b |= buttons::PUSH;
        }
        self.sequence += 1;
        quantize_input(&PlayerInput {
            sequence: self.sequence,
            tick,
            payload: inertia_sandbox::SandboxInput {
                movement: [mx as f32, mz as f32],
                yaw: ((self.yaw + std::f64::consts::PI).rem_euclid(std::f64::consts::TAU)
                    - std::f64::consts::PI) as f32,
                buttons: b,
            }
            .to_payload(),
            view_behind: 0.0,
        })
    }
}

/// Nearest-rank percentile `p` (0–100) of a non-empty sample.
fn percentile(xs: &[f64], p: f64) -> f64 {
    crate::suites::physics::percentile(xs, p)
}

/// What the recording holds, by record kind: (records, bytes with framing).
#[derive(Debug, Default)]
struct Contents {
    files: u64,
    bytes: u64,
    keyframes: (u64, u64),
    journal: (u64, u64),
    hashes: (u64, u64),
    other: (u64, u64),
    keyframe_sizes: Vec<f64>,
    /// Per keyframe, unpacked: bytes of the world's save, of the rules'
    /// state, of the rest (entity table, spawn points, clients, header),
    /// and in all.
    keyframe_parts: Vec<[f64; 4]>,
}

fn contents(dir: &Path) -> Result<Contents, BenchError> {
    let reader = RecordReader::open(dir)?;
    let mut c = Contents::default();
    for f in reader.segment_files() {
        c.files += 1;
        c.bytes += f.bytes;
    }
    for record in reader.iter() {
        let record = record?;
        let framed = record.payload_len() + FRAME_OVERHEAD;
        let slot = match &record {
            Record::Keyframe { state, .. } => {
                c.keyframe_sizes.push(state.len() as f64);
                // Stored packed (zstd); the parts are of the unpacked state.
                let s = SimState::decode(state)?;
                let raw = s.encode().len() as f64;
                let (world, rules) = (s.world.len() as f64, s.rules.len() as f64);
                c.keyframe_parts
                    .push([world, rules, raw - world - rules, raw]);
                &mut c.keyframes
            }
            Record::Journal { .. } => &mut c.journal,
            Record::TickHash { .. } => &mut c.hashes,
            _ => &mut c.other,
        };
        slot.0 += 1;
        slot.1 += framed;
    }
    Ok(c)
}

/// A temporary recording directory, removed when dropped.
struct TempDir(PathBuf);

impl TempDir {
    fn new(tag: &str) -> Result<Self, BenchError> {
        let dir =
            std::env::temp_dir().join(format!("inertia-bench-replay-{}-{tag}", std::process::id()));
        if dir.exists() {
            std::fs::remove_dir_all(&dir)?;
        }
        Ok(TempDir(dir))
    }
}

impl Drop for TempDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

/// The suite's sizes, from the options.
#[derive(Debug, Clone, PartialEq)]
pub struct Plan {
    /// Ticks recorded.
    pub ticks: u64,
    /// Dynamic bodies.
    pub bodies: u32,
    /// Clients.
    pub bots: u32,
    /// Seeks timed per recording.
    pub seeks: u32,
    /// Keyframe intervals, one recording each.
    pub keyframe_ticks: Vec<u64>,
}

impl Plan {
    /// The sizes `opts` ask for (`--quick`: 12 s, 300 bodies, 20 seeks,
    /// K = 120).
    pub fn from_opts(opts: &Opts) -> Result<Self, BenchError> {
        let minutes = opts
            .minutes
            .unwrap_or(if opts.quick { 0.2 } else { DEFAULT_MINUTES });
        let ticks = (minutes * 60.0 * f64::from(TICK_HZ)).round();
        if !(2.0..1e9).contains(&ticks) {
            return Err(format!("--minutes {minutes} gives no ticks to seek in").into());
        }
        let keyframe_ticks = opts.keyframe_ticks.clone().unwrap_or_else(|| {
            if opts.quick {
                vec![120]
            } else {
                DEFAULT_KEYFRAME_TICKS.to_vec()
            }
        });
        if keyframe_ticks.is_empty() || keyframe_ticks.contains(&0) {
            return Err("--keyframe-ticks must be at least 1".into());
        }
        Ok(Plan {
            ticks: ticks as u64,
            bodies: opts
                .bodies
                .unwrap_or(if opts.quick { 300 } else { DEFAULT_BODIES }),
            bots: opts.bots.unwrap_or(DEFAULT_BOTS),
            seeks: opts
                .seeks
                .unwrap_or(if opts.quick { 20 } else { DEFAULT_SEEKS })
                .max(1),
            keyframe_ticks,
        })
    }
}

/// Runs the suite: one record per keyframe interval.
pub fn run(opts: &Opts, sink: &mut dyn Sink) -> Result<(), BenchError> {
    let plan = Plan::from_opts(opts)?;
    let text = scene_ron(plan.bodies)?;
    let scene = Scene::parse(&text, SceneFormat::Ron)?;
    let mut rows = Vec::new();
    for &k in &plan.keyframe_ticks {
        if !opts.wants(&format!("replay_k{k}")) {
            continue;
        }
        let r = run_one(&scene, &plan, k, sink)?;
        rows.push(r);
    }
    if rows.len() > 1 {
        let mut t = String::from(
            "keyframe_ticks  bytes_per_hour  keyframe_bytes  seek_ms_median  seek_ms_p99  seek_ms_max  verify_ticks_per_s\n",
        );
        for r in &rows {
            let f = |k: &str| {
                r.get(k)
                    .and_then(serde_json::Value::as_f64)
                    .unwrap_or(f64::NAN)
            };
            t.push_str(&format!(
                "{:>14}  {:>12.1} MB  {:>11.0} B  {:>14.2}  {:>11.2}  {:>11.2}  {:>18.0}\n",
                f("keyframe_ticks"),
                f("bytes_per_hour") / 1e6,
                f("keyframe_bytes_mean"),
                f("seek_ms_median"),
                f("seek_ms_p99"),
                f("seek_ms_max"),
                f("verify_ticks_per_s"),
            ));
        }
        eprint!("{t}");
    }
    Ok(())
}

/// Records, measures, seeks and verifies at keyframe interval `k`.
fn run_one(scene: &Scene, plan: &Plan, k: u64, sink: &mut dyn Sink) -> Result<Out, BenchError> {
    let dir = TempDir::new(&format!("k{k}"))?;
    let built = scene.build()?;
    let entities = built.entities.len();
    let config = SimConfig {
        recording: Some(RecorderConfig {
            keyframe_ticks: k,
            capacity: RECORDER_CAPACITY,
            ..RecorderConfig::new(&dir.0)
        }),
        record_at_start: true,
        max_clients: plan.bots.max(1),
        ..SimConfig::default()
    };
    let mut sim = Simulation::new(built, Box::new(SandboxRules::default()), config);
    if !sim.recording() {
        return Err(format!("cannot record into {}", dir.0.display()).into());
    }
    let mut bots = Vec::new();
    for i in 0..u64::from(plan.bots) {
        let client = i + 1;
        let avatar = sim
            .join(client)
            .map_err(|e| format!("bot {client} cannot join: {e}"))?;
        bots.push(Bot::new(client, avatar));
    }

    // 1. Record.
    let pb = progress(plan.ticks, &format!("replay K={k}: recording"));
    let mut tick_ms = Vec::with_capacity(plan.ticks as usize);
    let mut rejected = 0u64;
    let began = Instant::now();
    for t in 0..plan.ticks {
        if t % 30 == 0 {
            let frame = sim.frame();
            for b in &mut bots {
                let at = frame
                    .entities
                    .iter()
                    .find(|e| e.id == b.avatar)
                    .map(|e| (e.position.x, e.position.z));
                b.look(at);
            }
        }
        let now = sim.world().tick();
        for b in &mut bots {
            let input = b.input(now);
            if sim.input(b.client, &input).is_err() {
                rejected += 1;
            }
        }
        let t0 = Instant::now();
        sim.run_ticks(1);
        tick_ms.push(t0.elapsed().as_secs_f64() * 1e3);
        if t % 60 == 0 {
            pb.set_position(t);
        }
    }
    let record_wall_s = began.elapsed().as_secs_f64();
    pb.set_position(plan.ticks);
    let frame = sim.frame();
    let awake = frame
        .entities
        .iter()
        .filter(|e| !e.asleep && e.linear_velocity.length() > 1e-3)
        .count();
    let (history_keyframes, history_keyframe_bytes) =
        sim.history().map_or((0, 0), |h| h.keyframe_stats());
    let (history_checkpoints, history_checkpoint_bytes) =
        sim.history().map_or((0, 0), |h| h.checkpoint_stats());
    let t0 = Instant::now();
    sim.finish_recording();
    let finish_ms = t0.elapsed().as_secs_f64() * 1e3;
    pb.finish_and_clear();
    let gaps = sim
        .stats()
        .record_gaps
        .load(std::sync::atomic::Ordering::Relaxed);
    if gaps > 0 {
        return Err(format!("the recording has {gaps} gap(s): the recorder fell behind").into());
    }
    let live = sim.live_tick();

    // 2. Bytes.
    let c = contents(&dir.0)?;
    let per_hour = 3600.0 * f64::from(TICK_HZ) / plan.ticks as f64;
    let keyframe_bytes_mean = if c.keyframe_sizes.is_empty() {
        0.0
    } else {
        c.keyframe_sizes.iter().sum::<f64>() / c.keyframe_sizes.len() as f64
    };
    let part_mean = |i: usize| {
        c.keyframe_parts.iter().map(|p| p[i]).sum::<f64>() / c.keyframe_parts.len().max(1) as f64
    };

    let mean = |xs: &[f64]| xs.iter().sum::<f64>() / xs.len().max(1) as f64;

    // 3. Seeks, in random order over the recorded ticks (not the live one).
    let mut rng = SplitMix(0x5EE4 ^ k);
    let pb = progress(u64::from(plan.seeks), &format!("replay K={k}: seeking"));
    let mut seek_ms = Vec::new();
    let mut resimulated = Vec::new();
    let mut from_keyframe = 0u64;
    let mut mismatches = 0u64;
    for _ in 0..plan.seeks {
        let target = 1 + (rng.next_u64() % (live - 1));
        let t0 = Instant::now();
        let report = sim.seek(target)?;
        seek_ms.push(t0.elapsed().as_secs_f64() * 1e3);
        resimulated.push(report.resimulated as f64);
        if report.base_tick % k == 0 {
            from_keyframe += 1;
        }
        if report.recorded_hash != Some(report.state_hash) {
            mismatches += 1;
            note(
                &pb,
                &format!(
                    "seek to {target}: hash {:016x}, recorded {:?}",
                    report.state_hash, report.recorded_hash
                ),
            );
        }
        pb.inc(1);
    }
    pb.finish_and_clear();
    // What a seek's fixed part costs: decoding and restoring a keyframe,
    // timed alone on a few random ones (while the view is still shown, as
    // a seek does it).
    let held: Vec<_> = (0..RESTORES)
        .filter_map(|_| {
            let t = 1 + (rng.next_u64() % (live - 1));
            sim.history().and_then(|h| h.base_for(t))
        })
        .collect();
    let mut restore_ms = Vec::new();
    if sim.showing_history() {
        for k in &held {
            let t0 = Instant::now();
            let state = SimState::decode(&k.bytes)?;
            sim.restore(&state)?;
            restore_ms.push(t0.elapsed().as_secs_f64() * 1e3);
        }
    }
    sim.go_live();
    let restore_mean = mean(&restore_ms);
    let ms_per_tick = (seek_ms.iter().sum::<f64>() - restore_mean * seek_ms.len() as f64)
        / resimulated.iter().sum::<f64>().max(1.0);

    // 4. Verify.
    let pb = progress(live, &format!("replay K={k}: verifying"));
    let verified = verify(
        &dir.0,
        || Box::new(SandboxRules::default()),
        |tick, _| pb.set_position(tick),
    )?;
    pb.finish_and_clear();

    let bytes_per_hour = c.bytes as f64 * per_hour;
    let seek_p99 = percentile(&seek_ms, 99.0);
    let out = Out::new()
        .field("case", format!("replay_k{k}"))
        .field("scene", "replay")
        .field("threads", logical_cores() as u64)
        .field("bodies", plan.bodies)
        .field("entities", entities as u64)
        .field("bots", plan.bots)
        .field("ticks", plan.ticks)
        .field("minutes", plan.ticks as f64 / 60.0 / f64::from(TICK_HZ))
        .field("keyframe_ticks", k)
        .field("bytes", c.bytes)
        .num("bytes_per_hour", bytes_per_hour)
        .field("segments", c.files)
        .field("keyframes", c.keyframes.0)
        .num("keyframe_bytes_mean", keyframe_bytes_mean)
        .num(
            "keyframe_bytes_max",
            c.keyframe_sizes.iter().copied().fold(0.0, f64::max),
        )
        .num("keyframe_raw_bytes_mean", part_mean(3))
        .num("keyframe_world_bytes_mean", part_mean(0))
        .num("keyframe_rules_bytes_mean", part_mean(1))
        .num("keyframe_table_bytes_mean", part_mean(2))
        .num("keyframe_bytes_per_hour", c.keyframes.1 as f64 * per_hour)
        .num("journal_bytes_per_hour", c.journal.1 as f64 * per_hour)
        .num("hash_bytes_per_hour", c.hashes.1 as f64 * per_hour)
        .num(
            "other_bytes_per_hour",
            (c.other.1 + SEGMENT_HEADER * c.files) as f64 * per_hour,
        )
        .num(
            "journal_bytes_per_tick",
            c.journal.1 as f64 / plan.ticks as f64,
        )
        .field("seeks", plan.seeks)
        .num("seek_ms_median", median(&seek_ms))
        .num("seek_ms_p99", seek_p99)
        .num("seek_ms_max", seek_ms.iter().copied().fold(0.0, f64::max))
        .num("seek_ms_mean", mean(&seek_ms))
        .field("seek_ms", seek_ms.clone())
        .field("seek_hash_mismatches", mismatches)
        .num("seek_resimulated_mean", mean(&resimulated))
        .num(
            "seek_resimulated_max",
            resimulated.iter().copied().fold(0.0, f64::max),
        )
        .field("seeks_from_keyframe", from_keyframe)
        .num("seek_restore_ms_mean", restore_mean)
        .num("seek_ms_per_resimulated_tick", ms_per_tick)
        .field("history_keyframes", history_keyframes as u64)
        .field("history_keyframe_bytes", history_keyframe_bytes as u64)
        .field("history_checkpoints", history_checkpoints as u64)
        .field("history_checkpoint_bytes", history_checkpoint_bytes as u64)
        .num("verify_ticks_per_s", verified.ticks_per_second())
        .field("verify_ticks", verified.ticks)
        .field("verify_hashes_checked", verified.hashes_checked)
        .field("verify_keyframes_checked", verified.keyframes_checked)
        .field("verify_mismatches", verified.mismatch_count)
        .num("tick_ms_mean", mean(&tick_ms))
        .num("tick_ms_p50", median(&tick_ms))
        .num("tick_ms_p99", percentile(&tick_ms, 99.0))
        .num("tick_ms_max", tick_ms.iter().copied().fold(0.0, f64::max))
        .num("record_wall_s", record_wall_s)
        .num("finish_ms", finish_ms)
        .field("inputs_rejected", rejected)
        .field("moving_at_end", awake as u64)
        .field(
            "meets_targets",
            seek_p99 <= TARGET_SEEK_P99_MS && bytes_per_hour <= TARGET_BYTES_PER_HOUR,
        );
    sink.record(out.clone());
    if mismatches > 0 || verified.mismatch_count > 0 {
        return Err(format!(
            "K={k}: {mismatches} seek(s) and {} verified tick(s) did not match the recorded hash",
            verified.mismatch_count
        )
        .into());
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scene_has_the_bodies_asked_for() {
        for bodies in [6, 57, 300, 1000, 1633] {
            let scene = Scene::parse(&scene_ron(bodies).unwrap(), SceneFormat::Ron).unwrap();
            let built = scene.build().unwrap();
            // Every body is an entity: the dynamic ones, the ground, the
            // pit's four walls, the paddle and the pendulums' pivots.
            assert_eq!(
                built.entities.len() as u32,
                bodies + 6 + PENDULUMS,
                "{bodies}"
            );
        }
        assert!(scene_ron(5).is_err());
    }

    #[test]
    fn bot_inputs_are_quantized_and_in_sequence() {
        let mut bot = Bot::new(3, 1);
        for t in 0..500 {
            let i = bot.input(t);
            assert_eq!(i, quantize_input(&i));
            assert_eq!(i.sequence, t as u32 + 1);
            let sandbox = inertia_sandbox::SandboxInput::from_payload(&i.payload).unwrap();
            assert!(sandbox.buttons & !buttons::ALL == 0);
        }
    }
}
