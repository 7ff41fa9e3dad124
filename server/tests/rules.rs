//! The sandbox rules under scripted inputs: an avatar walks, jumps once
//! when standing, cannot fly by spamming jump, pushes a crate, and bad
//! inputs are refused or clamped.

use inertia_protocol::input::GameInput;
use inertia_protocol::input::InputBuffer;
use inertia_protocol::message::GameMessage;
use inertia_protocol::{EntityKind, PlayerInput};
use inertia_sandbox::buttons;
use inertia_sandbox::SandboxEvent;
use inertia_server::rules::{InputRefusal, JoinRefusal, SandboxRules};
use inertia_server::scene::{Scene, SceneFormat};
use inertia_server::sim::{SimConfig, Simulation};

const FLAT: &str = r#"(
    spawn_points: [(0.0, 1.0, 0.0), (3.0, 1.0, 0.0)],
    bodies: [
        (name: "ground", kind: Static, shape: Cuboid(half_extents: (50.0, 0.5, 50.0)), position: (0.0, -0.5, 0.0)),
        (name: "crate", shape: Cuboid(half_extents: (0.4, 0.4, 0.4)), position: (0.0, 0.4, 3.0), density: 200.0),
    ],
)"#;

/// The sandbox's events among a frame's recent messages, with their ticks.
fn events(frame: &inertia_server::sim::Frame) -> Vec<(u64, SandboxEvent)> {
    frame
        .messages
        .iter()
        .map(|m| {
            (
                m.tick,
                SandboxEvent::decode(&m.message.bytes).expect("a sandbox event"),
            )
        })
        .collect()
}

fn sim(max_clients: u32) -> Simulation {
    let built = Scene::parse(FLAT, SceneFormat::Ron)
        .unwrap()
        .build()
        .unwrap();
    let config = SimConfig {
        max_clients,
        ..SimConfig::default()
    };
    Simulation::new(built, Box::new(SandboxRules::default()), config)
}

struct Player {
    client: u64,
    sequence: u32,
}

impl Player {
    fn send(&mut self, sim: &mut Simulation, movement: [f32; 2], yaw: f32, buttons: u8) {
        self.sequence += 1;
        let input = PlayerInput {
            sequence: self.sequence,
            tick: sim.world().tick(),
            payload: inertia_sandbox::SandboxInput {
                movement,
                yaw,
                buttons,
            }
            .to_payload(),
            view_behind: 0.0,
        };
        sim.input(self.client, &input).unwrap();
    }
}

fn avatar_pos(sim: &Simulation, avatar: u32) -> inertia_physics::glam::DVec3 {
    let h = sim.entities().body(avatar).unwrap();
    sim.world().body(h).unwrap().center_of_mass()
}

fn settle(sim: &mut Simulation) {
    sim.run_ticks(60);
}

#[test]
fn avatar_walks_where_it_is_told() {
    let mut sim = sim(4);
    let avatar = sim.join(7).unwrap();
    let e = sim.entities().get(avatar).unwrap();
    assert_eq!(e.desc.kind, EntityKind::Avatar);
    assert_eq!(e.desc.owner, Some(7));
    settle(&mut sim);
    let start = avatar_pos(&sim, avatar);
    let mut p = Player {
        client: 7,
        sequence: 0,
    };
    for _ in 0..120 {
        p.send(&mut sim, [1.0, 0.0], 0.0, 0);
        sim.run_ticks(1);
    }
    let end = avatar_pos(&sim, avatar);
    let moved = end - start;
    // Two seconds at up to 6 m/s along +x, after a short acceleration.
    assert!(moved.x > 8.0 && moved.x < 12.5, "moved {moved}");
    assert!(moved.z.abs() < 0.5, "drifted {moved}");
    assert!((end.y - start.y).abs() < 0.1, "stayed on the ground: {end}");
    let h = sim.entities().body(avatar).unwrap();
    let v = sim.world().body(h).unwrap().linear_velocity();
    assert!((v.x - 6.0).abs() < 0.3, "top speed {v}");
    // Let go of the stick: the controller brakes.
    for _ in 0..60 {
        p.send(&mut sim, [0.0, 0.0], 0.0, 0);
        sim.run_ticks(1);
    }
    let v = sim.world().body(h).unwrap().linear_velocity();
    assert!(v.length() < 0.2, "stopped: {v}");
    let frame = sim.frame();
    assert!(frame.entities.iter().any(|s| s.id == avatar));
    assert!(frame.catalog.contains_key(&avatar));
}

#[test]
fn jumps_once_when_grounded_and_cannot_fly() {
    let mut sim = sim(4);
    let avatar = sim.join(1).unwrap();
    settle(&mut sim);
    let ground_y = avatar_pos(&sim, avatar).y;
    let mut p = Player {
        client: 1,
        sequence: 0,
    };
    // Hold jump for a second: one jump, on the press.
    let mut peak = ground_y;
    for _ in 0..60 {
        p.send(&mut sim, [0.0, 0.0], 0.0, buttons::JUMP);
        sim.run_ticks(1);
        peak = peak.max(avatar_pos(&sim, avatar).y);
    }
    let jumps = events(&sim.frame())
        .iter()
        .filter(|(_, e)| matches!(e, SandboxEvent::Jumped { .. }))
        .count();
    assert_eq!(jumps, 1, "holding the button jumps once");
    let rise = peak - ground_y;
    // v = 5.5 m/s reaches v²/2g ≈ 1.54 m.
    assert!(rise > 1.2 && rise < 1.8, "rise {rise}");

    // Spam: press and release every tick for three seconds.
    p.send(&mut sim, [0.0, 0.0], 0.0, 0);
    settle(&mut sim);
    let mut peak = ground_y;
    let spam_from = sim.frame().tick;
    for i in 0..180 {
        let b = if i % 2 == 0 { buttons::JUMP } else { 0 };
        p.send(&mut sim, [0.0, 0.0], 0.0, b);
        sim.run_ticks(1);
        peak = peak.max(avatar_pos(&sim, avatar).y);
    }
    let rise = peak - ground_y;
    assert!(
        rise < 1.8,
        "spamming jump must not climb higher than one jump: {rise}"
    );
    let jumps = events(&sim.frame())
        .iter()
        .filter(|(tick, e)| *tick > spam_from && matches!(e, SandboxEvent::Jumped { .. }))
        .count();
    // Each jump takes about 1.1 s in the air: at most three in 3 s.
    assert!((1..=3).contains(&jumps), "{jumps} jumps, rise {rise}");
}

#[test]
fn push_moves_the_crate_within_limits() {
    let mut sim = sim(4);
    let avatar = sim.join(1).unwrap();
    settle(&mut sim);
    let mut p = Player {
        client: 1,
        sequence: 0,
    };
    // Walk up to the crate (at z = 3), facing +z (yaw 0).
    for _ in 0..200 {
        let z = avatar_pos(&sim, avatar).z;
        if z > 1.7 {
            break;
        }
        p.send(&mut sim, [0.0, 0.4], 0.0, 0);
        sim.run_ticks(1);
    }
    p.send(&mut sim, [0.0, 0.0], 0.0, 0);
    sim.run_ticks(10);
    sim.frame();
    p.send(&mut sim, [0.0, 0.0], 0.0, buttons::PUSH);
    sim.run_ticks(1);
    let frame = sim.frame();
    let pushed: Vec<_> = events(&frame)
        .into_iter()
        .filter_map(|(_, e)| match e {
            SandboxEvent::Pushed {
                target, impulse, ..
            } => Some((target, impulse)),
            _ => None,
        })
        .collect();
    assert_eq!(pushed.len(), 1, "{:?}", events(&frame));
    let crate_h = sim.entities().body(pushed[0].0).unwrap();
    let b = sim.world().body(crate_h).unwrap();
    let v = b.linear_velocity();
    assert!(v.z > 1.0, "the crate moves away: {v}");
    assert!(v.length() <= 12.0 + 1e-6, "capped by the context: {v}");
}

#[test]
fn bad_inputs_are_refused_or_clamped() {
    let mut sim = sim(4);
    let avatar = sim.join(1).unwrap();
    settle(&mut sim);
    // A tick that has passed: the input is applied, and checked, at once
    // (one for a tick to come waits for it, and is checked then).
    let tick = sim.world().tick() - 1;
    // Bytes the sandbox's input never has: an undefined button, and a
    // payload of another game's size.
    for bytes in [&[0x7f, 0x7f, 0, 0xf0, 0x0f][..], &[0; 3]] {
        let junk = PlayerInput {
            sequence: 1,
            tick,
            payload: inertia_protocol::input::InputPayload::new(bytes).unwrap(),
            ..PlayerInput::default()
        };
        assert!(matches!(
            sim.input(1, &junk),
            Err(InputRefusal::Undecodable(_))
        ));
    }
    assert!(matches!(
        sim.input(2, &PlayerInput::default()),
        Err(InputRefusal::NotJoined(2))
    ));
    let huge = PlayerInput {
        sequence: 2,
        tick,
        payload: inertia_sandbox::SandboxInput {
            movement: [1e30, 1e30],
            yaw: 1e20,
            buttons: !(buttons::JUMP | buttons::PUSH),
        }
        .to_payload(),
        view_behind: 0.0,
    };
    sim.input(1, &huge).unwrap();
    sim.run_ticks(120);
    let h = sim.entities().body(avatar).unwrap();
    let v = sim.world().body(h).unwrap().linear_velocity();
    let horizontal = (v.x * v.x + v.z * v.z).sqrt();
    assert!(horizontal <= 6.0 + 0.1, "clamped to top speed: {v}");
    assert!(v.y.abs() < 0.5, "no flight from junk buttons: {v}");
    // Replays and reordering are refused before the rules see them: the
    // connection's input buffer hands each sequence on once, in order.
    let mut buffer = InputBuffer::new(16);
    buffer.push(huge);
    buffer.push(PlayerInput {
        sequence: 1,
        ..huge
    });
    buffer.push(huge);
    assert_eq!(buffer.pop().map(|i| i.sequence), Some(2));
    assert_eq!(
        buffer.pop(),
        None,
        "the replay and the older input are dropped"
    );
    let old = PlayerInput {
        sequence: 3,
        tick: 0,
        ..PlayerInput::default()
    };
    assert!(matches!(
        sim.input(1, &old),
        Err(InputRefusal::Stale { .. })
    ));
    let ahead = PlayerInput {
        sequence: 4,
        tick: sim.world().tick() + 10_000,
        ..PlayerInput::default()
    };
    assert!(matches!(
        sim.input(1, &ahead),
        Err(InputRefusal::Future { .. })
    ));
    // The five the simulation refused (two undecodable, not joined, too
    // old, too far ahead); the buffer counted the replay and the
    // reordering.
    assert_eq!(
        sim.stats()
            .inputs_rejected
            .load(std::sync::atomic::Ordering::Relaxed),
        5
    );
}

#[test]
fn joining_leaving_and_the_client_cap() {
    let mut sim = sim(2);
    let a = sim.join(1).unwrap();
    let b = sim.join(2).unwrap();
    assert_ne!(a, b);
    assert_eq!(sim.join(1), Err(JoinRefusal::AlreadyJoined(1)));
    assert_eq!(sim.join(3), Err(JoinRefusal::Full { max: 2 }));
    // Two avatars do not start inside each other.
    let d = (avatar_pos(&sim, a) - avatar_pos(&sim, b)).length();
    assert!(d > 0.7, "{d}");
    let v0 = sim.frame().catalog_version;
    sim.leave(1);
    let f = sim.frame();
    assert!(f.catalog_version != v0);
    assert!(!f.catalog.contains_key(&a));
    assert!(events(&f)
        .iter()
        .any(|(_, e)| matches!(e, SandboxEvent::Left { client: 1 })));
    assert!(sim.join(3).is_ok());
}

#[test]
fn an_avatar_that_falls_off_the_world_comes_back() {
    let text = r#"(
        world: (bounds: (min: (-20.0, -10.0, -20.0), max: (20.0, 50.0, 20.0))),
        spawn_points: [(0.0, 1.0, 0.0)],
        bodies: [(name: "ground", kind: Static, shape: Cuboid(half_extents: (2.0, 0.5, 2.0)), position: (0.0, -0.5, 0.0))],
    )"#;
    let built = Scene::parse(text, SceneFormat::Ron)
        .unwrap()
        .build()
        .unwrap();
    let mut sim = Simulation::new(
        built,
        Box::new(SandboxRules::default()),
        SimConfig::default(),
    );
    let first = sim.join(1).unwrap();
    let mut p = Player {
        client: 1,
        sequence: 0,
    };
    let mut respawned = None;
    for _ in 0..600 {
        p.send(&mut sim, [1.0, 0.0], 0.0, 0);
        sim.run_ticks(1);
        for (_, e) in events(&sim.frame()) {
            if let SandboxEvent::Respawned { avatar, .. } = e {
                respawned = Some(avatar);
            }
        }
        if respawned.is_some() {
            break;
        }
    }
    let second = respawned.expect("the avatar walked off the edge and came back");
    assert_ne!(first, second);
    assert!(sim.entities().get(first).is_none());
}
