//! Inputs are applied on the tick they are for, so an avatar moves the
//! same way whatever jitter the network added to its inputs.
//!
//! The test drives the server's own parts as the server runs them: each
//! input datagram (the last eight inputs, as the SDK sends them) reaches
//! the client's `InputBuffer` at its arrival time, the buffer hands the
//! inputs on in order, and the simulation takes them between ticks. The
//! same script of inputs, stamped a lead ahead of the server, is run over
//! a steady link and over a jittery one: the avatar's path is the same to
//! the bit. Stamped with the tick they arrive at instead (what applying
//! inputs on arrival amounts to), the two paths part.

use inertia_physics::glam::DVec3;
use inertia_protocol::input::GameInput;
use inertia_protocol::input::{InputBuffer, InputDatagram, MAX_REDUNDANT_INPUTS};
use inertia_protocol::rng::SplitMix;
use inertia_protocol::PlayerInput;
use inertia_sandbox::{buttons, SandboxInput};
use inertia_server::rules::SandboxRules;
use inertia_server::scene::{Scene, SceneFormat};
use inertia_server::sim::{SimConfig, Simulation};

const FLAT: &str = r#"(
    spawn_points: [(0.0, 1.0, 0.0)],
    bodies: [
        (name: "ground", kind: Static, shape: Cuboid(half_extents: (50.0, 0.5, 50.0)), position: (0.0, -0.5, 0.0)),
        (name: "crate", shape: Cuboid(half_extents: (0.4, 0.4, 0.4)), position: (2.0, 0.4, 3.0), density: 200.0),
    ],
)"#;

const CLIENT: u64 = 7;
/// Ticks of scripted input.
const SCRIPT_TICKS: u64 = 300;
/// How far ahead of the server the client stamps its inputs, ticks.
const LEAD: u64 = 8;

/// The player's input for script tick `k`: a walk that turns every 25
/// ticks, a jump every 70 and a push every 90.
fn scripted(k: u64) -> ([f32; 2], f32, u8) {
    let leg = (k / 25) as f32;
    let movement = [(leg * 1.3).cos(), (leg * 1.3).sin()];
    let mut pressed = 0;
    if k % 70 < 3 {
        pressed |= buttons::JUMP;
    }
    if k % 90 < 2 {
        pressed |= buttons::PUSH;
    }
    (movement, leg * 0.7, pressed)
}

/// How the inputs are stamped.
#[derive(Clone, Copy)]
enum Stamp {
    /// With the tick they are for: the script's tick, a lead ahead.
    Ahead,
    /// With the tick at which they arrive: applied on arrival.
    OnArrival,
}

/// Runs the script over a link whose one-way delay is `base` ticks plus
/// up to `jitter` ticks at random, and returns the avatar's position
/// after each tick, with the server's count of late inputs.
fn run(base: f64, jitter: f64, stamp: Stamp, seed: u64) -> (Vec<DVec3>, u64) {
    let built = Scene::parse(FLAT, SceneFormat::Ron)
        .unwrap()
        .build()
        .unwrap();
    let mut sim = Simulation::new(
        built,
        Box::new(SandboxRules::default()),
        SimConfig::default(),
    );
    let avatar = sim.join(CLIENT).unwrap();
    sim.run_ticks(60);
    // The script starts a lead after now, when its first input is made.
    let start = sim.world().tick() + LEAD;

    // Input k is for tick start + k and made (sent) when the server is at
    // start + k − LEAD; its datagram carries it and the seven before it.
    let mut rng = SplitMix(seed);
    let mut made: Vec<PlayerInput> = Vec::new();
    let mut in_flight: Vec<(f64, InputDatagram)> = Vec::new();
    let mut buffer = InputBuffer::new(256);
    let mut path = Vec::new();
    let last_send = start + SCRIPT_TICKS - LEAD;
    for now in start - LEAD..start + SCRIPT_TICKS + 20 {
        assert_eq!(sim.world().tick(), now);
        if now <= last_send {
            let k = now + LEAD - start;
            let (movement, yaw, pressed) = scripted(k);
            made.push(PlayerInput {
                sequence: k as u32 + 1,
                tick: start + k,
                payload: SandboxInput {
                    movement,
                    yaw,
                    buttons: pressed,
                }
                .to_payload(),
                view_behind: 0.0,
            });
            let delay = base + jitter * rng.uniform();
            let inputs = made
                .iter()
                .rev()
                .take(MAX_REDUNDANT_INPUTS)
                .copied()
                .collect();
            in_flight.push((
                now as f64 + delay,
                InputDatagram {
                    ack: None,
                    ack_bits: 0,
                    inputs,
                },
            ));
        }
        // Everything that arrived before this tick, in order of arrival.
        in_flight.sort_by(|a, b| a.0.total_cmp(&b.0));
        let arrived = in_flight.partition_point(|(at, _)| *at < now as f64);
        for (_, datagram) in in_flight.drain(..arrived) {
            let bytes = datagram.encode().unwrap();
            buffer.push_datagram(&InputDatagram::decode(&bytes).unwrap());
            while let Some(mut input) = buffer.pop() {
                if let Stamp::OnArrival = stamp {
                    input.tick = sim.world().tick();
                }
                let _ = sim.input(CLIENT, &input);
            }
        }
        sim.run_ticks(1);
        if sim.world().tick() > start {
            let h = sim.entities().body(avatar).unwrap();
            path.push(sim.world().body(h).unwrap().center_of_mass());
        }
    }
    let late = sim.input_timing(CLIENT).unwrap().late;
    (path, late)
}

fn largest_gap(a: &[DVec3], b: &[DVec3]) -> f64 {
    a.iter()
        .zip(b)
        .map(|(p, q)| p.distance(*q))
        .fold(0.0, f64::max)
}

#[test]
fn issue_17_inputs_on_their_tick_move_an_avatar_the_same_way_whatever_the_jitter() {
    // 3 ticks (50 ms) each way, then 2 to 7 ticks: within the lead of 8.
    let (steady, steady_late) = run(3.0, 0.0, Stamp::Ahead, 1);
    let (jittery, jittery_late) = run(2.0, 5.0, Stamp::Ahead, 2);
    assert_eq!((steady_late, jittery_late), (0, 0), "every input on time");
    let travelled = steady.first().unwrap().distance(*steady.last().unwrap());
    assert!(travelled > 5.0, "the avatar walked {travelled} m");
    assert_eq!(steady.len(), jittery.len());
    let gap = largest_gap(&steady, &jittery);
    println!(
        "on their tick: {} ticks, walked {travelled:.2} m; largest gap between the steady and the jittery run {gap} m",
        steady.len()
    );
    assert_eq!(steady, jittery, "the same path to the bit");

    // Applied when they arrive, the same inputs make another path.
    let (steady, _) = run(3.0, 0.0, Stamp::OnArrival, 1);
    let (jittery, _) = run(2.0, 5.0, Stamp::OnArrival, 2);
    let gap = largest_gap(&steady, &jittery);
    println!("on arrival: largest gap between the two runs {gap:.3} m");
    assert!(
        gap > 0.05,
        "jitter moves an avatar driven on arrival: {gap} m"
    );
}

#[test]
fn issue_17_late_inputs_are_applied_at_once_and_counted() {
    // Up to 12 ticks of delay against a lead of 8: some arrive late.
    let (path, late) = run(2.0, 10.0, Stamp::Ahead, 3);
    assert!(late > 0, "some inputs were late");
    assert!(late < SCRIPT_TICKS, "{late} late");
    let travelled = path.first().unwrap().distance(*path.last().unwrap());
    assert!(
        travelled > 5.0,
        "late inputs still move the avatar: {travelled} m"
    );
    println!("{late} of {SCRIPT_TICKS} inputs late, applied at once");
}
