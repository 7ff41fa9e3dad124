//! `bandwidth`: Glenn Fiedler's snapshot-compression scene ("Snapshot
//! Compression", gafferongames.com, 2015) built in our engine and streamed
//! through our snapshot codec over a simulated lossy link.
//!
//! The scene: a 30 × 30 grid of small cubes resting on the ground and one
//! larger player cube, driven by a control force and torque along a
//! figure of eight through the grid, rolling and pushing the others
//! around: 901 entities, stepped at 60 Hz. Every tick the server codes one
//! snapshot for one client and sends it through a [`SimLink`] (50 ms
//! delay, ±5 ms jitter, 5 % loss); the client decodes it and acknowledges
//! through a second link back.
//!
//! The server holds the client to a bandwidth budget: a token bucket that
//! fills at [`BUDGET_KBPS`] and holds at most one datagram, so each
//! snapshot may use what the previous ones left. Within it the priority
//! accumulator decides what goes out.
//!
//! Measured: datagram payload bandwidth (snapshot bytes only, as
//! Fiedler's figures; add 32 bytes a packet for UDP/IP headers, his rule
//! of thumb), and the error of the client's view against the server's
//! unquantized truth of the same tick, over every entity of every
//! snapshot decoded.

use std::time::Instant;

use inertia_physics::glam::{DQuat, DVec3};
use inertia_physics::rigid::body::RigidBodyDesc;
use inertia_physics::rigid::pose::Pose;
use inertia_physics::rigid::shape::Shape;
use inertia_physics::{BodyHandle, World, WorldConfig};
use inertia_protocol::{
    EntityState, Interest, PositionGrid, PriorityAccumulator, SimLink, SimLinkConfig,
    SnapshotConfig, SnapshotDecoder, SnapshotEncoder,
};

use crate::report::{logical_cores, progress, Measurement, Sink, Suspended};
use crate::{BenchError, Opts};

/// Snapshots (and physics steps) per second.
pub const SNAPSHOT_HZ: u32 = 60;
/// Seconds streamed by default (`--seconds`).
pub const DEFAULT_SECONDS: u32 = 20;
/// The client's bandwidth budget, kbit/s (Fiedler's target).
pub const BUDGET_KBPS: f64 = 256.0;
/// One-way link delay, s.
pub const DELAY: f64 = 0.05;
/// Link jitter (uniform, ±), s.
pub const JITTER: f64 = 0.005;
/// Packet loss each way.
pub const LOSS: f64 = 0.05;
/// Cubes along each side of the grid.
pub const GRID: u32 = 30;
/// Half the edge of a small cube, m.
pub const CUBE_HALF: f64 = 0.25;
/// Distance between neighbouring small cubes' centres, m.
pub const SPACING: f64 = 1.0;
/// Half the edge of the player cube, m.
pub const PLAYER_HALF: f64 = 0.75;
/// The player's mean speed along its path, m/s.
pub const PLAYER_SPEED: f64 = 4.0;
/// Half the width of the player's figure of eight along X (it starts
/// outside the grid, at `x = -PATH_X`), m.
pub const PATH_X: f64 = 17.0;
/// Half its depth along Z, m.
pub const PATH_Z: f64 = 9.0;
/// How hard the player is steered to its path's velocity, 1/s.
pub const STEER_GAIN: f64 = 8.0;
/// Seconds the cubes settle (and fall asleep) before streaming starts.
pub const SETTLE: f64 = 1.0;

/// Fiedler's uncompressed starting point, bits a cube: orientation 4 ×
/// f32 (128) + linear velocity 3 × f32 (96) + position 3 × f32 (96) +
/// interacting bool (1).
pub const FIEDLER_BITS_PER_CUBE: f64 = 321.0;
/// His rule of thumb for UDP/IP header overhead, bytes a packet.
pub const FIEDLER_HEADER_BYTES: f64 = 32.0;

/// The codec's settings for this scene: 1 mm grid within ±256 m, 11-bit
/// rotation components, no velocities (the client interpolates between
/// snapshots 1/60 s apart), 1200-byte datagrams.
pub fn codec_config() -> SnapshotConfig {
    SnapshotConfig {
        grid: PositionGrid {
            resolution: 0.001,
            bound: 256.0,
        },
        rotation_bits: 11,
        velocities: false,
        ..SnapshotConfig::default()
    }
}

/// The scene: the world, the small cubes' handles (ids 0..900) and the
/// player's (id 900).
struct CubeScene {
    world: World,
    bodies: Vec<BodyHandle>,
    player: BodyHandle,
}

fn build() -> Result<CubeScene, BenchError> {
    let mut world = World::new(WorldConfig::default())?;
    world.set_gravity(DVec3::new(0.0, -9.81, 0.0))?;
    world.add_body(&RigidBodyDesc::fixed(
        Shape::cuboid(DVec3::new(100.0, 1.0, 100.0))?,
        Pose::new(DVec3::new(0.0, -1.0, 0.0), DQuat::IDENTITY),
    ))?;
    let half = f64::from(GRID - 1) * SPACING / 2.0;
    let mut bodies = Vec::new();
    for row in 0..GRID {
        for col in 0..GRID {
            let p = DVec3::new(
                f64::from(col) * SPACING - half,
                CUBE_HALF,
                f64::from(row) * SPACING - half,
            );
            let mut d = RigidBodyDesc::dynamic(
                Shape::cuboid(DVec3::splat(CUBE_HALF))?,
                500.0,
                Pose::new(p, DQuat::IDENTITY),
            )?;
            d.friction_static = 0.6;
            d.friction_dynamic = 0.6;
            bodies.push(world.add_body(&d)?);
        }
    }
    let start = path(0.0).0 + DVec3::Y * PLAYER_HALF;
    let mut d = RigidBodyDesc::dynamic(
        Shape::cuboid(DVec3::splat(PLAYER_HALF))?,
        1000.0,
        Pose::new(start, DQuat::IDENTITY),
    )?;
    d.can_sleep = false;
    d.friction_static = 0.6;
    d.friction_dynamic = 0.6;
    let player = world.add_body(&d)?;
    bodies.push(player);
    Ok(CubeScene {
        world,
        bodies,
        player,
    })
}

/// The player's path at time `t` (s): a figure of eight across the grid,
/// point on the ground (m) and velocity (m/s).
fn path(t: f64) -> (DVec3, DVec3) {
    let (a, b) = (PATH_X, PATH_Z);
    // Angular rate for a mean speed of about PLAYER_SPEED (the curve's
    // length is about 6.1 (a + b) for these proportions).
    let w = PLAYER_SPEED * 2.0 * std::f64::consts::PI / (6.1 * (a + b));
    // Starts at (-a, 0, 0), outside the grid.
    let phase = w * t - std::f64::consts::FRAC_PI_2;
    let p = DVec3::new(a * phase.sin(), 0.0, b * (2.0 * phase).sin());
    let v = DVec3::new(a * w * phase.cos(), 0.0, 2.0 * b * w * (2.0 * phase).cos());
    (p, v)
}

/// Steers the player: a force towards its point on the path, matched to
/// the path's velocity, and a torque that rolls it the way it goes.
fn drive(scene: &mut CubeScene, t: f64) -> Result<(), BenchError> {
    let b = scene.world.body(scene.player).ok_or("player vanished")?;
    let (target, target_v) = path(t);
    let x = b.center_of_mass() * DVec3::new(1.0, 0.0, 1.0);
    let v = b.linear_velocity() * DVec3::new(1.0, 0.0, 1.0);
    let want_v = target_v + (target - x) * 2.0;
    let force = (want_v - v) * b.mass() * STEER_GAIN;
    let roll = DVec3::Y.cross(want_v) / PLAYER_HALF;
    let torque = (roll - b.angular_velocity()) * b.mass() * PLAYER_HALF * PLAYER_HALF;
    scene.world.set_body_control(scene.player, force, torque)?;
    Ok(())
}

/// Every body's state, ascending by entity id.
fn states(scene: &CubeScene) -> Vec<EntityState> {
    scene
        .bodies
        .iter()
        .enumerate()
        .filter_map(|(id, h)| {
            let b = scene.world.body(*h)?;
            let pose = b.pose();
            Some(EntityState {
                id: id as u32,
                position: pose.translation,
                rotation: pose.rotation,
                linear_velocity: b.linear_velocity(),
                angular_velocity: b.angular_velocity(),
                asleep: b.is_sleeping(),
            })
        })
        .collect()
}

/// The `p`-quantile of `xs` (sorted here), 0 for none.
pub(crate) fn quantile(xs: &mut [f64], p: f64) -> f64 {
    if xs.is_empty() {
        return 0.0;
    }
    xs.sort_by(f64::total_cmp);
    xs[((xs.len() - 1) as f64 * p).round() as usize]
}

/// Runs the scene for `--seconds` (default [`DEFAULT_SECONDS`]; 3 with
/// `--quick`) and reports one record.
pub fn run(opts: &Opts, sink: &mut dyn Sink) -> Result<(), BenchError> {
    if !opts.wants("fiedler_cubes") {
        return Ok(());
    }
    let seconds = opts
        .seconds
        .unwrap_or(if opts.quick { 3 } else { DEFAULT_SECONDS });
    let ticks = u64::from(seconds * SNAPSHOT_HZ);
    let dt = 1.0 / f64::from(SNAPSHOT_HZ);
    let config = codec_config();
    let link = SimLinkConfig {
        delay: DELAY,
        jitter: JITTER,
        loss: LOSS,
        duplicate: 0.0,
    };
    let mut down = SimLink::new(link, 0x5A)?;
    let mut up = SimLink::new(link, 0xAC)?;
    let mut encoder = SnapshotEncoder::new(config)?;
    let mut decoder = SnapshotDecoder::new(config)?;
    let mut interest = Interest::everything();
    // The player's cube is the client's avatar.
    interest.always_relevant.insert(GRID * GRID);
    let mut priorities = PriorityAccumulator::new(interest);
    let mut scene = build()?;
    // Fiedler's cubes start at rest: let ours settle and fall asleep, the
    // player waiting at the start of its path.
    let settle_ticks = (SETTLE * f64::from(SNAPSHOT_HZ)).round() as u64;
    for _ in 0..settle_ticks {
        drive(&mut scene, 0.0)?;
        scene.world.step(dt)?;
    }
    let n = scene.bodies.len();

    let bucket_max = config.max_datagram as f64;
    let fill = BUDGET_KBPS * 1000.0 / 8.0 / f64::from(SNAPSHOT_HZ);
    let mut tokens = fill;
    // The truth each snapshot described, by sequence (a ring longer than
    // any snapshot stays in flight).
    let mut truth: Vec<Option<(u16, Vec<EntityState>)>> = vec![None; 256];
    let mut bits_per_snapshot = Vec::with_capacity(ticks as usize);
    let (mut pos_err, mut rot_err) = (Vec::new(), Vec::new());
    let (mut deferred, mut limited, mut full_view_at) = (0u64, 0u64, None);
    let mut full_view_tick = ticks;
    let mut max_moving = 0usize;

    let pb = progress(ticks, "bandwidth fiedler_cubes");
    let started = Instant::now();
    for tick in 1..=ticks {
        let now = tick as f64 * dt;
        drive(&mut scene, now)?;
        scene.world.step(dt)?;
        let world = states(&scene);
        max_moving = max_moving.max(world.iter().filter(|e| !e.asleep).count());

        tokens = (tokens + fill).min(bucket_max);
        let bytes = encoder.encode(
            settle_ticks + tick,
            1.0,
            false,
            &world,
            &mut priorities,
            tokens as usize,
        );
        tokens -= bytes.len() as f64;
        let report = encoder.last_report();
        deferred += report.deferred as u64;
        limited += u64::from(report.deferred > 0);
        bits_per_snapshot.push(bytes.len() as f64 * 8.0);
        truth[usize::from(report.sequence) % 256] = Some((report.sequence, world));
        down.send(now, bytes);

        for packet in down.receive(now) {
            let Ok(got) = decoder.decode(&packet) else {
                continue;
            };
            let Some((_, truth)) = truth[usize::from(got.sequence) % 256]
                .as_ref()
                .filter(|(s, _)| *s == got.sequence)
            else {
                continue;
            };
            let Some(view) = decoder.entities(got.sequence) else {
                continue;
            };
            if view.len() == n && full_view_at.is_none() {
                full_view_at = Some(now);
                full_view_tick = tick;
            }
            for v in &view {
                let t = &truth[v.id as usize];
                pos_err.push((v.position - t.position).length() * 1e3);
                let dot = v.rotation.dot(t.rotation).abs().min(1.0);
                rot_err.push((2.0 * dot.acos()).to_degrees());
            }
            let (newest, bits) = decoder.ack_state();
            let mut ack = newest.unwrap_or(0).to_le_bytes().to_vec();
            ack.extend_from_slice(&bits.to_le_bytes());
            up.send(now, ack);
        }
        for ack in up.receive(now) {
            encoder.on_ack(u16::from_le_bytes([ack[0], ack[1]]));
        }
        pb.inc(1);
    }
    pb.finish_and_clear();
    let wall = started.elapsed().as_secs_f64();

    let hz = f64::from(SNAPSHOT_HZ);
    let kbps = |bits: f64| bits * hz / 1000.0;
    let mean = |xs: &[f64]| xs.iter().sum::<f64>() / xs.len().max(1) as f64;
    let mean_bits = mean(&bits_per_snapshot);
    // After the client's view first held every entity: the join's burst
    // left out.
    let steady_bits = mean(&bits_per_snapshot[full_view_tick as usize..]);
    let mut windows: Vec<f64> = bits_per_snapshot
        .chunks(SNAPSHOT_HZ as usize)
        .filter(|w| w.len() == SNAPSHOT_HZ as usize)
        .map(|w| w.iter().sum::<f64>() / 1000.0)
        .collect();
    let window_max = windows.iter().copied().fold(0.0, f64::max);
    // In time order, before the quantile sorts them.
    let per_second = windows.clone();
    let uncompressed = f64::from(GRID * GRID + 1) * FIEDLER_BITS_PER_CUBE * hz / 1000.0
        + FIEDLER_HEADER_BYTES * 8.0 * hz / 1000.0;
    let stats = decoder.stats();
    let mut out = Suspended::new(&pb, sink);
    out.record(
        Measurement::new()
            .field("case", "fiedler_cubes")
            .field("scene", "fiedler_cubes")
            .field("entities", n)
            .field("seconds", seconds)
            .field("snapshot_hz", SNAPSHOT_HZ)
            .num("loss", LOSS)
            .num("delay_ms", DELAY * 1e3)
            .num("jitter_ms", JITTER * 1e3)
            .num("budget_kbps", BUDGET_KBPS)
            .num("uncompressed_kbps", uncompressed)
            .field(
                "uncompressed_basis",
                "901 cubes x 321 bits (quat 4xf32, velocity 3xf32, position 3xf32, bool) + 32-byte UDP/IP header, x 60 Hz",
            )
            .num("kbps_mean", kbps(mean_bits))
            .num("kbps_mean_after_join", kbps(steady_bits))
            .num("kbps_mean_with_headers", kbps(mean_bits + FIEDLER_HEADER_BYTES * 8.0))
            .num("kbps_p95", kbps(quantile(&mut bits_per_snapshot, 0.95)))
            .num("kbps_p95_1s", quantile(&mut windows, 0.95))
            .num("kbps_max_1s", window_max)
            .field("kbps_per_s", per_second)
            .num("bytes_per_snapshot_mean", mean_bits / 8.0)
            .num("pos_err_mm_p99", quantile(&mut pos_err, 0.99))
            .num("pos_err_mm_max", pos_err.last().copied().unwrap_or(0.0))
            .num("rot_err_deg_p99", quantile(&mut rot_err, 0.99))
            .num("rot_err_deg_max", rot_err.last().copied().unwrap_or(0.0))
            .field("error_samples", pos_err.len())
            .num(
                "budget_limited_pct",
                100.0 * limited as f64 / bits_per_snapshot.len() as f64,
            )
            .num("deferred_per_snapshot", deferred as f64 / ticks as f64)
            .field("moving_max", max_moving)
            .num("full_view_after_s", full_view_at.unwrap_or(f64::NAN))
            .field("snapshots_sent", ticks)
            .field("snapshots_decoded", stats.decoded)
            .field("missing_baseline", stats.missing_baseline)
            .num("grid_mm", config.grid.resolution * 1e3)
            .field("rotation_bits", config.rotation_bits)
            .field("velocities", config.velocities)
            .field("threads", logical_cores())
            .num("wall_s", wall),
    );
    Ok(())
}
