use super::*;
use inertia_protocol::input::GameInput;
use inertia_protocol::{EntityDesc, ShapeDesc};
use inertia_sandbox::SandboxInput;

const CLIENT: u64 = 1;
const AVATAR: EntityId = 2;

fn desc(id: EntityId, kind: EntityKind, shape: ShapeDesc, at: [f64; 3]) -> EntityDesc {
    EntityDesc {
        id,
        kind,
        shape,
        color: [255; 4],
        owner: (kind == EntityKind::Avatar).then_some(CLIENT),
        name: String::new(),
        position: at,
        rotation: [0.0, 0.0, 0.0, 1.0],
    }
}

/// A floor and the own avatar standing on it.
fn table() -> KnownEntities {
    let mut t = KnownEntities::new();
    t.spawn(desc(
        1,
        EntityKind::Static,
        ShapeDesc::Cuboid {
            half_extents: [50.0, 0.5, 50.0],
        },
        [0.0, -0.5, 0.0],
    ));
    t.spawn(desc(
        AVATAR,
        EntityKind::Avatar,
        ShapeDesc::Capsule {
            half_height: 0.55,
            radius: 0.35,
        },
        [0.0, 0.9, 0.0],
    ));
    t
}

fn state(position: DVec3, velocity: DVec3) -> ViewEntity {
    ViewEntity {
        id: AVATAR,
        position,
        rotation: DQuat::IDENTITY,
        linear_velocity: Some(velocity),
        angular_velocity: None,
        at_rest: false,
    }
}

fn input(tick: u64, movement: [f32; 2], buttons: u8) -> PlayerInput {
    PlayerInput {
        sequence: tick as u32,
        tick,
        payload: SandboxInput {
            movement,
            yaw: 0.0,
            buttons,
        }
        .to_payload(),
        view_behind: 0.0,
    }
}

/// A scripted walk: forwards, a turn, a jump, a stop.
fn script(t: u64) -> PlayerInput {
    match t {
        0..=39 => input(t, [0.0, 1.0], 0),
        40..=79 => input(t, [1.0, 0.0], if (50..55).contains(&t) { 1 } else { 0 }),
        _ => input(t, [0.0, 0.0], 0),
    }
}

fn predictor(table: &KnownEntities) -> Predictor {
    let mut p = Predictor::new(PredictionConfig::default(), CLIENT, 60).unwrap();
    p.on_snapshot(0, &[state(DVec3::new(0.0, 0.9, 0.0), DVec3::ZERO)], table);
    p
}

/// The "server": the same controller run on every input, its state by
/// tick, shifted by `shift(tick)` (as if something the client cannot
/// know had pushed it).
fn server_states(ticks: u64, table: &KnownEntities) -> Vec<(DVec3, DVec3)> {
    let mut s = predictor(table);
    let mut out = vec![(DVec3::new(0.0, 0.9, 0.0), DVec3::ZERO)];
    for t in 0..ticks {
        s.on_input(&script(t));
        let a = s.avatar().unwrap();
        assert_eq!(a.tick, t + 1);
        out.push((a.predicted, a.velocity));
    }
    out
}

/// Runs the client against the server's states shifted by `shift` from
/// tick `from` on, snapshots 6 ticks late every other tick; returns the
/// predictor and the largest per-tick move of the drawn avatar off its
/// predicted motion.
fn run(shift: DVec3, from: u64) -> (Predictor, f64) {
    let table = table();
    let server = server_states(120, &table);
    let mut c = predictor(&table);
    let mut last: Option<PredictedAvatar> = None;
    let mut worst: f64 = 0.0;
    for t in 0..120 {
        c.on_input(&script(t));
        if t >= 6 && t % 2 == 0 {
            let at = t - 6;
            let (p, v) = server[at as usize];
            let p = if at >= from { p + shift } else { p };
            c.on_snapshot(at, &[state(p, v)], &table);
        }
        let a = c.avatar().unwrap();
        if let Some(l) = last {
            let motion = (a.predicted - l.predicted) - (a.corrected - l.corrected);
            worst = worst.max(((a.position - l.position) - motion).length());
        }
        last = Some(a);
    }
    (c, worst)
}

#[test]
fn the_avatar_answers_the_first_input() {
    let table = table();
    let mut p = predictor(&table);
    let before = p.avatar().unwrap();
    p.on_input(&input(0, [1.0, 0.0], 0));
    let after = p.avatar().unwrap();
    assert_eq!(after.tick, 1);
    assert!(after.position.x - before.position.x > 1e-3, "{after:?}");
}

#[test]
fn the_same_inputs_predict_the_server_exactly() {
    let (c, _) = run(DVec3::ZERO, u64::MAX);
    let s = c.stats();
    assert!(s.compared > 40, "{s:?}");
    assert!(s.error_max < 1e-9, "{s:?}");
    assert_eq!(s.corrections, 0, "{s:?}");
}

#[test]
fn replay_after_a_correction_converges_and_the_picture_slides() {
    let shift = DVec3::new(0.3, 0.0, -0.2);
    let (c, worst) = run(shift, 30);
    let s = c.stats();
    // The first shifted state corrects; once replayed from it, the
    // prediction agrees with every later one.
    assert_eq!(s.corrections, 1, "{s:?}");
    assert_eq!(s.teleports, 0, "{s:?}");
    assert!((s.error_max - shift.length()).abs() < 1e-6, "{s:?}");
    assert!(s.error_p50 < 1e-6, "{s:?}");
    // The correction fades: at most (1 − e^(−dt/τ)) of it per tick.
    let bound = shift.length() * (1.0 - (-1.0f64 / 6.0).exp()) + 1e-9;
    assert!(worst <= bound, "{worst} > {bound}");
    assert!(s.snap_max <= bound, "{s:?}");
    // And it is gone from view by the end (1.5 s later).
    let a = c.avatar().unwrap();
    assert!((a.position - a.predicted).length() < 1e-3, "{a:?}");
}

#[test]
fn a_teleport_snaps() {
    let (c, _) = run(DVec3::new(0.0, 0.0, 8.0), 30);
    let s = c.stats();
    assert_eq!((s.corrections, s.teleports), (1, 1), "{s:?}");
    assert_eq!(s.snap_max, 0.0, "a snap is no slide: {s:?}");
    let a = c.avatar().unwrap();
    assert_eq!(a.position, a.predicted);
}

#[test]
fn inputs_are_forgotten_once_a_snapshot_covers_them() {
    let table = table();
    let mut c = predictor(&table);
    for t in 0..20 {
        c.on_input(&script(t));
    }
    assert_eq!(c.inputs_held(), 20);
    let s = server_states(20, &table);
    let (p, v) = s[12];
    c.on_snapshot(12, &[state(p, v)], &table);
    assert_eq!(c.inputs_held(), 8, "ticks 12 to 19 wait for the server");
    assert_eq!(c.avatar().unwrap().tick, 20);
}

/// A game's own avatar: a ball rolled by a 2-byte stick, and a memory of
/// how many ticks it has been pushed (to see a correction put it back).
#[derive(Debug, Default)]
struct Roller {
    pushed: u64,
}

impl AvatarController for Roller {
    fn body(&self, at: DVec3) -> Result<RigidBodyDesc, PredictionError> {
        Ok(RigidBodyDesc::dynamic(
            Shape::sphere(0.5)?,
            200.0,
            Pose::from_translation(at),
        )?)
    }

    fn control(&mut self, step: ControlStep<'_>) {
        let bytes = step.input.as_bytes();
        let [x, z] =
            [bytes.first(), bytes.get(1)].map(|b| f64::from(b.copied().unwrap_or(0) as i8));
        if x != 0.0 || z != 0.0 {
            self.pushed += 1;
        }
        let _ = step
            .world
            .set_body_control(step.avatar, DVec3::new(x, 0.0, z) * 20.0, DVec3::ZERO);
    }

    fn memory(&self) -> Vec<u8> {
        self.pushed.to_le_bytes().to_vec()
    }

    fn recall(&mut self, memory: &[u8]) {
        self.pushed = memory.try_into().map_or(0, u64::from_le_bytes);
    }
}

#[test]
fn issue_43_a_games_own_controller_predicts_its_own_input() {
    let table = table();
    let mut p = Predictor::with_controller(
        PredictionConfig::default(),
        Box::new(Roller::default()),
        CLIENT,
        60,
    )
    .unwrap();
    p.on_snapshot(0, &[state(DVec3::new(0.0, 0.5, 0.0), DVec3::ZERO)], &table);
    // The game's own bytes: the stick right, for half a second.
    for t in 0..30 {
        p.on_input(&PlayerInput {
            sequence: t as u32,
            tick: t,
            payload: inertia_protocol::input::InputPayload::new(&[100, 0]).unwrap(),
            view_behind: 0.0,
        });
    }
    let a = p.avatar().expect("predicted");
    assert_eq!(a.tick, 30);
    assert!(a.predicted.x > 0.5, "rolled right: {}", a.predicted);
    assert!(a.predicted.z.abs() < 1e-6, "{}", a.predicted);
    // The server saw it elsewhere at tick 10: the prediction replays the
    // inputs from there, with the controller's memory as of tick 10.
    p.on_snapshot(
        10,
        &[state(DVec3::new(-3.0, 0.5, 0.0), DVec3::ZERO)],
        &table,
    );
    let b = p.avatar().expect("predicted");
    assert_eq!(b.tick, 30);
    assert!(
        b.predicted.x < a.predicted.x - 2.0,
        "{} then {}",
        a.predicted,
        b.predicted
    );
}
